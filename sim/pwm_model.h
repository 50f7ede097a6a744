/*
 * pwm_model: Timer1's fast PWM on OC1A (PB1) computed from its registers instead of stepped
 * by simavr. simavr's timer wakes the simulation at every compare match and overflow (32 000
 * events a second at 16 kHz) and raises the pin each time, for a waveform whose only
 * observer is the motor part, which wants the share of each physics step the pin was high.
 * This part keeps simavr's Timer1 stopped and gives that share exactly: in mode 14 (TOP =
 * ICR1) with COM1A = 2 the pin is high for OCR1A + 1 of every ICR1 + 1 counts from BOTTOM;
 * OCR1A writes are double-buffered to the next BOTTOM, as on the chip; with COM1A = 0 the pin
 * is PORTB1. It stands in only for what the firmware uses: Timer1 interrupts (TIMSK1), a
 * TCNT1 read or another mode end the model (a message says so) and hand Timer1 back to
 * simavr, edges and all. simmod's `exact_pwm` option keeps simavr's timer from the start.
 */
#ifndef AUGER_SIM_PWM_MODEL_H
#define AUGER_SIM_PWM_MODEL_H

#include "avr_timer.h"
#include "sim_avr.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct pwm_model_t {
	avr_t *avr;
	avr_timer_t *timer;      /* simavr's Timer1, kept stopped */
	int active;              /* 0: simavr runs Timer1 (never engaged, or given back) */
	/* waveform */
	int running;             /* mode 14, clock on, no prescaler other than the CS value */
	int connected;           /* COM1A1:0 = 2: OC1A drives the pin */
	int port_level;          /* PORTB1 */
	avr_cycle_count_t prescale;      /* the clock's divider */
	avr_cycle_count_t period_cycles; /* (ICR1 + 1) x prescaler */
	avr_cycle_count_t high_cycles;   /* (OCR1A + 1) x prescaler, at most the period */
	avr_cycle_count_t t0;    /* a BOTTOM: periods start at t0 + k period */
	uint16_t ocr_pending;    /* written OCR1A, applied at the next BOTTOM */
	int pending;
	avr_cycle_count_t pending_at;
	/* integral of the pin level from `mark` on */
	avr_cycle_count_t mark;
	avr_cycle_count_t high_acc;
	avr_cycle_count_t last_change; /* last edge outside the periodic ones (quiet time) */
	avr_io_read_t tcnt_read;       /* simavr's TCNT1 reader, for when the model lets go */
	void *tcnt_param;
	/* the handlers this part wraps (simavr shares few registers between handlers) */
	struct {
		avr_io_addr_t addr;
		avr_io_write_t c;
		void *param;
	} wrapped[6];
} pwm_model_t;

/* Hooks Timer1's registers and PORTB. Returns 0, or -1 without a Timer1. */
int pwm_model_attach(avr_t *avr, pwm_model_t *p);
/* After an avr_reset: the registers are cleared, the pin is an input (low). */
void pwm_model_restart(pwm_model_t *p);
/* Cycles the pin was high from the previous call (or restart) up to `now`. */
avr_cycle_count_t pwm_model_take_high(pwm_model_t *p, avr_cycle_count_t now);
/* Duty of the waveform in force (0..1): what 16 periods of edges would average. */
double pwm_model_duty(const pwm_model_t *p);
/* Cycles since the pin last changed level, as of `now`. */
avr_cycle_count_t pwm_model_quiet(const pwm_model_t *p, avr_cycle_count_t now);

#ifdef __cplusplus
}
#endif
#endif
