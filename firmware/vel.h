/*
 * Screw speed estimated by differencing the encoder position once per control period
 * (the paper's method). Resolution: one count per period; at 48 counts per motor
 * revolution and the estimated 369:1 gear that is 6e8 / (1771200 * 10 ms) = 33.9 crpm,
 * about 0.34 rpm per count per 10 ms. Called by the control step.
 * Fixed point: the speed of one count per period is held as a 16.16 number (set up once per
 * settings change), so a step is two 16x16-bit multiplies instead of float arithmetic.
 */
#ifndef AUGER_VEL_H
#define AUGER_VEL_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
    uint32_t crpm_per_count_q16; /* speed of one count per period, 0.01 rpm x 65536 */
    uint32_t last_position;      /* unsigned: differences wrap correctly */
    bool primed;
} vel_t;

/* counts_per_rev_x100 > 0, period_ms > 0 (settings_validate guarantees it). */
void vel_init(vel_t *v, uint32_t counts_per_rev_x100, uint16_t period_ms);
/* Forget the previous position (after a settings change). */
void vel_restart(vel_t *v);
/* Counts moved since the previous call (0 on the first), wrap-safe. */
int32_t vel_diff_counts(vel_t *v, int32_t position_counts);
/* Speed for a count difference, rounded half away from zero, clamped to +-32767. */
int16_t vel_crpm_from_counts(const vel_t *v, int32_t counts);
/* Both of the above. */
int16_t vel_update_crpm(vel_t *v, int32_t position_counts);

#ifdef __cplusplus
}
#endif

#endif /* AUGER_VEL_H */
