/*
 * Velocity-form PID of the paper, eqs. (23)-(24):
 *   u_k = u_{k-1} + A e_k + B e_{k-1} + C e_{k-2}
 *   A = kp + ki T/2 + kd/T,  B = -kp + ki T/2 - 2 kd/T,  C = kd/T
 * u is clamped each step; since the next step starts from the clamped u_{k-1}, the integral
 * cannot wind up (the form's built-in anti-windup).
 * Evaluation: eq. (23) with eq. (24)'s coefficients regrouped per gain,
 *   A e_k + B e_{k-1} + C e_{k-2}
 *     = kp (e_k - e_{k-1}) + (ki T/2)(e_k + e_{k-1}) + (kd/T)((e_k - e_{k-1}) - (e_{k-1} - e_{k-2})),
 * the same equation term for term; it keeps the small ki T/2 apart from the large kp (the
 * paper's gains give A = 1.0000015 and B = -1.4999985, whose sum ki T = 3e-6 a 24-bit
 * mantissa cannot hold).
 * Fixed point (the module has no FPU: the float step cost ~1500 cycles, this one ~300):
 * e in 0.01 rpm (int16, clamped to +-PID_E_MAX_CRPM), u in Q27 (PID_U_ONE = 2^27 is the
 * motor's rated voltage), and each per-gain coefficient as a 15-bit mantissa with a binary
 * exponent (pid_gain_t), so the gains keep 15 significant bits across the paper's range
 * (ki T/2 = 1.5e-6 to kd/T = 0.5 per rpm) and beyond. Each product is exact in 32 bits
 * before its shift; the terms sum in 32 bits while each stays within +-4 times the rated
 * voltage, else (large gains with large errors) in 64 bits, so that large terms of opposite
 * sign cancel exactly as in the equation.
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

#define PID_U_SHIFT 27
#define PID_U_ONE (1L << PID_U_SHIFT) /* u = PID_U_FULL: the motor's rated voltage */
/* Errors beyond +-81.91 rpm are held there (their sums and differences then fit 16 bits);
 * any such error saturates the output within a step with working gains. */
#define PID_E_MAX_CRPM 8191

/* coefficient x 2^27 = m x 2^shift: the term for an error x (0.01 rpm) is (m x) << shift
 * (or >> -shift); m = 0 for a zero gain. */
typedef struct {
    int16_t m;     /* 0, or 2^14 .. 2^15 - 1 */
    int8_t shift;
} pid_gain_t;

typedef struct {
    pid_gain_t qp, qi, qd; /* kp, ki T/2, kd/T per 0.01 rpm of error, in units of u */
    int32_t u;             /* u_{k-1} in Q27, already clamped */
    int16_t e1, e2;        /* e_{k-1}, e_{k-2}, 0.01 rpm */
} pid_state_t;

/* Gains in the firmware's units (docs/firmware.md: e in rpm x PID_E_PER_RPM, u = PID_U_FULL
 * at the rated voltage, t in the unit the gains assume). Resets the state. */
void pid_set_gains(pid_state_t *p, float kp, float ki, float kd, float t);
/* The value a coefficient stands for, in units of u per rpm of error (tests, docs). */
double pid_gain_per_rpm(pid_gain_t g);
/* eq. (24)'s A, B, C from the stored coefficients, per rpm (tests). */
void pid_coeffs(const pid_state_t *p, double *a, double *b, double *c);
/* Zero the output and the error history (motor disabled: next enable starts from rest). */
void pid_reset(pid_state_t *p);
/* One step of eq. (23): error in 0.01 rpm, |u| <= u_max (Q27, 0..PID_U_ONE); returns u
 * (Q27). *saturated tells whether the clamp acted. */
int32_t pid_step(pid_state_t *p, int32_t error_crpm, int32_t u_max_q27, bool *saturated);

/* Duty cap from the motor rating: motor_rated_mv / battery_mv, in 1/10000, at most 10000;
 * 0 while the battery voltage is unknown (0). */
int16_t pid_duty_cap_x10000(uint16_t motor_rated_mv, uint16_t battery_mv);
/* Signed duty for an output u (Q27) under a cap: u x cap, rounded. */
int16_t pid_duty_x10000(int32_t u_q27, int16_t cap_x10000);

/* The control step's call: speed error in 0.01 rpm to signed duty in 1/10000. u is the motor
 * voltage as a share of its rating (|u| <= u_max_q27 <= PID_U_ONE, 0 while the cap is 0: no
 * voltage reading, no drive and no wind-up); duty = u x cap with cap = rated / battery
 * voltage, so the loop gain is the same at 15 V and at 21 V. *u_q27 (if not NULL) gets u. */
int16_t pid_step_duty(pid_state_t *p, int32_t error_crpm, int16_t cap_x10000, int32_t u_max_q27,
                      bool *saturated, int32_t *u_q27);

#ifdef __cplusplus
}
#endif

#endif /* AUGER_PID_H */
