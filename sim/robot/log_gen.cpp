// Batch log generator (log_gen.hpp, docs/robot-sim.md "auger-sim-log"): what the robot's and the
// gantry's runs share, the ideal screws and the encoders, and the truth file. The effects are in
// log_gen_effects.cpp, the runs in log_gen_robot.cpp and log_gen_gantry.cpp.
#include <cmath>

#include "auger/log.hpp"
#include "log_gen_internal.hpp"

namespace auger::sim {
namespace loggen {

Vec4 ideal_screw_step(Vec4& omega_rpm, const Vec4& target_rpm, double tau_s, double h_s) {
  const double a = std::exp(-h_s / tau_s);
  const Vec4 start = omega_rpm;
  omega_rpm = target_rpm + a * (start - target_rpm);
  return target_rpm + (start - target_rpm) * (tau_s / h_s * (1.0 - a));
}

double encoder_rpm(double rev_prev, double rev_now, double counts_per_rev) {
  const double counts = std::floor(rev_now * counts_per_rev) - std::floor(rev_prev * counts_per_rev);
  const double rpm = counts / counts_per_rev / kTick_s * 60.0;
  return std::round(rpm * 100.0) / 100.0;
}

}  // namespace loggen

void write_truth(const LogGenResult& r, std::ostream& out) {
  CsvLogWriter w(out, {{"format", "auger-sim-truth v1"}},
                 {"t_s", "x_m", "y_m", "psi_rad", "u_mps", "v_mps", "r_radps", "acting"});
  for (const TruthRow& t : r.truth) {
    const double row[8] = {t.t_s, t.eta[0], t.eta[1], t.eta[2], t.zeta[0], t.zeta[1], t.zeta[2], t.acting ? 1.0 : 0.0};
    w.write_row(row, 8);
  }
}

}  // namespace auger::sim
