/* Velocity-form PID, eqs. (23)-(24), in fixed point; see pid.h. */
#include "pid.h"

#include "config.h"
#include "mul16.h"

/* Terms within +-4 (times the rated voltage) sum in 32 bits; a larger one (large gains and
 * errors) sends the step down an exact 64-bit path. */
#define TERM_FAST_MAX (4L << PID_U_SHIFT)

/* value = coefficient x 2^27 per 0.01 rpm; normalised to a 15-bit mantissa. Float here only
 * (once per settings change). */
static pid_gain_t to_gain(float value)
{
    pid_gain_t g = {0, 0};
    if (!(value > 0.0f)) return g; /* zero (settings_validate refuses negatives and NaN) */
    int8_t s = 0;
    while (value >= 32768.0f && s < 16) {
        value *= 0.5f;
        s++;
    }
    if (value >= 32768.0f) { /* 16 or more per 0.01 rpm: any error saturates the term */
        g.m = 32767;
        g.shift = 16;
        return g;
    }
    while (value < 16384.0f && s > -64) {
        value *= 2.0f;
        s--;
    }
    int32_t m = (int32_t)(value + 0.5f);
    if (m > 32767) { /* rounded up to 2^15 */
        m = 16384;
        s++;
    }
    g.m = (int16_t)m;
    g.shift = s;
    return g;
}

double pid_gain_per_rpm(pid_gain_t g)
{
    double v = (double)g.m;
    for (int8_t s = g.shift; s > 0; --s) v *= 2.0;
    for (int8_t s = g.shift; s < 0; ++s) v *= 0.5;
    return v / (double)PID_U_ONE * 100.0 / (double)(PID_E_PER_RPM) * (double)(PID_U_FULL);
}

void pid_set_gains(pid_state_t *p, float kp, float ki, float kd, float t)
{
    /* per 0.01 rpm of error, in units of PID_U_FULL, times 2^27 */
    const float scale = (float)(PID_E_PER_RPM) / 100.0f / (float)(PID_U_FULL) * (float)PID_U_ONE;
    p->qp = to_gain(PID_QP(kp, ki, kd, t) * scale);
    p->qi = to_gain(PID_QI(kp, ki, kd, t) * scale);
    p->qd = to_gain(PID_QD(kp, ki, kd, t) * scale);
    pid_reset(p);
}

void pid_coeffs(const pid_state_t *p, double *a, double *b, double *c)
{
    double qp = pid_gain_per_rpm(p->qp), qi = pid_gain_per_rpm(p->qi), qd = pid_gain_per_rpm(p->qd);
    *a = qp + qi + qd;
    *b = -qp + qi - 2.0 * qd;
    *c = qd;
}

void pid_reset(pid_state_t *p)
{
    p->u = 0;
    p->e1 = 0;
    p->e2 = 0;
}

/* (m x) scaled by 2^shift; m x is exact in 32 bits (|m|, |x| < 2^15); right shifts floor
 * (gcc shifts signed values arithmetically), a bias of half a unit of 2^-27 per step. Sets
 * *big instead when the result would exceed +-TERM_FAST_MAX. */
static inline __attribute__((always_inline)) int32_t term(pid_gain_t g, int16_t x, bool *big)
{
    if (g.m == 0 || x == 0) return 0;
    int32_t v = (int32_t)g.m * x;
    int8_t s = g.shift;
    if (s > 0) {
        int32_t lim = TERM_FAST_MAX >> s;
        if (v > lim || v < -lim) {
            *big = true;
            return 0;
        }
        return (int32_t)((uint32_t)v << s);
    }
    while (s <= -8) {
        v >>= 8;
        s = (int8_t)(s + 8);
    }
    while (s < 0) {
        v >>= 1;
        s++;
    }
    return v;
}

/* The same term without a bound (rare: library shifts are fine here). */
static int64_t term64(pid_gain_t g, int16_t x)
{
    int64_t v = (int64_t)g.m * x;
    return g.shift >= 0 ? v * ((int64_t)1 << g.shift) : v >> -g.shift;
}

int32_t pid_step(pid_state_t *p, int32_t error_crpm, int32_t u_max_q27, bool *saturated)
{
    int16_t e = (int16_t)(error_crpm > PID_E_MAX_CRPM    ? PID_E_MAX_CRPM
                          : error_crpm < -PID_E_MAX_CRPM ? -PID_E_MAX_CRPM
                                                         : error_crpm);
    int16_t d1 = (int16_t)(e - p->e1);     /* e_k - e_{k-1} */
    int16_t d0 = (int16_t)(p->e1 - p->e2); /* e_{k-1} - e_{k-2} */
    /* eq. (23), regrouped per gain (pid.h); |u| <= 2^27 and three terms <= 2^29 fit 31 bits */
    int16_t ei = (int16_t)(e + p->e1), ed = (int16_t)(d1 - d0);
    bool big = false;
    int32_t u = p->u + term(p->qp, d1, &big) + term(p->qi, ei, &big) + term(p->qd, ed, &big);
    if (big) {
        /* exact, so that large terms of opposite sign still cancel as in the equation */
        int64_t w = (int64_t)p->u + term64(p->qp, d1) + term64(p->qi, ei) + term64(p->qd, ed);
        u = w > 2 * (int64_t)PID_U_ONE ? 2 * PID_U_ONE : w < -2 * (int64_t)PID_U_ONE ? -2 * PID_U_ONE : (int32_t)w;
    }
    bool sat = false;
    if (u > u_max_q27) {
        u = u_max_q27;
        sat = true;
    } else if (u < -u_max_q27) {
        u = -u_max_q27;
        sat = true;
    }
    p->u = u;
    p->e2 = p->e1;
    p->e1 = e;
    *saturated = sat;
    return u;
}

int16_t pid_duty_cap_x10000(uint16_t motor_rated_mv, uint16_t battery_mv)
{
    if (battery_mv == 0) return 0;
    if (motor_rated_mv >= battery_mv) return 10000; /* the quotient would be >= 10000 */
    /* rated x 10000 / battery < 10000 < 2^14: 14 steps of shift-and-subtract give the same
     * integer quotient as the 32-bit division, which libgcc does in 32 steps (~590 cycles
     * on the AVR, measured; this: ~250), once per control step. */
    uint32_t rem = (uint32_t)motor_rated_mv * 10000u;
    uint32_t div = (uint32_t)battery_mv << 13;
    uint16_t q = 0;
    for (uint8_t i = 0; i < 14u; ++i) {
        q = (uint16_t)(q << 1);
        if (rem >= div) {
            rem -= div;
            q |= 1u;
        }
        div >>= 1;
    }
    return (int16_t)q;
}

int16_t pid_duty_x10000(int32_t u_q27, int16_t cap_x10000)
{
    /* u in Q15 (held to +-32767: 2^-15 of the cap at full output) times the cap (<= 10000)
     * is a 16x16 multiply; doubled, plus half a unit, its high word is the duty rounded half
     * up (bit 15 is the first fraction bit). */
    /* >> 12 as >> 8 (byte moves) and >> 4: the barrier keeps gcc from fusing them into
     * one 12-step loop (84 cycles on the AVR; this: 36) */
    int32_t u15 = u_q27 >> 8;
    __asm__("" : "+r"(u15));
    u15 >>= PID_U_SHIFT - 15 - 8;
    if (u15 > 32767) u15 = 32767;
    if (u15 < -32767) u15 = -32767;
    /* By magnitude (an inline unsigned multiply, not libgcc's signed x unsigned one): for
     * u < 0 the floor of (-2m + 0x8000) / 2^16 is -((2m + 0x7FFF) >> 16), the same value. */
    bool neg = u15 < 0;
    uint16_t mag = (uint16_t)(neg ? -u15 : u15);
    uint32_t twice = mul_u16(mag, (uint16_t)cap_x10000) * 2u;
    int16_t duty = neg ? (int16_t)-(int16_t)((twice + 0x7FFFu) >> 16) : (int16_t)((twice + 0x8000u) >> 16);
    if (duty > 10000) duty = 10000;
    if (duty < -10000) duty = -10000;
    return duty;
}

int16_t pid_step_duty(pid_state_t *p, int32_t error_crpm, int16_t cap_x10000, int32_t u_max_q27,
                      bool *saturated, int32_t *u_q27)
{
    /* With the cap unknown (no voltage reading yet) the output stays 0 and does not wind. */
    int32_t u = pid_step(p, error_crpm, cap_x10000 > 0 ? u_max_q27 : 0, saturated);
    if (u_q27) *u_q27 = u;
    return pid_duty_x10000(u, cap_x10000);
}
