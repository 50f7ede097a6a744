/*
 * pwm_ocr_fix: work around simavr 1.6's timers, which read OCRnx only when the timer is
 * (re)configured (a write to TCCRnA/B): in PWM modes a later OCR write changes nothing on
 * the pin. The real chip double-buffers OCRnx and applies it at BOTTOM; this watches the
 * OCR writes and, at the next BOTTOM (+1 cycle), stops and restarts the timer clock through TCCRnB so simavr
 * reconfigures with the new value. Measured: without it, a duty written after the timer
 * started never reaches PB1 (tests/sim "PWM duty ..." fails).
 */
#ifndef AUGER_SIM_PWM_OCR_FIX_H
#define AUGER_SIM_PWM_OCR_FIX_H

#include "avr_timer.h"
#include "sim_avr.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct pwm_ocr_fix_t {
	avr_t *avr;
	avr_timer_t *timer;
	avr_io_addr_t tccrb;
	int pending;
	const int *bypass; /* while *bypass is set, another part runs the timer's output */
} pwm_ocr_fix_t;

/* Watch the timer's OCRnA/OCRnB low bytes (the bytes whose write completes a 16-bit
 * write). 0, or -1 when the timer is not found. */
int pwm_ocr_fix_attach(avr_t *avr, pwm_ocr_fix_t *f, char timer_name, avr_io_addr_t tccrb);
/* After avr_reset (cycle timers cleared). */
void pwm_ocr_fix_restart(pwm_ocr_fix_t *f);

#ifdef __cplusplus
}
#endif
#endif
