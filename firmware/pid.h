/*
 * Velocity-form PID of the paper, eqs. (23)-(24):
 *   u_k = u_{k-1} + A e_k + B e_{k-1} + C e_{k-2}
 *   A = kp + ki T/2 + kd/T,  B = -kp + ki T/2 - 2 kd/T,  C = kd/T
 * u is clamped to the duty range each step; since the next step starts from the clamped
 * u_{k-1}, the integral cannot wind up (the form's built-in anti-windup).
 * Single-precision float: the gains arrive as floats (protocol CONFIG frame), they span
 * 0.0003..0.5 with increments near 1e-6, and one step costs about a thousand cycles
 * every 10 ms; fixed point would need per-gain scaling to keep that range.
 * Evaluation: eq. (23) with eq. (24)'s coefficients regrouped per gain,
 *   A e_k + B e_{k-1} + C e_{k-2}
 *     = kp (e_k - e_{k-1}) + (ki T/2)(e_k + e_{k-1}) + (kd/T)(e_k - 2 e_{k-1} + e_{k-2}),
 * the same equation term for term. In float, A = 1.0000015 and B = -1.4999985 (the
 * paper's gains) cannot hold their ki T/2 parts: A + B + C comes out 2.86e-6 instead of
 * ki T = 3e-6, a 5 % error of the integral gain, which the regrouped form does not have.
 * Called by the control step at 100 Hz.
 */
#ifndef AUGER_PID_H
#define AUGER_PID_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* eq. (24); macros so that the build defaults are folded at compile time. The step uses
 * the per-gain parts below; PID_A/B/C document and test eq. (24) itself. */
#define PID_A(kp, ki, kd, t) ((kp) + (ki) * (t) / 2.0f + (kd) / (t))
#define PID_B(kp, ki, kd, t) (-(kp) + (ki) * (t) / 2.0f - 2.0f * (kd) / (t))
#define PID_C(kp, ki, kd, t) ((kd) / (t))
#define PID_QP(kp, ki, kd, t) (kp)
#define PID_QI(kp, ki, kd, t) ((ki) * (t) / 2.0f)
#define PID_QD(kp, ki, kd, t) ((kd) / (t))

typedef struct {
    float qp, qi, qd; /* kp, ki T/2, kd/T: A = qp + qi + qd, B = -qp + qi - 2 qd, C = qd */
    float u;        /* u_{k-1}, already clamped */
    float e1, e2;   /* e_{k-1}, e_{k-2} */
} pid_state_t;

void pid_set_gains(pid_state_t *p, float kp, float ki, float kd, float t);
/* eq. (24)'s A, B, C from the stored parts. */
void pid_coeffs(const pid_state_t *p, float *a, float *b, float *c);
/* Zero the output and the error history (motor disabled: next enable starts from rest). */
void pid_reset(pid_state_t *p);
/* One step of eq. (23) in the PID's own units; |u| <= u_max. *saturated tells whether the
 * clamp acted. */
float pid_step(pid_state_t *p, float e, float u_max, bool *saturated);

/* Duty cap from the motor rating: motor_rated_mv / battery_mv, in 1/10000, at most 10000;
 * 0 while the battery voltage is unknown (0). */
int16_t pid_duty_cap_x10000(uint16_t motor_rated_mv, uint16_t battery_mv);

/* The control step's call: speed error in 0.01 rpm to signed duty in 1/10000, with the
 * unit scaling of config.h (PID_E_PER_RPM, PID_U_FULL). u is the motor voltage as a share of
 * its rating: |u| <= PID_U_FULL, and duty = u / PID_U_FULL * cap with cap = rated / battery
 * voltage. The battery voltage is thereby compensated: the loop gain is the same at 15 V
 * and at 21 V. */
int16_t pid_step_duty(pid_state_t *p, int32_t error_crpm, int16_t cap_x10000, bool *saturated);

#ifdef __cplusplus
}
#endif

#endif /* AUGER_PID_H */
