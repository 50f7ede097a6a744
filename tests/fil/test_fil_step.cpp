// The velocity loop of eqs. (23)-(24) with the firmware's default (tuned) gains, on the real
// firmware in the simulator: rise time (10-90 %) <= 0.3 s, overshoot <= 10 %, steady-state
// error <= 0.5 rpm (issue 3), for 0 -> 10 rpm at 15 V and at 21 V battery, 10 -> 20 rpm, and
// a reversal 10 -> -10 rpm. docs/firmware.md has the figures and the paper's gains.
#include "fil_rig.hpp"

#include <catch2/catch.hpp>

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
