/* Current foldback; see foldback.h. */
#include "foldback.h"

#include "config.h"
#include "pid.h"

/* Moves of the limit per control period. Over the start level the limit first comes down to
 * the output as it is; inside the band it moves towards the linear derating by at most 1/16
 * down or 1/256 up; below the band up by 1/64 (full output again 0.64 s after an overload); at
 * the trip it halves at once. At 18 V a locked rotor's pack current grows by about 16 A per
 * unit of u (dI/du = 2 x 144 u / Vbatt at 12 V rated, 0.6 ohm), so inside the band the
 * current rises by at most about 0.06 A a period above where the derating meets the load. A
 * load that raises the current by more than the band (0.7 A) within one period can show one
 * reading above the trip, after which the limit halves (the trip needs overcurrent_samples
 * readings in a row); the reading after a halving, which still averages the period before
 * it, holds the limit. docs/firmware.md has the measured figures. */
#define FOLDBACK_RISE_Q27 (PID_U_ONE / 64)
#define FOLDBACK_RISE_BAND_Q27 (PID_U_ONE / 256)
#define FOLDBACK_FALL_BAND_Q27 (PID_U_ONE / 16)

void foldback_configure(foldback_t *f, uint16_t start_ma, uint16_t trip_ma)
{
    f->start_ma = start_ma;
    f->trip_ma = trip_ma;
    f->inv_band_q24 = (start_ma != 0 && trip_ma > start_ma) ? (1UL << 24) / (uint16_t)(trip_ma - start_ma) : 0;
    foldback_reset(f);
}

void foldback_reset(foldback_t *f)
{
    f->limit_q27 = PID_U_ONE;
    f->halved = false;
}

int32_t foldback_update(foldback_t *f, int16_t current_ma, int32_t u_q27)
{
    if (f->inv_band_q24 == 0) return f->limit_q27; /* off: PID_U_ONE */
    uint16_t mag = (uint16_t)(current_ma < 0 ? -(int32_t)current_ma : current_ma);
    int32_t l = f->limit_q27;
    /* Over the start level the limit acts from the output as it is, not from full output
     * far above it (a limit moving down from 1 towards a u of 0.8 would take periods to
     * bite while the current grows). */
    int32_t u_mag = u_q27 < 0 ? -u_q27 : u_q27;
    if (mag > f->start_ma && l > u_mag) l = u_mag;
    bool halve = mag >= f->trip_ma && !f->halved;
    if (mag >= f->trip_ma) {
        /* Above the derating's end: halve, so that the current (between proportional to u
         * when the motor turns and to u^2 at a locked rotor) is below the band within a
         * period or two, long before the overcurrent trip's consecutive readings; not to 0,
         * which would leave a stall with no current to be seen. The reading right after a
         * halving still averages the period before it: that one holds. */
        if (halve) l >>= 1;
    } else if (mag <= f->start_ma) {
        l += FOLDBACK_RISE_Q27;
        if (l > PID_U_ONE) l = PID_U_ONE;
    } else {
        /* (trip - I) / (trip - start) < 1: below 2^24 in Q24, then Q27 */
        uint32_t share_q24 = (uint32_t)(uint16_t)(f->trip_ma - mag) * f->inv_band_q24;
        int32_t target = (int32_t)(share_q24 << (PID_U_SHIFT - 24));
        if (target > l) {
            l += FOLDBACK_RISE_BAND_Q27;
            if (l > target) l = target;
        } else {
            l -= FOLDBACK_FALL_BAND_Q27;
            if (l < target) l = target;
        }
    }
    f->halved = halve;
    f->limit_q27 = l;
    return l;
}

bool foldback_active(const foldback_t *f) { return f->limit_q27 < PID_U_ONE; }
