// The velocity loop of eqs. (23)-(24) with the firmware's default (tuned) gains, on the real
// firmware in the simulator: rise time (10-90 %) <= 0.3 s, overshoot <= 10 %, steady-state
// error <= 0.5 rpm (issue 3), for 0 -> 10 rpm at 15 V and at 21 V battery, 10 -> 20 rpm, and
// a reversal 10 -> -10 rpm. docs/firmware.md has the figures and the paper's gains.
#include "config.h"
#include "fil_rig.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

using namespace auger::fil;

namespace {

StepMetrics step(double battery_v, double from_rpm, double to_rpm)
{
    Rig rig(RigOptions{1, battery_v, 1});
    rig.run_for(0.05);
    // 15 V is below the default 16.0 V under-voltage stop; the loop is under test here.
    if (battery_v < 16.0) rig.reconfigure(0, [](proto_config_t& c) { c.undervoltage_mv = 14000; });
    rig.command(0, from_rpm, PROTO_SP_ENABLE);
    rig.run_for(1.0);
    const double t_step = rig.t_s();
    rig.command(0, to_rpm, PROTO_SP_ENABLE);
    rig.run_for(1.5);
    REQUIRE((rig.last(0).tm.status & PROTO_F_MASK) == 0);
    return step_metrics(rig.telemetry(0), t_step, from_rpm, to_rpm);
}

}  // namespace

TEST_CASE("velocity step responses meet the loop criteria", "[fil][pid]")
{
    struct Case {
        double battery_v, from_rpm, to_rpm;
    };
    const Case cases[] = {{15.0, 0.0, 10.0}, {21.0, 0.0, 10.0}, {18.0, 10.0, 20.0},
                          {18.0, 10.0, -10.0}, {15.0, -10.0, 10.0}};
    for (const Case& c : cases) {
        StepMetrics m = step(c.battery_v, c.from_rpm, c.to_rpm);
        INFO(c.battery_v << " V, " << c.from_rpm << " -> " << c.to_rpm << " rpm: rise "
                         << m.rise_time_s << " s, overshoot " << m.overshoot_pct
                         << " %, steady-state error " << m.steady_error_rpm << " rpm");
        CHECK(m.rise_time_s <= 0.3);
        CHECK(m.overshoot_pct <= 10.0);
        CHECK(m.steady_error_rpm <= 0.5);
    }
}

TEST_CASE("the loop holds its speed under a terrain load", "[fil][pid]")
{
    Rig rig(RigOptions{1, 18.0, 1});
    rig.command(0, 10.0, PROTO_SP_ENABLE);
    rig.run_for(1.0);
    motor_params_t p;
    motor_params_default(&p);
    // A third of the stall torque at 12 V, applied at once (the screw bites into sand).
    simmod_set_load_torque(rig.sim(), 0, motor_model_stall_out_nm(&p, 12.0) / 3.0);
    const double t_load = rig.t_s();
    rig.run_for(1.5);
    StepMetrics m = step_metrics(rig.telemetry(0), t_load, 10.0, 10.0 + 1e-9);
    CHECK(m.steady_error_rpm <= 0.5);
    // The dip recovers within 0.3 s.
    double worst_late = 0;
    for (const auto& t : rig.telemetry(0))
        if (t.t_s > t_load + 0.3) worst_late = std::max(worst_late, std::fabs(t.omega_rpm() - 10.0));
    CHECK(worst_late <= 0.7);  // two counts of the 0.34 rpm velocity quantum
}

TEST_CASE("the fixed-point loop computes eq. (23) on these steps as a double-precision one would",
          "[fil][pid]")
{
    // The firmware's PID is fixed point (firmware/pid.h). Replay the errors it saw, from its
    // own telemetry (setpoint in use and measured speed of each 10 ms step), through eq. (23)
    // with eq. (24)'s A, B, C in double, clamped at the rated voltage and scaled by the duty
    // cap of the same step (12 V / the reported battery voltage): the duty it applied must be
    // the double's within the quantisation (1 of 10000: the PWM's step is 10). The current
    // foldback (its own clamp) is off, so the output clamp is the duty cap's alone.
    const double t = PID_T, A = KP + KI * t / 2 + KD / t, B = -KP + KI * t / 2 - 2 * KD / t, C = KD / t;
    struct Case {
        double battery_v, from_rpm, to_rpm;
    };
    int compared = 0, worst = 0, at_clamp = 0;
    // The steps of the test above, and one to 30 rpm (more than the motor has: the clamp).
    for (const Case c : {Case{15.0, 0.0, 10.0}, Case{21.0, 0.0, 10.0}, Case{18.0, 10.0, 20.0},
                         Case{18.0, 10.0, -10.0}, Case{15.0, -10.0, 10.0}, Case{21.0, 0.0, 30.0}}) {
        Rig rig(RigOptions{1, c.battery_v, 1});
        rig.run_for(0.05);
        rig.reconfigure(0, [](proto_config_t& cfg) {
            cfg.undervoltage_mv = 14000;
            cfg.foldback_ma = 0;
        });
        const size_t first = rig.telemetry(0).size();
        rig.command(0, c.from_rpm, PROTO_SP_ENABLE);
        rig.run_for(1.0);
        rig.command(0, c.to_rpm, PROTO_SP_ENABLE);
        rig.run_for(1.5);
        REQUIRE(rig.host_dropped(0) == 0);
        double u = 0, e1 = 0, e2 = 0;
        const auto& tel = rig.telemetry(0);
        for (size_t i = first; i < tel.size(); ++i) {
            const proto_telemetry_t& tm = tel[i].tm;
            if (!(tm.status & PROTO_ST_ENABLED)) continue;  // the PID starts from rest at enable
            REQUIRE(tel[i].tm.time_ms - tel[i - 1].tm.time_ms == 10);  // every step is here
            const double cap = std::min(1.0, 12000.0 / tm.voltage_mv);
            const double err_crpm = std::clamp(double(tm.omega_cmd_crpm - tm.omega_crpm), -8191.0, 8191.0);
            const double e = err_crpm / 100.0 * PID_E_PER_RPM;
            u = std::clamp(u + A * e + B * e1 + C * e2, -double(PID_U_FULL), double(PID_U_FULL));
            e2 = e1;
            e1 = e;
            const double duty = u / PID_U_FULL * cap * 10000.0;
            const int diff = std::abs(tm.duty_x10000 - int(std::lround(duty)));
            worst = std::max(worst, diff);
            at_clamp += std::fabs(u) == PID_U_FULL;
            ++compared;
        }
    }
    INFO(compared << " steps compared, " << at_clamp << " at the clamp; largest difference " << worst << " of 10000");
    CHECK(compared > 1000);
    CHECK(at_clamp > 0);
    CHECK(worst <= 1);
}
