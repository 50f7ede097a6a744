/* Brushed DC motor + gearbox + screw: docs/simulator.md lists the equations. */
#include "motor_model.h"

#include <math.h>

#define TWO_PI 6.283185307179586
#define RPM_PER_RAD_S (60.0 / TWO_PI)

void motor_params_default(motor_params_t *p)
{
	p->rated_v = 12.0;
	p->no_load_out_rpm = 23.0;
	p->no_load_current_a = 0.52;
	p->stall_current_a = 20.0;
	p->gear_ratio = 369.0;
	p->gear_efficiency = 0.7;
	p->inductance_h = 0.5e-3;
	p->rotor_inertia_kg_m2 = 3e-6;
	/* 6 kg module, screw radius 0.0775 m: a thin-walled drum of about 3 kg carrying it
	 * gives m r^2 ~ 0.018 kg m^2. */
	p->screw_inertia_kg_m2 = 0.018;
	p->coulomb_share = 0.5;
	motor_params_derive(p);
}

void motor_params_derive(motor_params_t *p)
{
	double omega0 = p->no_load_out_rpm * p->gear_ratio / RPM_PER_RAD_S;
	p->resistance_ohm = p->rated_v / p->stall_current_a;
	/* no load: V = R I0 + ke w0 */
	p->ke_v_s_per_rad = (p->rated_v - p->resistance_ohm * p->no_load_current_a) / omega0;
	/* no load: kt I0 = Tc + b w0 */
	double friction_nm = p->ke_v_s_per_rad * p->no_load_current_a;
	p->coulomb_nm = p->coulomb_share * friction_nm;
	p->viscous_nm_s_per_rad = (1.0 - p->coulomb_share) * friction_nm / omega0;
	p->inertia_kg_m2 = p->rotor_inertia_kg_m2 +
			p->screw_inertia_kg_m2 / (p->gear_ratio * p->gear_ratio);
}

void motor_model_init(motor_model_t *m, const motor_params_t *p)
{
	m->p = *p;
	m->angle_rad = 0;
	m->omega_rad_s = 0;
	m->current_a = 0;
	m->load_nm = 0;
	m->load_viscous_nm_per_rpm = 0;
	m->locked = 0;
}

static double sgn(double x)
{
	return (x > 0) - (x < 0);
}

void motor_model_step(motor_model_t *m, double v_motor, double dt_s)
{
	const motor_params_t *p = &m->p;
	const double k = p->ke_v_s_per_rad;
	const double r = p->resistance_ohm;
	const double j = p->inertia_kg_m2;
	const double load_m = m->load_nm / (p->gear_ratio * p->gear_efficiency);
	/* the passive load as a viscous term at the motor shaft: T_out = b omega_out_rpm */
	const double viscous = p->viscous_nm_s_per_rad + m->load_viscous_nm_per_rpm * RPM_PER_RAD_S /
			(p->gear_ratio * p->gear_ratio * p->gear_efficiency);
	const double w = m->omega_rad_s;
	double w_new;

	if (p->inductance_h > 0) {
		/* exact for constant v and w over the step: i -> (v - k w)/R with tau L/R */
		double i_ss = (v_motor - k * w) / r;
		double decay = exp(-dt_s * r / p->inductance_h);
		m->current_a = i_ss + (m->current_a - i_ss) * decay;
		double drive = k * m->current_a - load_m;
		if (w == 0 && fabs(drive) <= p->coulomb_nm) {
			w_new = 0; /* static friction holds */
		} else {
			double dir = w != 0 ? sgn(w) : sgn(drive);
			w_new = w + dt_s / j * (drive - viscous * w - p->coulomb_nm * dir);
			if (w != 0 && sgn(w_new) != sgn(w))
				w_new = 0;
		}
	} else {
		/* quasi-static current: i = (v - k w)/R; the electrical damping k^2/R is the
		 * stiff term, so it and the viscous term are taken implicitly. */
		double drive0 = k * v_motor / r - load_m; /* torque at w = 0 */
		if (w == 0 && fabs(drive0) <= p->coulomb_nm) {
			w_new = 0;
		} else {
			double dir = w != 0 ? sgn(w) : sgn(drive0);
			double damp = viscous + k * k / r;
			w_new = (w + dt_s / j * (drive0 - p->coulomb_nm * dir)) / (1.0 + dt_s / j * damp);
			if (w != 0 && sgn(w_new) != sgn(w))
				w_new = 0;
		}
		if (m->locked)
			w_new = 0;
		m->current_a = (v_motor - k * w_new) / r;
	}
	if (m->locked)
		w_new = 0;
	m->angle_rad += 0.5 * (w + w_new) * dt_s;
	m->omega_rad_s = w_new;
}

double motor_model_out_angle_rad(const motor_model_t *m)
{
	return m->angle_rad / m->p.gear_ratio;
}

double motor_model_out_rpm(const motor_model_t *m)
{
	return m->omega_rad_s / m->p.gear_ratio * RPM_PER_RAD_S;
}

double motor_model_stall_out_nm(const motor_params_t *p, double v)
{
	double motor_nm = p->ke_v_s_per_rad * v / p->resistance_ohm - p->coulomb_nm;
	return motor_nm * p->gear_ratio * p->gear_efficiency;
}
