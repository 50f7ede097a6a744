/* Velocity-form PID, eqs. (23)-(24); see pid.h. */
#include "pid.h"

#include "config.h"

void pid_set_gains(pid_state_t *p, float kp, float ki, float kd, float t)
{
    p->qp = PID_QP(kp, ki, kd, t);
    p->qi = PID_QI(kp, ki, kd, t);
    p->qd = PID_QD(kp, ki, kd, t);
    pid_reset(p);
}

void pid_coeffs(const pid_state_t *p, float *a, float *b, float *c)
{
    *a = p->qp + p->qi + p->qd;
    *b = -p->qp + p->qi - 2.0f * p->qd;
    *c = p->qd;
}

void pid_reset(pid_state_t *p)
{
    p->u = 0.0f;
    p->e1 = 0.0f;
    p->e2 = 0.0f;
}

float pid_step(pid_state_t *p, float e, float u_max, bool *saturated)
{
    /* eq. (23), A e_k + B e_{k-1} + C e_{k-2} regrouped per gain (pid.h says why) */
    float u = p->u + p->qp * (e - p->e1) + p->qi * (e + p->e1) +
              p->qd * ((e - p->e1) - (p->e1 - p->e2));
    bool sat = false;
    if (u > u_max) {
        u = u_max;
        sat = true;
    } else if (u < -u_max) {
        u = -u_max;
        sat = true;
    } else if (!(u == u)) {
        /* NaN cannot come from validated gains and bounded errors; never let it stick. */
        u = 0.0f;
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

int16_t pid_step_duty(pid_state_t *p, int32_t error_crpm, int16_t cap_x10000, bool *saturated)
{
    const float e_per_crpm = (float)(PID_E_PER_RPM) / 100.0f;
    const float u_full = (float)(PID_U_FULL);
    /* With the cap unknown (no voltage reading yet) the output stays 0 and does not wind. */
    float u = pid_step(p, (float)error_crpm * e_per_crpm, cap_x10000 > 0 ? u_full : 0.0f,
                       saturated);
    float duty = u / u_full * (float)cap_x10000;
    /* |u| <= cap, so |duty| <= 10000 up to rounding: clamp before converting anyway. */
    if (duty > 10000.0f) duty = 10000.0f;
    if (duty < -10000.0f) duty = -10000.0f;
    return (int16_t)(duty >= 0.0f ? duty + 0.5f : duty - 0.5f);
}
