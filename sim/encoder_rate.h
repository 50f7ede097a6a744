/*
 * An imposed encoder rate, for the firmware bench's figures
 * (docs/benchmarks.md "Highest encoder edge rate"): a module's encoder pins driven at edges_per_s
 * (the sign gives the direction) instead of from the shaft, to find the highest edge rate the
 * firmware decodes. Intervals between edges are uniform in mean x [1 - jitter, 1 + jitter]
 * (jitter 0..1; 0: regular spacing) from a deterministic xorshift64 generator seeded by seed;
 * edges come from cycle timers on the module's AVR, so at exact simulated times. The motor model
 * runs on unchanged. edges_per_s = 0 returns the pins to the shaft without a jump: the count goes
 * on from where they were left (simmod_encoder_count stays the true count on the pins
 * throughout). A reset of the AVR also ends it. One imposed rate per module index at a time (the
 * bench and the tests run one board).
 */
#ifndef AUGER_SIM_ENCODER_RATE_H
#define AUGER_SIM_ENCODER_RATE_H

#include <stdint.h>

#include "simmod.h"

#ifdef __cplusplus
extern "C" {
#endif

void encoder_rate_force(simmod_t *sim, int module, double edges_per_s, double jitter, uint64_t seed);

#ifdef __cplusplus
}
#endif
#endif
