// The robot's log of the batch log generator (log_gen.hpp): the scripted screw commands, the true
// robot driven by them with the hidden effects (and the base alongside for the effect's size),
// where the effects act, and the sensors written as a robot log (docs/log-format.md).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

#include "auger/log.hpp"
#include "log_gen_internal.hpp"

namespace auger::sim {

using namespace loggen;

namespace {

double wrap(double a) { return wrap_angle(a); }

// Scripted screw commands, one per 10 ms tick, along the robot's three DOF patterns p_k
// (the rows of B normalised to a largest entry of 1: forward, sideways, turning).
class CommandScript {
 public:
  CommandScript(const Model& m, const LogGenConfig& c) : rng_(c.seed * 7919 + 17), cfg_(c) {
    for (int k = 0; k < 3; ++k) {
      const Vec4 row = m.B.row(k).transpose();
      pattern_[k] = row / row.cwiseAbs().maxCoeff();
    }
  }
  std::vector<Vec4> make(std::size_t n_ticks) {
    return cfg_.trajectory == Trajectory::single_dof ? single_dof(n_ticks) : manual(n_ticks);
  }

 private:
  // The paper's Table 4 runs: one DOF at a time, forward then back, at several speeds (jittered
  // per seed so no two logs share a speed), each move 4-6 s with 1-2 s standing between.
  std::vector<Vec4> single_dof(std::size_t n) {
    std::vector<Vec4> out;
    out.reserve(n);
    std::uniform_real_distribution<double> jitter(0.9, 1.1), move_s(4.0, 6.0), rest_s(1.0, 2.0);
    const double speeds_rpm[] = {5.0, 10.0, 15.0, 20.0};
    while (out.size() < n) {
      for (int dof = 0; dof < 3 && out.size() < n; ++dof)
        for (double w : speeds_rpm)
          for (double dir : {1.0, -1.0}) {
            const Vec4 cmd = dir * std::min(w * jitter(rng_), 22.0) * pattern_[dof];
            append(out, cmd, move_s(rng_), n);
            append(out, Vec4::Zero(), rest_s(rng_), n);
          }
    }
    return out;
  }
  // Manual driving: a person with a joystick, going somewhere. Every 1.5-5 s a new stick
  // position (stop, one DOF, or a mix of all three; forward more often than back), followed
  // through a first-order smoothing of 0.5 s; the screw speeds are the patterns' mix, scaled
  // down to 22 rpm if needed.
  std::vector<Vec4> manual(std::size_t n) {
    std::vector<Vec4> out;
    out.reserve(n);
    std::uniform_real_distribution<double> u01(0.0, 1.0), hold_s(1.5, 5.0), amp(-20.0, 20.0), fwd(-8.0, 20.0);
    Eigen::Vector3d stick = Eigen::Vector3d::Zero(), target = Eigen::Vector3d::Zero();
    double next_s = 0.0;
    const double a = 1.0 - std::exp(-kTick_s / 0.5);
    for (std::size_t k = 0; k < n; ++k) {
      const double t = static_cast<double>(k) * kTick_s;
      if (t >= next_s) {
        next_s = t + hold_s(rng_);
        const double kind = u01(rng_);
        target.setZero();
        if (kind < 0.15) {
          // stop
        } else if (kind < 0.5) {
          const int d = static_cast<int>(u01(rng_) * 3.0) % 3;
          target[d] = d == 0 ? fwd(rng_) : amp(rng_);
        } else {
          for (int d = 0; d < 3; ++d) target[d] = d == 0 ? fwd(rng_) : amp(rng_);
        }
      }
      stick += a * (target - stick);
      Vec4 cmd = stick[0] * pattern_[0] + stick[1] * pattern_[1] + stick[2] * pattern_[2];
      const double peak = cmd.cwiseAbs().maxCoeff();
      if (peak > 22.0) cmd *= 22.0 / peak;
      out.push_back(cmd);
    }
    return out;
  }
  static void append(std::vector<Vec4>& out, const Vec4& cmd, double dur_s, std::size_t n) {
    const auto ticks = static_cast<std::size_t>(std::lround(dur_s / kTick_s));
    for (std::size_t k = 0; k < ticks && out.size() < n; ++k) out.push_back(cmd);
  }

  std::mt19937_64 rng_;
  LogGenConfig cfg_;
  std::array<Vec4, 3> pattern_;
};

// The run's effects, checked: each applies to robot logs and is given once.
std::vector<EffectSpec> robot_effects(const LogGenConfig& cfg) {
  const std::vector<EffectSpec> effects = active_effects(cfg);
  for (const EffectSpec& e : effects) {
    if (!info_of(e.id).robot) throw std::invalid_argument("effect " + e.id + " applies to gantry logs only");
    for (const EffectSpec& o : effects)
      if (&o != &e && o.id == e.id) throw std::invalid_argument("effect " + e.id + " given twice");
  }
  return effects;
}

// Base truth = the nominal linear model (docs/robot-sim.md "Base truth of the log generator").
// The physical base: the robot the firmware-in-the-loop chain drives (TruthParams' defaults).
TruthParams base_truth(const LogGenConfig& cfg) {
  TruthParams base;
  base.coriolis = cfg.physical_base;
  base.nominal_yaw_time_constant = !cfg.physical_base;
  base.substep_s = 0.001;  // no stiff dry force in the base: 1 ms RK4 is exact to ~1e-9
  if (cfg.physical_base && cfg.blocking_rpm > 0 && cfg.terrain == "sand") {
    base.blocking.on = true;
    base.blocking.omega_block_rpm = cfg.blocking_rpm;
  }
  return base;
}

// What every pass of the physics shares: the commands, the base, the shafts' start angles.
struct RunSetup {
  const Model& nominal;
  const TruthParams& base;
  const LogGenConfig& cfg;
  const std::vector<Vec4>& cmd;
  Vec4 rev0;  // the shafts' angles at the start (revolutions)
  std::size_t n_ticks;
};

// One pass of the physics: the rows of the truth and the speeds the encoders measured.
struct Pass {
  std::vector<TruthRow> rows;
  std::vector<Vec4> omega_meas;
  Vec3 rms = Vec3::Zero();  // with_base: the effect's size (LogGenResult::effect_rms)
};

// The true robot (truth model mdl with p) driven by the ideal screws along the commands; with_base
// runs the base alongside, reset to the truth every size_segment_s, for the effect-size report.
Pass run_pass(const RunSetup& run, const TruthParams& p, const Model& mdl, bool with_base) {
  const LogGenConfig& cfg = run.cfg;
  Pass ps;
  ps.rows.reserve(run.n_ticks);
  ps.omega_meas.reserve(run.n_ticks);
  TrueRobot robot(mdl, p);
  TrueRobot base_robot(run.nominal, run.base);
  Vec4 omega = Vec4::Zero(), rev = run.rev0, rev_prev = run.rev0;
  Vec3 sq = Vec3::Zero();
  double next_reset_s = 0.0;
  for (std::size_t k = 0; k < run.n_ticks; ++k) {
    const double t = static_cast<double>(k) * kTick_s;
    Vec4 meas;
    for (int i = 0; i < 4; ++i) meas[i] = k == 0 ? 0.0 : encoder_rpm(rev_prev[i], rev[i], cfg.counts_per_rev);
    rev_prev = rev;
    ps.omega_meas.push_back(meas);
    ps.rows.push_back({t, robot.state().eta, robot.state().zeta, false});
    if (with_base) {
      if (t >= next_reset_s - 1e-9) {
        base_robot.set_state(robot.state());
        next_reset_s += cfg.size_segment_s;
      }
      Vec3 d = robot.state().eta - base_robot.state().eta;
      d[2] = wrap(d[2]);
      sq += d.cwiseProduct(d);
    }
    if (k + 1 == run.n_ticks) break;
    for (int j = 0; j < 10; ++j) {
      const Vec4 mean_rpm = ideal_screw_step(omega, run.cmd[k], cfg.ideal_tau_s, kCouple_s);
      robot.step(mean_rpm, kCouple_s);
      if (with_base) base_robot.step(mean_rpm, kCouple_s);
      rev += mean_rpm * (kCouple_s / 60.0);
    }
  }
  if (with_base) ps.rms = (sq / static_cast<double>(run.n_ticks)).cwiseSqrt();
  return ps;
}

// Puts the soft patch on the base path, where the robot passes once: among the path's positions
// between 30 and 70 % of the run, the one the robot's footprint (about 0.35 m around the centre)
// covers for the shortest time; ties go to the one nearest at_frac of the run. Returns the note.
std::string place_soft_patch(const RunSetup& run, const EffectSpec& patch_spec, TruthParams& tp) {
  const Pass probe = run_pass(run, run.base, run.nominal, false);
  const double frac = std::clamp(param(patch_spec, "at_frac"), 0.0, 1.0);
  const std::size_t n = probe.rows.size();
  const double reach_m = tp.soft_patch.radius_m + 0.35;
  std::size_t best = n / 2;
  double best_cost = 1e300;
  for (std::size_t k = 3 * n / 10; k < 7 * n / 10; k += 50) {
    std::size_t covered = 0;
    for (std::size_t j = 0; j < n; j += 10)
      covered += (probe.rows[j].eta.head<2>() - probe.rows[k].eta.head<2>()).norm() < reach_m;
    const double cost = static_cast<double>(covered) * 10.0 / static_cast<double>(n) +
                        0.05 * std::fabs(static_cast<double>(k) / static_cast<double>(n) - frac);
    if (cost < best_cost) {
      best_cost = cost;
      best = k;
    }
  }
  // Under a contact (the front-right screw's), not under the centre: the robot straddles a
  // small patch centred on its own path.
  const Vec3& eb = probe.rows[best].eta;
  const double cb = std::cos(eb[2]), sb = std::sin(eb[2]);
  const ScrewMount& sc0 = run.nominal.screws[0];
  tp.soft_patch.x_m = eb[0] + cb * sc0.x_m - sb * sc0.y_m;
  tp.soft_patch.y_m = eb[1] + sb * sc0.x_m + cb * sc0.y_m;
  char note[160];
  std::snprintf(note, sizeof note, "soft_patch centre (%.3f, %.3f) m radius %.2f m (base path at t = %.1f s)",
                tp.soft_patch.x_m, tp.soft_patch.y_m, tp.soft_patch.radius_m, probe.rows[best].t_s);
  return note;
}

// Where the effects act (any of them): a contact on the soft patch, after a terrain change or a
// traction loss's start, everywhere for the others.
void mark_acting(std::vector<TruthRow>& rows, const std::vector<EffectSpec>& effects, const TruthParams& tp,
                 const Model& nominal) {
  const auto screws = nominal.screws;
  for (TruthRow& r : rows) {
    for (const EffectSpec& e : effects) {
      if (e.id == "soft_patch") {
        const double c = std::cos(r.eta[2]), s = std::sin(r.eta[2]);
        for (const auto& sc : screws) {
          const double xw = r.eta[0] + c * sc.x_m - s * sc.y_m, yw = r.eta[1] + s * sc.x_m + c * sc.y_m;
          if (std::hypot(xw - tp.soft_patch.x_m, yw - tp.soft_patch.y_m) < tp.soft_patch.radius_m) r.acting = true;
        }
      } else if (e.id == "terrain_change") {
        r.acting = r.acting || r.t_s >= tp.terrain_change.t_s;
      } else if (e.id == "screw_traction_loss") {
        r.acting = r.acting || r.t_s >= tp.loss.t_on_s;
      } else {
        r.acting = true;
      }
    }
  }
}

// The sensors, written as a robot log. The camera: white Gaussian noise, one frame per
// 1 / pose_rate_hz; with a time offset its frame stamped t shows the pose at t - dt (linear
// interpolation between rows). The IMU: heading with its bias and drift, and yaw rate, each
// with white noise.
void write_robot_log(const Pass& ps, const std::vector<Vec4>& cmd, const std::vector<EffectSpec>& effects,
                     const LogGenConfig& cfg, std::ostream& out) {
  const EffectSpec* offset_spec = find_effect(effects, "pose_time_offset");
  const EffectSpec* bias_spec = find_effect(effects, "imu_heading_bias");
  const EffectSpec* drift_spec = find_effect(effects, "imu_heading_drift");
  const double dt_off = offset_spec ? param(*offset_spec, "dt_s") : 0.0;
  const double bias = bias_spec ? param(*bias_spec, "bias_rad") : 0.0;
  const double drift = drift_spec ? param(*drift_spec, "drift_radps") : 0.0;
  std::mt19937_64 rng(cfg.seed * 2654435761ULL + 11);
  std::normal_distribution<double> n01(0.0, 1.0);
  const auto stride = std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(1.0 / (cfg.pose_rate_hz * kTick_s))));
  RobotLogWriter log(out, {{"format", kRobotLogFormat}, {"terrain", cfg.terrain}});
  const double t_end = ps.rows.back().t_s;
  for (std::size_t k = 0; k < ps.rows.size(); ++k) {
    const TruthRow& r = ps.rows[k];
    RobotSample s;
    s.t_s = r.t_s;
    for (int i = 0; i < 4; ++i) {
      s.omega_rpm[static_cast<std::size_t>(i)] = ps.omega_meas[k][i];
      s.cmd_rpm[static_cast<std::size_t>(i)] = std::round(cmd[k][i] * 100.0) / 100.0;
    }
    const Vec3 noise(n01(rng), n01(rng), n01(rng));  // drawn every row: the same seed, the same noise
    if (k % stride == 0) {
      const double ts = r.t_s - dt_off;
      if (ts >= 0.0 && ts <= t_end) {
        const auto j = std::min(ps.rows.size() - 2, static_cast<std::size_t>(ts / kTick_s));
        const double f = (ts - ps.rows[j].t_s) / kTick_s;
        Vec3 pose = (1 - f) * ps.rows[j].eta + f * ps.rows[j + 1].eta;
        pose += cfg.pose_noise.cwiseProduct(noise);
        s.x_m = pose[0];
        s.y_m = pose[1];
        s.psi_rad = wrap(pose[2]);
      }
    }
    const double ni = n01(rng), nr = n01(rng);
    s.imu_psi_rad = wrap(r.eta[2] + bias + drift * r.t_s + cfg.imu_psi_noise_rad * ni);
    s.imu_r_radps = r.zeta[2] + cfg.imu_r_noise_radps * nr;
    log.write(s);
  }
}

}  // namespace

LogGenResult generate_robot_log(const Model& nominal, const LogGenConfig& cfg, std::ostream& out) {
  const std::vector<EffectSpec> effects = robot_effects(cfg);
  if (!(cfg.seconds > 0)) throw std::invalid_argument("--seconds must be > 0");
  const auto n_ticks = static_cast<std::size_t>(std::lround(cfg.seconds / kTick_s)) + 1;

  const TruthParams base = base_truth(cfg);
  TruthParams tp = base;
  Model truth_model = nominal;
  for (const EffectSpec& e : effects) apply_robot_effect(e, cfg.seconds, tp, truth_model);
  if (tp.friction.on || tp.blocking.on) tp.substep_s = 0.0005;
  const EffectSpec* patch_spec = find_effect(effects, "soft_patch");

  CommandScript script(nominal, cfg);
  const std::vector<Vec4> cmd = script.make(n_ticks);

  LogGenResult res;
  std::mt19937_64 enc_rng(cfg.seed * 104729 + 3);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  Vec4 rev0;
  for (int i = 0; i < 4; ++i) rev0[i] = u01(enc_rng);
  const RunSetup run{nominal, base, cfg, cmd, rev0, n_ticks};

  if (tp.soft_patch.on) res.notes.push_back(place_soft_patch(run, *patch_spec, tp));
  bool physical = false;
  for (const EffectSpec& e : effects)
    physical = physical || !(e.id == "pose_time_offset" || e.id == "imu_heading_bias" || e.id == "imu_heading_drift");
  Pass ps = run_pass(run, tp, truth_model, physical);
  res.effect_rms = ps.rms;
  mark_acting(ps.rows, effects, tp, nominal);
  write_robot_log(ps, cmd, effects, cfg, out);
  res.truth = std::move(ps.rows);
  return res;
}

}  // namespace auger::sim
