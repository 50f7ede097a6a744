/* Timer1's fast PWM on OC1A from its registers; see the header. */
#include "pwm_model.h"

#include <stdio.h>
#include <string.h>

#include "sim_io.h"

/* ATmega328P data-space addresses */
#define R_TIMSK1 0x6F
#define R_TCCR1A 0x80
#define R_TCCR1B 0x81
#define R_TCNT1L 0x84
#define R_ICR1L 0x86
#define R_ICR1H 0x87
#define R_OCR1AL 0x88
#define R_OCR1AH 0x89
#define R_PORTB 0x25
#define PORTB_PWM_BIT 1 /* PB1 = OC1A */
#define MODE_FAST_PWM_ICR 14

static const uint16_t prescaler_of_cs[8] = { 0, 1, 8, 64, 256, 1024, 0, 0 };

static int toggling(const pwm_model_t *p)
{
	return p->running && p->connected && p->high_cycles < p->period_cycles;
}

/* Pin level at t under the waveform in force (t at or after t0 when running). */
static int level_at(const pwm_model_t *p, avr_cycle_count_t t)
{
	if (!p->connected)
		return p->port_level;
	if (!p->running)
		return p->port_level;
	if (p->high_cycles >= p->period_cycles)
		return 1;
	return (t - p->t0) % p->period_cycles < p->high_cycles;
}

/* High cycles of the periodic waveform from t0 to t. */
static avr_cycle_count_t periodic_high(const pwm_model_t *p, avr_cycle_count_t t)
{
	avr_cycle_count_t d = t - p->t0, k = d / p->period_cycles, r = d % p->period_cycles;
	return k * p->high_cycles + (r < p->high_cycles ? r : p->high_cycles);
}

/* The last edge of the periodic waveform at or before t. */
static avr_cycle_count_t periodic_last_edge(const pwm_model_t *p, avr_cycle_count_t t)
{
	avr_cycle_count_t start = p->t0 + (t - p->t0) / p->period_cycles * p->period_cycles;
	return t - start >= p->high_cycles ? start + p->high_cycles : start;
}

/* Integrate the pin from mark to t under the waveform in force. */
static void integrate(pwm_model_t *p, avr_cycle_count_t t)
{
	if (t <= p->mark)
		return;
	if (toggling(p))
		p->high_acc += periodic_high(p, t) - periodic_high(p, p->mark);
	else if (level_at(p, p->mark))
		p->high_acc += t - p->mark;
	p->mark = t;
}

/* After a change of the waveform at t: `was` the level just before, `edge` the last edge
 * before. A level step is an edge; a waveform that stopped toggling keeps the last one. */
static void note_change(pwm_model_t *p, avr_cycle_count_t t, int was, avr_cycle_count_t edge)
{
	if (level_at(p, t) != was)
		p->last_change = t;
	else if (!toggling(p))
		p->last_change = edge;
}

static avr_cycle_count_t last_edge(const pwm_model_t *p, avr_cycle_count_t t)
{
	return toggling(p) ? periodic_last_edge(p, t) : p->last_change;
}

/* Bring the integral to `now`, applying a buffered OCR1A at its BOTTOM on the way. */
static void advance(pwm_model_t *p, avr_cycle_count_t now)
{
	if (p->pending && p->pending_at <= now) {
		avr_cycle_count_t at = p->pending_at;
		integrate(p, at);
		int was = level_at(p, at > p->t0 ? at - 1 : at);
		avr_cycle_count_t edge = last_edge(p, at);
		p->pending = 0;
		avr_cycle_count_t high = ((avr_cycle_count_t)p->ocr_pending + 1) * p->prescale;
		p->high_cycles = high < p->period_cycles ? high : p->period_cycles;
		note_change(p, at, was, edge);
	}
	integrate(p, now);
}

/* simavr's Timer1 must not run while the model stands in: drop its cycle timers (all take
 * the timer as their parameter). */
static void stop_simavr_timer(pwm_model_t *p)
{
	avr_t *avr = p->avr;
	for (;;) {
		avr_cycle_timer_slot_p s = avr->cycle_timers.timer;
		while (s && s->param != p->timer)
			s = s->next;
		if (!s)
			break;
		avr_cycle_timer_cancel(avr, s->timer, s->param);
	}
}

/* Hand Timer1 back to simavr (the firmware uses it beyond PWM on OC1A): restart its clock
 * through TCCR1B so it configures itself from the registers. */
static void release(pwm_model_t *p, const char *why)
{
	if (!p->active)
		return;
	p->active = 0;
	fprintf(stderr, "auger-sim: Timer1 %s: simulated by simavr from now on (slower)\n", why);
	avr_t *avr = p->avr;
	avr_io_addr_t io = AVR_DATA_TO_IO(R_TCCR1B);
	uint8_t v = avr->data[R_TCCR1B];
	avr->io[io].w.c(avr, R_TCCR1B, (uint8_t)(v & ~0x07u), avr->io[io].w.param);
	avr->io[io].w.c(avr, R_TCCR1B, v, avr->io[io].w.param);
}

/* Re-read the configuration after a write (the write itself is already in data[]). */
static void reconfigure(pwm_model_t *p, avr_cycle_count_t now)
{
	const uint8_t *d = p->avr->data;
	advance(p, now);
	int was = level_at(p, now);
	avr_cycle_count_t edge = last_edge(p, now);

	uint8_t a = d[R_TCCR1A], b = d[R_TCCR1B];
	unsigned mode = (unsigned)(((b >> 3) & 0x3) << 2) | (a & 0x3);
	unsigned com1a = (a >> 6) & 0x3, com1b = (a >> 4) & 0x3;
	unsigned cs = b & 0x7;
	if (cs != 0 && (mode != MODE_FAST_PWM_ICR || prescaler_of_cs[cs] == 0 || com1a == 1 || com1a == 3 ||
			com1b != 0)) {
		release(p, "runs in another mode than fast PWM on OC1A");
		return;
	}
	int running = cs != 0;
	uint16_t top = (uint16_t)(d[R_ICR1L] | (d[R_ICR1H] << 8));
	uint16_t ocr = (uint16_t)(d[R_OCR1AL] | (d[R_OCR1AH] << 8));
	if (running && !p->running) {
		p->t0 = now; /* the clock starts at BOTTOM */
		p->mark = now;
		p->prescale = prescaler_of_cs[cs];
		p->pending = 0;
		p->high_cycles = ((avr_cycle_count_t)ocr + 1) * p->prescale;
	}
	p->running = running;
	p->connected = com1a == 2;
	p->period_cycles = ((avr_cycle_count_t)top + 1) * (running ? p->prescale : 1);
	if (p->high_cycles > p->period_cycles)
		p->high_cycles = p->period_cycles;
	p->port_level = (d[R_PORTB] >> PORTB_PWM_BIT) & 1;
	note_change(p, now, was, edge);
	stop_simavr_timer(p);
}

static void hook_write(struct avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
	pwm_model_t *p = (pwm_model_t *)param;
	/* the handler this one replaced first (simavr's timer, port, pwm_ocr_fix), or the plain
	 * store */
	int handled = 0;
	for (unsigned i = 0; i < sizeof(p->wrapped) / sizeof(p->wrapped[0]); i++)
		if (p->wrapped[i].addr == addr && p->wrapped[i].c) {
			p->wrapped[i].c(avr, addr, v, p->wrapped[i].param);
			handled = 1;
		}
	if (!handled)
		avr_core_watch_write(avr, addr, v);
	if (!p->active)
		return;
	if (addr == R_TIMSK1) {
		if (v)
			release(p, "interrupts are enabled (TIMSK1)");
		return;
	}
	if (addr == R_PORTB) {
		/* only the pin's level matters here */
		advance(p, avr->cycle);
		int was = level_at(p, avr->cycle);
		avr_cycle_count_t edge = last_edge(p, avr->cycle);
		p->port_level = (avr->data[R_PORTB] >> PORTB_PWM_BIT) & 1;
		note_change(p, avr->cycle, was, edge);
		return;
	}
	if (addr == R_OCR1AL) {
		/* the chip applies OCR1A at the next BOTTOM */
		advance(p, avr->cycle);
		uint16_t ocr = (uint16_t)(avr->data[R_OCR1AL] | (avr->data[R_OCR1AH] << 8));
		if (p->running) {
			avr_cycle_count_t k = (avr->cycle - p->t0) / p->period_cycles + 1;
			p->ocr_pending = ocr;
			p->pending = 1;
			p->pending_at = p->t0 + k * p->period_cycles;
		} else {
			p->high_cycles = (avr_cycle_count_t)ocr + 1;
		}
		stop_simavr_timer(p);
		return;
	}
	reconfigure(p, avr->cycle); /* TCCR1A, TCCR1B, ICR1L */
}

static uint8_t hook_tcnt_read(struct avr_t *avr, avr_io_addr_t addr, void *param)
{
	pwm_model_t *p = (pwm_model_t *)param;
	if (p->active)
		release(p, "counter TCNT1 is read");
	return p->tcnt_read ? p->tcnt_read(avr, addr, p->tcnt_param) : avr->data[addr];
}

int pwm_model_attach(avr_t *avr, pwm_model_t *p)
{
	memset(p, 0, sizeof(*p));
	p->avr = avr;
	for (avr_io_t *io = avr->io_port; io; io = io->next)
		if (io->kind && strcmp(io->kind, "timer") == 0 && ((avr_timer_t *)io)->name == '1')
			p->timer = (avr_timer_t *)io;
	if (!p->timer)
		return -1;
	/* In place of the registers' handlers, calling them first: simavr's muxer for several
	 * handlers of one register has room for four registers in all. */
	static const avr_io_addr_t regs[] = { R_TCCR1A, R_TCCR1B, R_ICR1L, R_OCR1AL, R_TIMSK1, R_PORTB };
	for (unsigned i = 0; i < sizeof(regs) / sizeof(regs[0]); i++) {
		avr_io_addr_t io = AVR_DATA_TO_IO(regs[i]);
		p->wrapped[i].addr = regs[i];
		p->wrapped[i].c = avr->io[io].w.c;
		p->wrapped[i].param = avr->io[io].w.param;
		avr->io[io].w.c = hook_write;
		avr->io[io].w.param = p;
	}
	/* simavr refuses a second reader: take its place and call it */
	avr_io_addr_t tcnt = AVR_DATA_TO_IO(R_TCNT1L);
	p->tcnt_read = avr->io[tcnt].r.c;
	p->tcnt_param = avr->io[tcnt].r.param;
	avr->io[tcnt].r.c = hook_tcnt_read;
	avr->io[tcnt].r.param = p;
	pwm_model_restart(p);
	return 0;
}

void pwm_model_restart(pwm_model_t *p)
{
	p->active = 1;
	p->running = p->connected = p->port_level = 0;
	p->pending = 0;
	p->prescale = 1;
	p->period_cycles = 1;
	p->high_cycles = 1;
	p->t0 = p->mark = p->last_change = p->avr->cycle;
	p->high_acc = 0;
}

avr_cycle_count_t pwm_model_take_high(pwm_model_t *p, avr_cycle_count_t now)
{
	advance(p, now);
	avr_cycle_count_t h = p->high_acc;
	p->high_acc = 0;
	return h;
}

double pwm_model_duty(const pwm_model_t *p)
{
	if (toggling(p))
		return (double)p->high_cycles / (double)p->period_cycles;
	return level_at(p, p->avr->cycle) ? 1.0 : 0.0;
}

avr_cycle_count_t pwm_model_quiet(const pwm_model_t *p, avr_cycle_count_t now)
{
	avr_cycle_count_t edge = p->last_change;
	if (toggling(p)) {
		avr_cycle_count_t periodic = periodic_last_edge(p, now);
		if (periodic > edge)
			edge = periodic;
	}
	return now - edge;
}
