// Shared helpers of the simulated-robot tests.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "auger/log.hpp"
#include "auger/model_file.hpp"
#include "protocol.h"
#include "scheduler.hpp"

namespace robot_test {

inline const auger::ModelFile& model_file() {
  static const auger::ModelFile f = auger::load_model_file(AUGER_MODEL_FILE);
  return f;
}
inline auger::Model nominal(const std::string& terrain) { return auger::build_model(model_file(), terrain); }

// Patterns of eq. (10)'s B: +x (B's x row), +y (its y row), pure yaw (all screws alike).
inline const auger::Vec4 kForward(-1, -1, 1, 1);
inline const auger::Vec4 kLateral(-1, 1, 1, -1);
inline const auger::Vec4 kYaw(1, 1, 1, 1);

// RMS of the true pose against the controller's reference over the enabled ticks from t0_s.
struct Rms {
  double pos_m = 0, psi_rad = 0;
};
inline Rms tracking_rms(const std::vector<auger::sim::TickRecord>& h, double t0_s) {
  double sp = 0, sa = 0;
  int n = 0;
  for (const auto& r : h) {
    if (!r.enabled || r.t_s < t0_s) continue;
    sp += (r.eta_true.head<2>() - r.eta_ref.head<2>()).squaredNorm();
    const double e = auger::wrap_angle(r.eta_true[2] - r.eta_ref[2]);
    sa += e * e;
    ++n;
  }
  if (n == 0) return {NAN, NAN};
  return {std::sqrt(sp / n), std::sqrt(sa / n)};
}

// The paper's open problem on sand: a 0.5 m move along the "helix diagonal", the direction in
// which screws 0 and 2 alone drive the nominal robot: atan((sigma_lat / D_y) / (sigma_long / D_x))
// = 28.0 deg on sand, near the 30 deg helix angle. Moving there at steady speed takes a force
// that the pseudo-inverse puts on screws 0 and 2 only, so screws 1 and 3 stop and block
// (docs/model-notes.md "Blocking").
struct DiagonalRun {
  double miss_m = 0;         // distance from the goal at the end
  double progress_m = 0;     // distance travelled towards the goal
  double max_abs_psi_rad = 0;
  int module_status_or = 0;  // the modules' status words ORed over the run (fault bits: none expected)
  double current_limited_frac = 0;  // share of module samples with the current foldback active
};

// The modules' status words (robot log status_N) ORed over a log written by the scheduler.
inline int status_or(const std::string& log_text) {
  std::istringstream in(log_text);
  auger::RobotLogReader reader(in, "scheduler log");
  auger::RobotSample s;
  int st = 0;
  while (reader.next(s))
    for (const auto& v : s.status)
      if (v) st |= int(*v);
  return st;
}
// The share of module samples (robot log status_N) that carry the given status bit.
inline double status_bit_frac(const std::string& log_text, int bit) {
  std::istringstream in(log_text);
  auger::RobotLogReader reader(in, "scheduler log");
  auger::RobotSample s;
  long with = 0, all = 0;
  while (reader.next(s))
    for (const auto& v : s.status)
      if (v) ++all, with += (int(*v) & bit) != 0;
  return all ? double(with) / double(all) : 0.0;
}
inline double diagonal_angle_rad(const auger::Model& m) {
  return std::atan2(m.terrain.sigma_lat / m.terrain.D_y, m.terrain.sigma_long / m.terrain.D_x);
}
inline DiagonalRun run_diagonal(auger::sim::ScrewMode mode, auger::AllocatorKind kind, double omega_block_rpm,
                                double duration_s, std::uint64_t seed = 1, bool noiseless_sensors = false) {
  using namespace auger;
  const Model m = nominal("sand");
  ControllerConfig cc = controller_config(model_file(), "sand");
  cc.allocator.kind = kind;
  // Keep every screw clearly above the blocking threshold when the null-space allocator engages,
  // and engage as soon as any screw would turn faster than blocking allows.
  cc.allocator.omega_min_rpm = std::max(3.0, omega_block_rpm + 1.0);
  cc.allocator.engage_rpm = omega_block_rpm;
  cc.gamma_per_s = Vec3::Constant(0.2);
  Controller c(m, cc);
  sim::TruthParams tp;
  tp.blocking.on = true;
  tp.blocking.omega_block_rpm = omega_block_rpm;
  sim::SchedulerConfig sc;
  sc.mode = mode;
  sc.elf_path = AUGER_FIRMWARE_ELF_PATH;
  sc.seed = seed;
  sc.terrain = "sand";
  if (noiseless_sensors) {
    sc.camera.noise_std.setZero();
    sc.imu = sim::ImuParams{0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  }
  sim::Scheduler s(m, tp, sc);
  std::ostringstream log;
  s.set_log(&log);
  s.set_controller(&c);
  s.run_until(0.1);  // modules boot
  c.set_waypoints({{0.0, Vec3(0.5 * std::cos(diagonal_angle_rad(m)), 0.5 * std::sin(diagonal_angle_rad(m)), 0.0)}});
  c.set_enabled(true);
  s.run_until(0.1 + duration_s);
  DiagonalRun r;
  const Vec3 goal(0.5 * std::cos(diagonal_angle_rad(m)), 0.5 * std::sin(diagonal_angle_rad(m)), 0.0);
  const Vec3& eta = s.robot().state().eta;
  r.miss_m = (eta.head<2>() - goal.head<2>()).norm();
  r.progress_m = eta.head<2>().dot(goal.head<2>().normalized());
  for (const auto& h : s.history()) r.max_abs_psi_rad = std::max(r.max_abs_psi_rad, std::fabs(h.eta_true[2]));
  s.set_log(nullptr);
  if (mode == sim::ScrewMode::fil) {
    r.module_status_or = status_or(log.str());
    r.current_limited_frac = status_bit_frac(log.str(), PROTO_ST_CURRENT_LIMITED);
  }
  return r;
}

}  // namespace robot_test
