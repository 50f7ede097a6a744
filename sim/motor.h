/*
 * motor: simavr part for the MD20A driver + motor + gearbox + screw of one module.
 * Inputs are the driver's PWM and DIR pins (IRQ_MOTOR_PWM_IN, IRQ_MOTOR_DIR_IN, wired by
 * the board to PB1 and PB0). The duty is measured from the PWM pin's edges (the high
 * time inside each physics step), the physics (motor_model.c) runs on a cycle timer
 * every step_s of simulated time, and a hook hands each step's shaft trajectory to the
 * encoder and the current to the INA219.
 */
#ifndef AUGER_SIM_MOTOR_H
#define AUGER_SIM_MOTOR_H

#include "sim_avr.h"
#include "sim_irq.h"

#include "battery.h"
#include "motor_model.h"
#include "pwm_model.h"

#ifdef __cplusplus
extern "C" {
#endif

enum {
	IRQ_MOTOR_PWM_IN = 0,
	IRQ_MOTOR_DIR_IN,
	IRQ_MOTOR_COUNT
};

/* Called after each physics step: the shaft moves from angle_from to angle_to (motor
 * shaft, rad) between cycles from and to; battery current and terminal voltage. */
typedef void (*motor_step_hook_t)(void *ctx, avr_cycle_count_t from, avr_cycle_count_t to,
		double angle_from_rad, double angle_to_rad, double battery_current_a,
		double battery_v, double dt_s);

typedef struct motor_t {
	avr_irq_t *irq;
	avr_t *avr;
	motor_model_t model;
	battery_t *battery;
	double step_s;
	avr_cycle_count_t step_cycles;

	int pwm_level, dir_level;
	avr_cycle_count_t window_start, mark, high_cycles;
	avr_cycle_count_t last_rise, last_fall, last_edge;
	/* the last MOTOR_DUTY_PERIODS complete PWM periods: high and total cycles */
	avr_cycle_count_t ring_high[16], ring_period[16];
	unsigned ring_pos, ring_n;
	double period_hz;

	double step_duty;         /* high fraction of the last physics step */
	double battery_current_a; /* average over the last step */
	double battery_v;
	motor_step_hook_t hook;
	void *hook_ctx;
	pwm_model_t *pwm; /* while it is active, the PWM pin's high time comes from it */
} motor_t;

void motor_init(avr_t *avr, motor_t *m, const motor_params_t *p, battery_t *battery,
		double step_s);
/* Wire the PWM and DIR pins (ioport pin IRQs) to the part. */
void motor_attach(motor_t *m, avr_irq_t *pwm_pin, avr_irq_t *dir_pin);
void motor_set_hook(motor_t *m, motor_step_hook_t hook, void *ctx);
/* Take the PWM pin's waveform from Timer1's registers (pwm_model.h) instead of its edges. */
void motor_use_pwm_model(motor_t *m, pwm_model_t *pwm);
/* (Re)start the physics timer: at attach time and after every avr_reset. */
void motor_start(motor_t *m);
/* Load torque on the screw, N m, opposing positive rotation when positive. */
void motor_set_load(motor_t *m, double load_nm);
/* Duty measured over the last 16 complete PWM periods (simavr changes the pin when it
 * processes its timers, up to an instruction late: averaging removes that jitter), 0..1,
 * or the pin level after 4 ms without an edge. */
double motor_pwm_duty(const motor_t *m);
/* Seconds since the PWM pin last changed level. */
double motor_pwm_quiet_s(const motor_t *m);

#ifdef __cplusplus
}
#endif
#endif
