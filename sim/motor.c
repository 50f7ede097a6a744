/* MD20A + motor part: PWM/DIR pins in, physics on a cycle timer. */
#include "motor.h"

#include <stddef.h>

#include "sim_time.h"

static const char *motor_irq_names[IRQ_MOTOR_COUNT] = {
	[IRQ_MOTOR_PWM_IN] = "<motor.pwm",
	[IRQ_MOTOR_DIR_IN] = "<motor.dir",
};

static void motor_pwm_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	motor_t *m = (motor_t *)param;
	int level = value != 0;
	avr_cycle_count_t now = m->avr->cycle;
	if (level == m->pwm_level)
		return;
	if (m->pwm_level && now > m->mark)
		m->high_cycles += now - m->mark;
	m->mark = now;
	m->pwm_level = level;
	m->last_edge = now;
	if (level) {
		if (m->last_rise && now > m->last_rise) {
			avr_cycle_count_t high = m->last_fall > m->last_rise ? m->last_fall - m->last_rise : 0;
			if (m->ring_n == 16) {
				m->ring_pos = (m->ring_pos + 1) % 16;
			} else {
				m->ring_n++;
			}
			unsigned i = (m->ring_pos + m->ring_n - 1) % 16;
			m->ring_high[i] = high;
			m->ring_period[i] = now - m->last_rise;
			m->period_hz = m->avr->frequency / (double)(now - m->last_rise);
		}
		m->last_rise = now;
	} else {
		m->last_fall = now;
	}
}

static void motor_dir_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	motor_t *m = (motor_t *)param;
	m->dir_level = value != 0;
}

static avr_cycle_count_t motor_step_timer(avr_t *avr, avr_cycle_count_t when, void *param)
{
	motor_t *m = (motor_t *)param;
	avr_cycle_count_t now = avr->cycle;

	if (m->pwm_level && now > m->mark)
		m->high_cycles += now - m->mark;
	m->mark = now;
	if (m->pwm && m->pwm->active)
		m->high_cycles = pwm_model_take_high(m->pwm, now);
	avr_cycle_count_t window = now > m->window_start ? now - m->window_start : 1;
	double duty = (double)m->high_cycles / (double)window;
	if (duty > 1)
		duty = 1;
	m->high_cycles = 0;
	m->window_start = now;
	m->step_duty = duty;

	/* The MD20A connects the motor to the pack while PWM is high and shorts it (brake)
	 * while low: the average terminal voltage is duty * supply, signed by DIR. */
	double sign = m->dir_level ? 1.0 : -1.0;
	m->battery_v = battery_terminal_v(m->battery, m->battery_current_a);
	double v_motor = sign * duty * m->battery_v;
	double angle_from = m->model.angle_rad;
	motor_model_step(&m->model, v_motor, m->step_s);
	/* the pack supplies the motor current only while PWM is high */
	m->battery_current_a = duty * sign * m->model.current_a;
	battery_draw(m->battery, m->battery_current_a, m->step_s);
	if (m->hook)
		m->hook(m->hook_ctx, when, when + m->step_cycles, angle_from, m->model.angle_rad,
				m->battery_current_a, m->battery_v, m->step_s);
	return when + m->step_cycles;
}

void motor_init(avr_t *avr, motor_t *m, const motor_params_t *p, battery_t *battery,
		double step_s)
{
	m->avr = avr;
	m->irq = avr_alloc_irq(&avr->irq_pool, 0, IRQ_MOTOR_COUNT, motor_irq_names);
	motor_model_init(&m->model, p);
	m->battery = battery;
	m->step_s = step_s;
	m->step_cycles = (avr_cycle_count_t)(step_s * avr->frequency + 0.5);
	m->pwm_level = m->dir_level = 0;
	m->window_start = m->mark = m->high_cycles = 0;
	m->last_rise = m->last_fall = m->last_edge = 0;
	m->ring_pos = m->ring_n = 0;
	m->period_hz = 0;
	m->step_duty = 0;
	m->battery_current_a = 0;
	m->battery_v = battery_terminal_v(battery, 0);
	m->hook = NULL;
	m->hook_ctx = NULL;
	m->pwm = NULL;
	avr_irq_register_notify(m->irq + IRQ_MOTOR_PWM_IN, motor_pwm_hook, m);
	avr_irq_register_notify(m->irq + IRQ_MOTOR_DIR_IN, motor_dir_hook, m);
}

void motor_attach(motor_t *m, avr_irq_t *pwm_pin, avr_irq_t *dir_pin)
{
	avr_connect_irq(pwm_pin, m->irq + IRQ_MOTOR_PWM_IN);
	avr_connect_irq(dir_pin, m->irq + IRQ_MOTOR_DIR_IN);
	motor_start(m);
}

void motor_use_pwm_model(motor_t *m, pwm_model_t *pwm)
{
	m->pwm = pwm;
}

void motor_set_hook(motor_t *m, motor_step_hook_t hook, void *ctx)
{
	m->hook = hook;
	m->hook_ctx = ctx;
}

void motor_start(motor_t *m)
{
	/* after a reset the pins are inputs: the MD20A sees PWM low (brake) */
	m->pwm_level = 0;
	m->dir_level = 0;
	m->window_start = m->mark = m->avr->cycle;
	m->high_cycles = 0;
	m->step_cycles = (avr_cycle_count_t)(m->step_s * m->avr->frequency + 0.5);
	avr_cycle_timer_cancel(m->avr, motor_step_timer, m);
	avr_cycle_timer_register(m->avr, m->step_cycles, motor_step_timer, m);
}

void motor_set_load(motor_t *m, double load_nm)
{
	m->model.load_nm = load_nm;
}

double motor_pwm_quiet_s(const motor_t *m)
{
	avr_cycle_count_t quiet = m->pwm && m->pwm->active ? pwm_model_quiet(m->pwm, m->avr->cycle)
			: m->avr->cycle - m->last_edge;
	return (double)quiet / (double)m->avr->frequency;
}

double motor_pwm_duty(const motor_t *m)
{
	if (m->pwm && m->pwm->active)
		return pwm_model_duty(m->pwm);
	avr_cycle_count_t quiet = avr_usec_to_cycles(m->avr, 4000);
	if (m->avr->cycle - m->last_edge > quiet || m->ring_n == 0)
		return m->pwm_level ? 1.0 : 0.0;
	avr_cycle_count_t high = 0, total = 0;
	for (unsigned i = 0; i < m->ring_n; i++) {
		high += m->ring_high[i];
		total += m->ring_period[i];
	}
	return total ? (double)high / (double)total : 0.0;
}
