// Velocity-form PID, eqs. (23)-(24), in the firmware's fixed point: coefficients, a
// hand-computed sequence, agreement with a double-precision eq. (23) within the fixed
// point's quantisation (saturated or not), clamping and recovery (anti-windup), extreme
// inputs, duty cap and duty rounding.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <random>

#include "config.h"
#include "pid.h"

namespace {
// The paper's gains (section IV-C); the firmware's defaults are tuned ones (docs/firmware.md).
constexpr double kPaperKp = 0.5, kPaperKi = 0.0003, kPaperKd = 0.005;

double u_of(int32_t q27) { return double(q27) / double(PID_U_ONE); }

// eq. (23) with eq. (24)'s A, B, C in double, clamped like the firmware (the clamped value
// is u_{k-1} of the next step), errors in 0.01 rpm held within +-PID_E_MAX_CRPM.
struct DoublePid {
    double A, B, C, u = 0, e1 = 0, e2 = 0;
    DoublePid(double kp, double ki, double kd, double t)
        : A(kp + ki * t / 2 + kd / t), B(-kp + ki * t / 2 - 2 * kd / t), C(kd / t) {}
    double step(int32_t error_crpm, double u_max)
    {
        double e = std::clamp(double(error_crpm), -double(PID_E_MAX_CRPM), double(PID_E_MAX_CRPM)) / 100.0;
        u = std::clamp(u + A * e + B * e1 + C * e2, -u_max, u_max);
        e2 = e1;
        e1 = e;
        return u;
    }
};
}  // namespace

TEST_CASE("pid: eq. (24) coefficients, and the fixed-point ones within 2^-15")
{
    // kp 1, ki 2, kd 0.5, T 0.5: A = 1 + 0.5 + 1, B = -1 + 0.5 - 2, C = 1
    CHECK(PID_A(1.0f, 2.0f, 0.5f, 0.5f) == 2.5f);
    CHECK(PID_B(1.0f, 2.0f, 0.5f, 0.5f) == -2.5f);
    CHECK(PID_C(1.0f, 2.0f, 0.5f, 0.5f) == 1.0f);
    // The paper's gains with T = 10 ms: A = 1.0000015, B = -1.4999985, C = 0.5.
    pid_state_t p;
    pid_set_gains(&p, float(kPaperKp), float(kPaperKi), float(kPaperKd), float(PID_T));
    double a, b, c;
    pid_coeffs(&p, &a, &b, &c);
    CHECK(a == Approx(1.0000015).epsilon(4e-5));
    CHECK(b == Approx(-1.4999985).epsilon(4e-5));
    CHECK(c == Approx(0.5).epsilon(4e-5));
    // Each coefficient keeps 15 significant bits, the tiny ki T/2 as well.
    CHECK(pid_gain_per_rpm(p.qi) == Approx(kPaperKi * PID_T / 2).epsilon(3.1e-5));
    CHECK(pid_gain_per_rpm(p.qp) == Approx(kPaperKp).epsilon(3.1e-5));
    CHECK(pid_gain_per_rpm(p.qd) == Approx(kPaperKd / PID_T).epsilon(3.1e-5));
    // The build defaults reach the PID.
    pid_state_t d;
    pid_set_gains(&d, float(KP), float(KI), float(KD), float(PID_T));
    CHECK(pid_gain_per_rpm(d.qp) == Approx(KP).epsilon(3.1e-5));
    CHECK(pid_gain_per_rpm(d.qi) == Approx(KI * PID_T / 2).epsilon(3.1e-5));
    CHECK(d.qd.m == 0);  // kd 0: no term at all
}

TEST_CASE("pid: the integral action per step is ki T, also for the paper's tiny ki")
{
    // Constant error: after two steps e_k = e_{k-1} = e_{k-2}, and eq. (23) adds
    // (A + B + C) e = ki T e per step. With the paper's gains A + B + C = 3e-6, which float
    // A and B (1.0000015, -1.4999985) would only give as 2.86e-6; here ki T/2 has a
    // coefficient of its own.
    pid_state_t p;
    pid_set_gains(&p, float(kPaperKp), float(kPaperKi), float(kPaperKd), float(PID_T));
    bool sat = false;
    const int32_t e_crpm = 500;  // 5 rpm: kp e = 2.5 would clamp; errors are held below
    p.u = 0;
    // Start from a state where e_{k-1} = e_{k-2} = e (no proportional or derivative kick).
    p.e1 = p.e2 = int16_t(e_crpm);
    const int32_t u0 = p.u;
    for (int i = 0; i < 1000; ++i) pid_step(&p, e_crpm, PID_U_ONE, &sat);
    REQUIRE_FALSE(sat);
    const double per_step = u_of(p.u - u0) / 1000.0 / (e_crpm / 100.0);
    CHECK(per_step == Approx(kPaperKi * PID_T).epsilon(0.005));
}

TEST_CASE("pid: fixed-point steps follow a double eq. (23) within the quantisation")
{
    struct Gains {
        double kp, ki, kd;
    };
    std::mt19937 rng(3);
    for (const Gains g : {Gains{KP, KI, KD}, Gains{kPaperKp, kPaperKi, kPaperKd}, Gains{0.2, 4.0, 0.001}}) {
        INFO("kp " << g.kp << " ki " << g.ki << " kd " << g.kd);
        pid_state_t p;
        pid_set_gains(&p, float(g.kp), float(g.ki), float(g.kd), float(PID_T));
        DoublePid ref(g.kp, g.ki, g.kd, PID_T);
        // Errors as the loop sees them: multiples of the 33.9 crpm velocity quantum around a
        // setpoint, and every 500 steps a setpoint step held for 30 steps (these saturate).
        int saturated = 0, max_duty_diff = 0;
        double max_u_diff = 0;
        int32_t offset = 0;
        for (int k = 0; k < 5000; ++k) {
            if (k % 500 == 0) offset = (rng() % 2 ? 1 : -1) * int32_t(2000 + rng() % 4000);
            if (k % 500 == 30) offset = 0;
            int32_t e = offset + int32_t(std::lround(33.875 * int(rng() % 7 - 3))) + int32_t(rng() % 11) - 5;
            const int16_t cap = int16_t(5714 + rng() % 4287);
            bool sat = false;
            int32_t uq = 0;
            const int16_t duty = pid_step_duty(&p, e, cap, PID_U_ONE, &sat, &uq);
            const double u = ref.step(e, 1.0);
            saturated += sat;
            max_u_diff = std::max(max_u_diff, std::fabs(u_of(uq) - u));
            max_duty_diff = std::max(max_duty_diff, std::abs(duty - int(std::lround(u * cap))));
        }
        INFO("steps at the clamp " << saturated << ", largest |u - u_double| " << max_u_diff
                                   << ", largest duty difference " << max_duty_diff);
        CHECK(saturated > 0);
        CHECK(max_u_diff < 2e-4);      // 15-bit coefficients, floors of 2^-27 per step
        CHECK(max_duty_diff <= 2);     // of 10000: inside the PWM's step of 10
    }
}

TEST_CASE("pid: eq. (23) against a sequence computed by hand")
{
    pid_state_t p;
    pid_set_gains(&p, 0.01f, 0.02f, 0.005f, 0.5f);  // per rpm: A 0.025, B -0.025, C 0.01
    bool sat = true;
    auto step = [&](double e_rpm) { return u_of(pid_step(&p, int32_t(std::lround(e_rpm * 100)), PID_U_ONE, &sat)); };
    CHECK(step(1.0) == Approx(0.025).margin(1e-4));  // 0 + 0.025*1
    CHECK_FALSE(sat);
    CHECK(step(2.0) == Approx(0.05).margin(1e-4));   // 0.025 + 0.025*2 - 0.025*1
    CHECK(step(3.0) == Approx(0.085).margin(1e-4));  // 0.05 + 0.075 - 0.05 + 0.01
    CHECK(step(0.0) == Approx(0.03).margin(1e-4));   // 0.085 + 0 - 0.075 + 0.02
    CHECK(step(0.0) == Approx(0.06).margin(1e-4));   // 0.03 + 0 + 0 + 0.01*3
    CHECK(step(0.0) == Approx(0.06).margin(1e-4));   // history empty of error: holds
    pid_reset(&p);
    CHECK(step(-1.0) == Approx(-0.025).margin(1e-4));
}

TEST_CASE("pid: clamping, and recovery without windup")
{
    pid_state_t p;
    pid_set_gains(&p, 0.0f, 10.0f, 0.0f, 0.1f);  // pure trapezoidal integrator: A = B = 0.5
    bool sat = false;
    auto step = [&](double e_rpm, int32_t u_max) { return u_of(pid_step(&p, int32_t(e_rpm * 100), u_max, &sat)); };
    CHECK(step(1.0, PID_U_ONE) == Approx(0.5).margin(1e-4));
    CHECK_FALSE(sat);
    for (int i = 0; i < 100; ++i) step(1.0, PID_U_ONE);
    CHECK(sat);
    CHECK(p.u == PID_U_ONE);  // held at the clamp, not 100
    // Error reverses: an unclamped integrator would need ~100 steps to come back.
    CHECK(step(-1.0, PID_U_ONE) == Approx(1.0).margin(1e-4));  // 1 - 0.5 + 0.5
    CHECK_FALSE(sat);
    CHECK(step(-1.0, PID_U_ONE) == Approx(0.0).margin(1e-4));
    CHECK(step(-1.0, PID_U_ONE) == Approx(-1.0).margin(1e-4));
    CHECK(step(-1.0, PID_U_ONE) == -1.0);
    CHECK(sat);
    // A lower limit (battery voltage rose, or the current foldback) takes effect at once.
    CHECK(step(-1.0, PID_U_ONE / 2) == -0.5);
}

TEST_CASE("pid: extreme errors neither overflow nor stick")
{
    pid_state_t p;
    pid_set_gains(&p, float(kPaperKp), float(kPaperKi), float(kPaperKd), float(PID_T));
    bool sat = false;
    for (int i = 0; i < 1000; ++i) {
        int32_t err = (i % 2) ? 65534 : -65534;  // setpoint and speed at opposite int16 ends
        int16_t d = pid_step_duty(&p, err, 10000, PID_U_ONE, &sat, nullptr);
        CHECK(std::abs(int(d)) <= 10000);
        CHECK(std::abs(p.u) <= PID_U_ONE);
    }
    pid_reset(&p);
    // A constant extreme error (held at 81.91 rpm): the first step hits the clamp; the second
    // applies the derivative term's decay, -(kd/T) e, to the clamped value and lands on the
    // other clamp. The clamped velocity form loses the part of each step the clamp cut off:
    // with the paper's gains in rpm and share of 12 V, any step over ~3 rpm does this
    // (docs/firmware.md). Then ki T e per step walks it back, from -1 to +1 of 12 V.
    CHECK(pid_step_duty(&p, 65534, 8000, PID_U_ONE, &sat, nullptr) == 8000);
    CHECK(pid_step_duty(&p, 65534, 8000, PID_U_ONE, &sat, nullptr) == -8000);
    int16_t last = -8000;
    for (int i = 0; i < 9000; ++i) {
        int16_t d = pid_step_duty(&p, 65534, 8000, PID_U_ONE, &sat, nullptr);
        CHECK(d >= last);  // monotonic recovery by the integral term
        last = d;
    }
    CHECK(last == 8000);
    // Error flips to the other extreme with a lower cap: clamped at once...
    CHECK(pid_step_duty(&p, -65534, 5714, PID_U_ONE, &sat, nullptr) == -5714);
    // ... then the e_{k-2} term of the derivative kicks the output to the positive clamp for
    // one step: the velocity form clips half of the D-term's second difference. Bounded is
    // what can be asserted here.
    for (int i = 0; i < 1000; ++i) {
        int16_t d = pid_step_duty(&p, -65534, 5714, PID_U_ONE, &sat, nullptr);
        CHECK(std::abs(int(d)) <= 5714);
    }
}

TEST_CASE("pid: unit scaling and rounding of pid_step_duty")
{
    pid_state_t p;
    pid_set_gains(&p, 1.0f, 0.0f, 0.0f, float(PID_T));  // u = e (proportional only)
    bool sat = false;
    // Defaults: e in rpm, u the share of the motor's rated voltage.
    CHECK(PID_E_PER_RPM == 1.0);
    CHECK(PID_U_FULL == 1.0);
    // 5 crpm = 0.05 rpm -> u = 0.05 -> 5 % of 12 V: duty 0.05 x cap.
    CHECK(pid_step_duty(&p, 5, 10000, PID_U_ONE, &sat, nullptr) == 500);
    pid_reset(&p);
    CHECK(pid_step_duty(&p, 5, 8000, PID_U_ONE, &sat, nullptr) == 400);  // 15 V battery: cap 0.8
    pid_reset(&p);
    CHECK(pid_step_duty(&p, 50, 5714, PID_U_ONE, &sat, nullptr) == 2857);  // 21 V: u 0.5 of 12 V
    CHECK_FALSE(sat);
    pid_reset(&p);
    CHECK(pid_step_duty(&p, 1000, 8000, PID_U_ONE, &sat, nullptr) == 8000);  // 10 rpm -> u 10, clamped at 1
    CHECK(sat);
    pid_reset(&p);
    int32_t u = 1;
    CHECK(pid_step_duty(&p, 1000, 0, PID_U_ONE, &sat, &u) == 0);  // cap 0 (voltage unknown): no drive
    CHECK(u == 0);                                                // and no wind-up
    CHECK(p.u == 0);
    // The duty is u x cap rounded, for every u the output can take, within one unit.
    for (int32_t uq = -PID_U_ONE; uq <= PID_U_ONE; uq += 4099)
        for (int16_t cap : {int16_t(10000), int16_t(5714), int16_t(8000), int16_t(1)})
            REQUIRE(std::abs(pid_duty_x10000(uq, cap) - u_of(uq) * cap) <= 0.5 + cap / 32768.0);
    CHECK(pid_duty_x10000(PID_U_ONE, 10000) == 10000);
    CHECK(pid_duty_x10000(-PID_U_ONE, 10000) == -10000);
    // Exactly u15 x cap / 2^15 rounded half up (towards +inf), also for u < 0 (the firmware
    // multiplies the magnitude): every Q15 output, caps at both ends and between.
    for (int32_t u15 = -32767; u15 <= 32767; ++u15)
        for (int32_t cap : {1, 2, 5714, 8000, 9999, 10000}) {
            int64_t twice = int64_t(u15) * cap * 2 + 0x8000;
            int64_t want = twice >= 0 ? twice / 65536 : -((-twice + 65535) / 65536);  // floor
            REQUIRE(pid_duty_x10000(u15 * 4096, int16_t(cap)) == want);
        }
}

TEST_CASE("pid: duty cap = motor rating / battery voltage")
{
    CHECK(pid_duty_cap_x10000(12000, 15000) == 8000);
    CHECK(pid_duty_cap_x10000(12000, 21000) == 5714);
    CHECK(pid_duty_cap_x10000(12000, 12000) == 10000);
    CHECK(pid_duty_cap_x10000(12000, 6000) == 10000);
    CHECK(pid_duty_cap_x10000(12000, 0) == 0);
    CHECK(pid_duty_cap_x10000(65535, 1) == 10000);
    CHECK(pid_duty_cap_x10000(1, 65535) == 0);
    // The shift-and-subtract division equals the integer quotient everywhere it runs.
    for (uint32_t rated = 1; rated < 65536u; rated += 37u)
        for (uint32_t batt = rated + 1u; batt < 65536u; batt += 101u)
            REQUIRE(pid_duty_cap_x10000(uint16_t(rated), uint16_t(batt)) ==
                    int16_t(rated * 10000u / batt));
}
