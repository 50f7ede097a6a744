// Velocity-form PID, eqs. (23)-(24): coefficients, a hand-computed sequence, clamping and
// recovery (anti-windup), extreme inputs, duty cap.
#include <catch2/catch.hpp>

#include <cmath>

#include "config.h"
#include "pid.h"

namespace {
// The paper's gains (section IV-C); the firmware's defaults are tuned ones (docs/firmware.md).
constexpr double kPaperKp = 0.5, kPaperKi = 0.0003, kPaperKd = 0.005;
}  // namespace

TEST_CASE("pid: eq. (24) coefficients")
{
    // kp 1, ki 2, kd 0.5, T 0.5: A = 1 + 0.5 + 1, B = -1 + 0.5 - 2, C = 1
    CHECK(PID_A(1.0f, 2.0f, 0.5f, 0.5f) == 2.5f);
    CHECK(PID_B(1.0f, 2.0f, 0.5f, 0.5f) == -2.5f);
    CHECK(PID_C(1.0f, 2.0f, 0.5f, 0.5f) == 1.0f);
    // The paper's gains with T = 10 ms.
    pid_state_t p;
    pid_set_gains(&p, float(kPaperKp), float(kPaperKi), float(kPaperKd), float(PID_T));
    float a, b, c;
    pid_coeffs(&p, &a, &b, &c);
    CHECK(a == Approx(1.0000015).epsilon(1e-7));
    CHECK(b == Approx(-1.4999985).epsilon(1e-7));
    CHECK(c == Approx(0.5).epsilon(1e-7));
    // Folded by the preprocessor (as the build defaults are), the same numbers.
    CHECK(PID_A(float(kPaperKp), float(kPaperKi), float(kPaperKd), float(PID_T)) == a);
    CHECK(PID_C(float(kPaperKp), float(kPaperKi), float(kPaperKd), float(PID_T)) == c);
    // The build defaults reach the PID unchanged.
    pid_state_t d;
    pid_set_gains(&d, float(KP), float(KI), float(KD), float(PID_T));
    pid_coeffs(&d, &a, &b, &c);
    CHECK(a == Approx(double(PID_A(float(KP), float(KI), float(KD), float(PID_T)))));
    CHECK(b == Approx(double(PID_B(float(KP), float(KI), float(KD), float(PID_T)))));
}

TEST_CASE("pid: the integral action per step is ki T, not lost in float rounding")
{
    // Constant error: after two steps e_k = e_{k-1} = e_{k-2}, and eq. (23) adds
    // (A + B + C) e = ki T e per step. With the paper's gains A + B + C = 3e-6, which
    // float A and B (1.0000015, -1.4999985) would only give as 2.86e-6.
    pid_state_t p;
    pid_set_gains(&p, float(kPaperKp), float(kPaperKi), float(kPaperKd), float(PID_T));
    bool sat = false;
    const float e = 10.0f;
    pid_step(&p, e, 1000.0f, &sat);
    pid_step(&p, e, 1000.0f, &sat);
    float u2 = p.u;
    for (int i = 0; i < 1000; ++i) pid_step(&p, e, 1000.0f, &sat);
    double per_step = (double(p.u) - double(u2)) / 1000.0 / double(e);
    CHECK(per_step == Approx(kPaperKi * double(PID_T)).epsilon(0.01));
}

TEST_CASE("pid: float steps follow a double-precision eq. (23) with eq. (24)'s A, B, C")
{
    const double kp = kPaperKp, ki = kPaperKi, kd = kPaperKd, t = PID_T;
    const double A = kp + ki * t / 2 + kd / t, B = -kp + ki * t / 2 - 2 * kd / t, C = kd / t;
    pid_state_t p;
    pid_set_gains(&p, float(kp), float(ki), float(kd), float(t));
    double u = 0, e1 = 0, e2 = 0;
    bool sat = false;
    for (int k = 0; k < 500; ++k) {
        double e = 0.3 * std::sin(0.05 * k) + 0.02 * ((k * 7) % 5 - 2); // small, unsaturated
        u = u + A * e + B * e1 + C * e2;
        e2 = e1;
        e1 = e;
        float uf = pid_step(&p, float(e), 100.0f, &sat);
        REQUIRE_FALSE(sat);
        CHECK(double(uf) == Approx(u).margin(1e-5));
    }
}

TEST_CASE("pid: eq. (23) against a sequence computed by hand")
{
    pid_state_t p;
    pid_set_gains(&p, 1.0f, 2.0f, 0.5f, 0.5f); // A 2.5, B -2.5, C 1
    bool sat = true;
    CHECK(pid_step(&p, 1.0f, 100.0f, &sat) == 2.5f); // 0 + 2.5*1
    CHECK_FALSE(sat);
    CHECK(pid_step(&p, 2.0f, 100.0f, &sat) == 5.0f); // 2.5 + 2.5*2 - 2.5*1
    CHECK(pid_step(&p, 3.0f, 100.0f, &sat) == 8.5f); // 5 + 7.5 - 5 + 1
    CHECK(pid_step(&p, 0.0f, 100.0f, &sat) == 3.0f); // 8.5 + 0 - 7.5 + 2
    CHECK(pid_step(&p, 0.0f, 100.0f, &sat) == 6.0f); // 3 + 0 + 0 + 1*3
    CHECK(pid_step(&p, 0.0f, 100.0f, &sat) == 6.0f); // history empty of error: holds
    pid_reset(&p);
    CHECK(pid_step(&p, -1.0f, 100.0f, &sat) == -2.5f);
}

TEST_CASE("pid: clamping, and recovery without windup")
{
    pid_state_t p;
    pid_set_gains(&p, 0.0f, 10.0f, 0.0f, 0.1f); // pure trapezoidal integrator: A = B = 0.5
    bool sat = false;
    CHECK(pid_step(&p, 1.0f, 1.0f, &sat) == 0.5f);
    CHECK_FALSE(sat);
    for (int i = 0; i < 100; ++i) pid_step(&p, 1.0f, 1.0f, &sat);
    CHECK(sat);
    CHECK(p.u == 1.0f); // held at the clamp, not 100
    // Error reverses: an unclamped integrator would need ~100 steps to come back.
    CHECK(pid_step(&p, -1.0f, 1.0f, &sat) == 1.0f); // 1 - 0.5 + 0.5
    CHECK_FALSE(sat);
    CHECK(pid_step(&p, -1.0f, 1.0f, &sat) == 0.0f);
    CHECK(pid_step(&p, -1.0f, 1.0f, &sat) == -1.0f);
    CHECK(pid_step(&p, -1.0f, 1.0f, &sat) == -1.0f);
    CHECK(sat);
    // A lower cap (battery voltage rose) takes effect at once.
    CHECK(pid_step(&p, -1.0f, 0.5f, &sat) == -0.5f);
}

TEST_CASE("pid: extreme errors neither overflow nor stick")
{
    pid_state_t p;
    pid_set_gains(&p, float(kPaperKp), float(kPaperKi), float(kPaperKd), float(PID_T));
    bool sat = false;
    for (int i = 0; i < 1000; ++i) {
        int32_t err = (i % 2) ? 65534 : -65534; // setpoint and speed at opposite int16 ends
        int16_t d = pid_step_duty(&p, err, 10000, &sat);
        CHECK(std::abs(int(d)) <= 10000);
        CHECK(std::isfinite(p.u));
    }
    pid_reset(&p);
    // A constant extreme error: the first step hits the clamp; the second applies the
    // derivative term's decay, -(kd/T) e, to the clamped value and lands on the other
    // clamp. The clamped velocity form loses the part of each step the clamp cut off:
    // with the paper's gains in rpm and share of 12 V, any step over ~3 rpm does this
    // (docs/firmware.md). Then ki T e per step walks it back, from -1 to +1 of 12 V.
    CHECK(pid_step_duty(&p, 65534, 8000, &sat) == 8000);
    CHECK(pid_step_duty(&p, 65534, 8000, &sat) == -8000);
    int16_t last = -8000;
    for (int i = 0; i < 2000; ++i) {
        int16_t d = pid_step_duty(&p, 65534, 8000, &sat);
        CHECK(d >= last); // monotonic recovery by the integral term
        last = d;
    }
    CHECK(last == 8000);
    // Error flips to the other extreme with a lower cap: clamped at once...
    CHECK(pid_step_duty(&p, -65534, 5714, &sat) == -5714);
    // ... then the e_{k-2} term of the derivative (C e_{k-2}, still +65534) kicks the
    // output to the positive clamp for one step: the velocity form clips half of the
    // D-term's second difference. Bounded and finite is what can be asserted here.
    for (int i = 0; i < 1000; ++i) {
        int16_t d = pid_step_duty(&p, -65534, 5714, &sat);
        CHECK(std::abs(int(d)) <= 5714);
    }
    CHECK(std::isfinite(p.u));
}

TEST_CASE("pid: unit scaling of pid_step_duty")
{
    pid_state_t p;
    pid_set_gains(&p, 1.0f, 0.0f, 0.0f, float(PID_T)); // u = e (proportional only)
    bool sat = false;
    // Defaults: e in rpm, u the share of the motor's rated voltage.
    CHECK(PID_E_PER_RPM == 1.0);
    CHECK(PID_U_FULL == 1.0);
    // 5 crpm = 0.05 rpm -> u = 0.05 -> 5 % of 12 V: duty 0.05 x cap.
    CHECK(pid_step_duty(&p, 5, 10000, &sat) == 500);
    pid_reset(&p);
    CHECK(pid_step_duty(&p, 5, 8000, &sat) == 400);  // 15 V battery: cap 0.8
    pid_reset(&p);
    CHECK(pid_step_duty(&p, 50, 5714, &sat) == 2857);  // 21 V: u 0.5 of 12 V
    CHECK_FALSE(sat);
    pid_reset(&p);
    CHECK(pid_step_duty(&p, 1000, 8000, &sat) == 8000); // 10 rpm -> u 10, clamped at 1
    CHECK(sat);
    pid_reset(&p);
    CHECK(pid_step_duty(&p, 1000, 0, &sat) == 0); // cap 0 (voltage unknown): no drive
    CHECK(p.u == 0.0f);                            // and no wind-up
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
