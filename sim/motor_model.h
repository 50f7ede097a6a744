/*
 * motor_model: brushed DC motor + planetary gearbox + screw, the physics behind the
 * simulated module's motor (sim/motor.c drives it from the PWM and DIR pins). No simavr
 * dependency, so tests/sim/test_motor_model.cpp checks it alone. Parameters and their
 * sources: docs/simulator.md.
 */
#ifndef AUGER_SIM_MOTOR_MODEL_H
#define AUGER_SIM_MOTOR_MODEL_H

#ifdef __cplusplus
extern "C" {
#endif

/* What the datasheets (or estimates) give; motor_params_derive() turns them into the
 * physical constants below. */
typedef struct motor_params_t {
	double rated_v;                /* motor rating: 12 V */
	double no_load_out_rpm;        /* output shaft no-load speed at rated_v: 23 rpm */
	double no_load_current_a;      /* current at no load, rated_v (estimate) */
	double stall_current_a;        /* current at stall, rated_v (estimate, ~20 A) */
	double gear_ratio;             /* motor turns per output turn (~369, estimate) */
	double gear_efficiency;        /* load torque reaches the motor divided by ratio*eff */
	double inductance_h;           /* armature inductance; 0 = quasi-static current */
	double rotor_inertia_kg_m2;    /* motor rotor (estimate) */
	double screw_inertia_kg_m2;    /* screw about its axis, seen at the output shaft */
	double coulomb_share;          /* share of the no-load friction that is Coulomb */
	/* derived by motor_params_derive() */
	double resistance_ohm;         /* rated_v / stall_current_a */
	double ke_v_s_per_rad;         /* back-EMF constant = torque constant kt (SI) */
	double coulomb_nm;             /* Coulomb friction at the motor shaft */
	double viscous_nm_s_per_rad;   /* viscous friction at the motor shaft */
	double inertia_kg_m2;          /* total inertia at the motor shaft */
} motor_params_t;

typedef struct motor_model_t {
	motor_params_t p;
	double angle_rad;      /* motor shaft angle (encoder side) */
	double omega_rad_s;    /* motor shaft speed */
	double current_a;      /* armature current, sign of the motor's positive direction */
	double load_nm;        /* load torque on the screw (output), opposes positive rotation */
	double load_viscous_nm_per_rpm; /* passive load on the screw: opposes its speed (tests) */
	int locked;            /* the screw cannot turn (a rotor held in rock; tests) */
} motor_model_t;

/* The defaults of docs/simulator.md, derived. */
void motor_params_default(motor_params_t *p);
/* Recompute the derived constants after changing a datasheet-level field. */
void motor_params_derive(motor_params_t *p);

void motor_model_init(motor_model_t *m, const motor_params_t *p);
/* Advance dt_s with terminal voltage v_motor (already duty * direction * supply: with the
 * MD20A braking while PWM is low, the average terminal voltage is duty * supply). */
void motor_model_step(motor_model_t *m, double v_motor, double dt_s);

/* Output (screw) shaft. */
double motor_model_out_angle_rad(const motor_model_t *m);
double motor_model_out_rpm(const motor_model_t *m);
/* Stall torque at the output for a terminal voltage (gear efficiency included). */
double motor_model_stall_out_nm(const motor_params_t *p, double v);

#ifdef __cplusplus
}
#endif
#endif
