/* An imposed encoder rate (encoder_rate.h), driving sim/encoder.c's pins while the
 * part is held. */
#include "encoder_rate.h"

#include <math.h>

#include "encoder.h"
#include "sim_avr.h"
#include "sim_cycle_timers.h"

typedef struct encoder_rate_t {
	encoder_t *e;
	int on;
	int dir;             /* +1 counts up, -1 down */
	double mean_cycles;  /* mean interval between edges */
	double jitter;       /* interval uniform in mean x [1 - j, 1 + j] */
	double next_cycle;   /* exact (fractional) time of the next edge */
	uint64_t rng_state;  /* xorshift64 state: deterministic per seed */
} encoder_rate_t;

static encoder_rate_t rate_of[SIMMOD_MAX_MODULES];

static double uniform01(encoder_rate_t *r)
{
	/* xorshift64 (Marsaglia): deterministic, no shared state between modules/threads */
	uint64_t x = r->rng_state;
	x ^= x << 13;
	x ^= x >> 7;
	x ^= x << 17;
	r->rng_state = x;
	return (double)(x >> 11) * (1.0 / 9007199254740992.0); /* 53 bits -> [0, 1) */
}

static double interval_cycles(encoder_rate_t *r)
{
	return r->mean_cycles * (1.0 + r->jitter * (2.0 * uniform01(r) - 1.0));
}

static avr_cycle_count_t edge_timer(avr_t *avr, avr_cycle_count_t when, void *param)
{
	(void)avr;
	encoder_rate_t *r = (encoder_rate_t *)param;
	if (!r->on || !r->e->held) /* ended, or a reset of the AVR released the pins */
		return 0;
	encoder_step(r->e, r->dir);
	/* Keep the exact fractional schedule so rounding does not bias the rate; at least one
	 * cycle later (a timer returned for the past is dropped). */
	r->next_cycle += interval_cycles(r);
	avr_cycle_count_t next = (avr_cycle_count_t)llround(r->next_cycle);
	return next > when ? next : when + 1;
}

void encoder_rate_force(simmod_t *sim, int module, double edges_per_s, double jitter, uint64_t seed)
{
	encoder_rate_t *r = &rate_of[module];
	encoder_t *e = simmod_encoder(sim, module);
	avr_cycle_timer_cancel(e->avr, edge_timer, r); /* a rate set before on this module */
	r->e = e;
	r->on = 0;
	if (edges_per_s == 0) {
		encoder_release(e, simmod_motor_angle_rad(sim, module));
		return;
	}
	encoder_hold(e);
	if (jitter < 0)
		jitter = 0;
	if (jitter > 1)
		jitter = 1;
	r->on = 1;
	r->dir = edges_per_s > 0 ? 1 : -1;
	r->mean_cycles = (double)e->avr->frequency / fabs(edges_per_s);
	r->jitter = jitter;
	r->rng_state = seed ? seed : 0x9E3779B97F4A7C15ull; /* xorshift must not start at 0 */
	r->next_cycle = (double)e->avr->cycle + interval_cycles(r);
	avr_cycle_count_t next = (avr_cycle_count_t)llround(r->next_cycle);
	avr_cycle_timer_register(e->avr, next > e->avr->cycle ? next - e->avr->cycle : 1, edge_timer, r);
}
