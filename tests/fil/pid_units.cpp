// Experiment: under which units do the paper's PID gains (kp 0.5, ki 0.0003, kd 0.005,
// T 10 ms, eqs. (23)-(24)) give a working velocity loop? Runs the real firmware in the
// simulator and measures the 0 -> 10 rpm step at 15 V and 21 V for each interpretation of
// the units of e, u and T, by loading the equivalent gains in the firmware's own units
// (e: screw rpm, u: share of the rated motor voltage, T: s) through CONFIG frames.
//   pid_units                 the paper's gains under every interpretation
//   pid_units KP KI KD        one gain set in the firmware's units
// Criteria (issue 3): rise time <= 0.3 s, overshoot <= 10 %, steady-state error <= 0.5 rpm.
#include "fil_rig.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

using namespace auger::fil;

namespace {

struct Result {
    StepMetrics m;
    uint16_t faults;
    bool current_limited;  // the current foldback acted at some point
};

Result step_test(double kp, double ki, double kd, double battery_v)
{
    Rig rig(RigOptions{1, battery_v, 1});
    rig.run_for(0.05);
    rig.reconfigure(0, [&](proto_config_t& c) {
        c.kp = float(kp);
        c.ki = float(ki);
        c.kd = float(kd);
        // 15 V is below the default 16.0 V under-voltage stop; the loop is what is measured.
        c.undervoltage_mv = 14000;
    });
    rig.command(0, 0.0, PROTO_SP_ENABLE);
    rig.run_for(0.2);
    const double t_step = rig.t_s();
    rig.command(0, 10.0, PROTO_SP_ENABLE);
    rig.run_for(2.0);
    uint16_t status = 0;
    for (const auto& t : rig.telemetry(0)) status |= t.tm.status;
    return {step_metrics(rig.telemetry(0), t_step, 0.0, 10.0), uint16_t(status & PROTO_F_MASK),
            (status & PROTO_ST_CURRENT_LIMITED) != 0};
}

bool works(const Result& r)
{
    return !r.faults && r.m.rise_time_s <= 0.3 && r.m.overshoot_pct <= 10.0 &&
           r.m.steady_error_rpm <= 0.5;
}

void row(const char* name, double kp, double ki, double kd)
{
    std::printf("| %s | %.4g / %.4g / %.4g |", name, kp, ki, kd);
    bool all = true;
    for (double v : {15.0, 21.0}) {
        Result r = step_test(kp, ki, kd, v);
        all = all && works(r);
        std::printf(" %.2f s, %.0f %%, %.2f rpm%s%s%s%s |", r.m.rise_time_s, r.m.overshoot_pct,
                    r.m.steady_error_rpm, r.faults & PROTO_F_OVERCURRENT ? ", overcurrent" : "",
                    r.faults & PROTO_F_UNDERVOLTAGE ? ", under-voltage" : "",
                    r.faults & PROTO_F_STALL ? ", stall" : "", r.current_limited ? ", current-limited" : "");
    }
    std::printf(" %s |\n", all ? "yes" : "no");
    std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv)
{
    std::printf("| interpretation | kp / ki / kd in firmware units (e rpm, u share of 12 V, T s) |"
                " 15 V: rise, overshoot, error | 21 V: rise, overshoot, error | works |\n");
    std::printf("|---|---|---|---|---|\n");
    if (argc == 4) {
        row("given", std::atof(argv[1]), std::atof(argv[2]), std::atof(argv[3]));
        return 0;
    }
    const double kp = 0.5, ki = 0.0003, kd = 0.005;
    // e per screw rpm: counts/10 ms and counts/s use 48 x 369 counts per screw turn.
    const double counts_per_rev = 48.0 * 369.0;
    struct Unit {
        const char* name;
        double scale;
    };
    const Unit e_units[] = {{"e screw rpm", 1.0},
                            {"e motor rpm", 369.0},
                            {"e screw rad/s", 2 * M_PI / 60},
                            {"e counts/10 ms", counts_per_rev / 60 / 100},
                            {"e counts/s", counts_per_rev / 60}};
    // u per share of the rated voltage, at the 18 V mid-pack voltage for duty-based units.
    const double duty_per_share = 12.0 / 18.0;
    const Unit u_units[] = {{"u share of 12 V", 1.0},
                            {"u duty 0..1", duty_per_share},
                            {"u PWM 0..255", 255 * duty_per_share},
                            {"u PWM 0..999", 999 * duty_per_share}};
    const Unit t_units[] = {{"T s", 1.0}, {"T ms", 1000.0}};
    for (const auto& t : t_units)
        for (const auto& e : e_units)
            for (const auto& u : u_units) {
                // kp e_u -> u_u: in firmware units multiply by e.scale / u.scale; ki T and
                // kd / T must keep their values with T expressed in t's unit.
                double s = e.scale / u.scale;
                std::string name = std::string(e.name) + ", " + u.name + ", " + t.name;
                row(name.c_str(), kp * s, ki * s * t.scale, kd * s / t.scale);
            }
    return 0;
}
