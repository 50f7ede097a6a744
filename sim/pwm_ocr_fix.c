/* Apply OCR writes at BOTTOM by replaying the TCCRnB write (see the header). */
#include "pwm_ocr_fix.h"

#include <string.h>

#include "sim_io.h"

static avr_cycle_count_t pwm_ocr_fix_apply(avr_t *avr, avr_cycle_count_t when, void *param)
{
	(void)when;
	pwm_ocr_fix_t *f = (pwm_ocr_fix_t *)param;
	f->pending = 0;
	avr_io_addr_t io = AVR_DATA_TO_IO(f->tccrb);
	/* simavr reconfigures only when the clock or mode bits change: stop the clock
	 * (CSn2:0 = 0), then restore it */
	uint8_t v = avr->data[f->tccrb];
	if (avr->io[io].w.c) {
		avr->io[io].w.c(avr, f->tccrb, (uint8_t)(v & ~0x07u), avr->io[io].w.param);
		avr->io[io].w.c(avr, f->tccrb, v, avr->io[io].w.param);
	}
	return 0;
}

static void pwm_ocr_fix_write(struct avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
	pwm_ocr_fix_t *f = (pwm_ocr_fix_t *)param;
	avr_core_watch_write(avr, addr, v);
	if (f->bypass && *f->bypass)
		return;
	avr_timer_t *t = f->timer;
	if (f->pending || t->tov_cycles == 0)
		return; /* stopped: the next TCCR write picks the value up */
	avr_cycle_count_t bottom = t->tov_base + t->tov_cycles;
	while (bottom <= avr->cycle)
		bottom += t->tov_cycles;
	f->pending = 1;
	avr_cycle_timer_register(avr, bottom + 1 - avr->cycle, pwm_ocr_fix_apply, f);
}

int pwm_ocr_fix_attach(avr_t *avr, pwm_ocr_fix_t *f, char timer_name, avr_io_addr_t tccrb)
{
	memset(f, 0, sizeof(*f));
	f->avr = avr;
	f->tccrb = tccrb;
	for (avr_io_t *io = avr->io_port; io; io = io->next) {
		if (io->kind && strcmp(io->kind, "timer") == 0 &&
				((avr_timer_t *)io)->name == timer_name) {
			f->timer = (avr_timer_t *)io;
			break;
		}
	}
	if (!f->timer)
		return -1;
	for (int c = 0; c < 2; c++)
		if (f->timer->comp[c].r_ocr)
			avr_register_io_write(avr, f->timer->comp[c].r_ocr, pwm_ocr_fix_write, f);
	return 0;
}

void pwm_ocr_fix_restart(pwm_ocr_fix_t *f)
{
	f->pending = 0;
}
