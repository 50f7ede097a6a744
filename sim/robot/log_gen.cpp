// Batch log generator: see log_gen.hpp and docs/robot-sim.md.
#include "log_gen.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <sstream>
#include <stdexcept>

#include "auger/log.hpp"
#include "true_gantry.hpp"
#include "true_robot.hpp"

namespace auger::sim {

namespace {

constexpr double kTick_s = 0.01;     // log rows and screw commands (the host loop, 100 Hz)
constexpr double kCouple_s = 0.001;  // screw lag <-> robot exchange, as the scheduler does

double param(const EffectSpec& e, const std::string& name);

// What an effect sets on the robot's truth, and on the gantry's.
struct RobotTruth {
  TruthParams& tp;
  Model& model;    // the truth's nominal part (paper_params rebuilds it)
  double seconds;  // the run's length (terrain_change's time)
};
struct GantryTruth {
  GantryTruthParams& gp;  // holds the rail's mass, sigma, drag and B on entry
  bool lateral;
  double rail_m;
};
using RobotForm = void (*)(const EffectSpec&, RobotTruth&);
using GantryForm = void (*)(const EffectSpec&, GantryTruth&);

// One row per hidden effect: its parameters with their defaults, and its physics in the true
// robot (TrueRobot) and on the gantry (TrueGantry, the robot's shapes along one DOF). A null form
// changes no physics: the sensor effects act when the log is written.
struct EffectRow {
  EffectInfo info;
  RobotForm robot = nullptr;
  GantryForm gantry = nullptr;
};

void robot_friction(const EffectSpec& e, RobotTruth& r) {
  TruthParams& tp = r.tp;
  const bool stick = e.id == "stick_slip_friction";
  const double ratio = stick ? param(e, "stiction_ratio") : 1.0;
  tp.friction.on = true;
  tp.friction.per_axis = true;
  tp.friction.coulomb_n = param(e, "force_x_n");
  tp.friction.y_ratio = param(e, "force_x_n") > 0 ? param(e, "force_y_n") / param(e, "force_x_n") : 1.0;
  tp.friction.stiction_n = param(e, "force_x_n") * ratio;
  tp.friction.stribeck_mps = stick ? param(e, "stribeck_mps") : 0.01;
  // Yaw: the same curve at the contacts' distance from the centre (about 0.33 m), so the
  // Stribeck speed in yaw is v_s / 0.33 m; smoothing 0.5 mrad/s (RK4 allows far less).
  tp.friction.stribeck_radps = tp.friction.stribeck_mps / 0.33;
  tp.friction.eps_radps = 0.0005;
  tp.friction.coulomb_nm = param(e, "torque_nm");
  tp.friction.stiction_nm = param(e, "torque_nm") * ratio;
  // Smoothing width as small as the 0.5 ms RK4 step allows (slope F_s / eps at rest, lambda h
  // about 2.2 of TrueRobot's limit 2.5): a force below the breakaway level creeps at about
  // eps atanh(F / F_s), which must stay well below what the camera resolves.
  const double f_max = std::max(tp.friction.stiction_n, tp.friction.stiction_n * tp.friction.y_ratio);
  tp.friction.eps_mps = std::max(0.0001, f_max / r.model.robot.m_kg * 0.0005 / 2.2);
}

void gantry_friction(const EffectSpec& e, GantryTruth& g) {
  GantryTruthParams& gp = g.gp;
  const bool stick = e.id == "stick_slip_friction";
  gp.friction.on = true;
  gp.friction.coulomb_n = param(e, g.lateral ? "force_y_n" : "force_x_n");
  gp.friction.stiction_n = stick ? gp.friction.coulomb_n * param(e, "stiction_ratio") : gp.friction.coulomb_n;
  gp.friction.stribeck_mps = stick ? param(e, "stribeck_mps") : 1;
  gp.friction.eps_mps = std::max(0.0001, gp.friction.stiction_n / gp.mass_kg * (kCouple_s / 2) / 2.2);  // as the robot's
}

const std::vector<EffectRow>& effect_rows() {
  static const std::vector<EffectRow> t = {
      {{"none", true, true, {}, "no hidden effect: the truth is the nominal model"}},
      {{"coulomb_friction", true, true, {{"force_x_n", 8.0}, {"force_y_n", 6.0}, {"torque_nm", 1.0}},
        "per axis level x tanh(speed / 0.3 mm/s) (smooth, no breakaway peak); yaw the same on r"},
       robot_friction, gantry_friction},
      {{"stick_slip_friction", true, true,
        {{"force_x_n", 8.0}, {"force_y_n", 6.0}, {"torque_nm", 1.0}, {"stiction_ratio", 1.5}, {"stribeck_mps", 0.01}},
        "per axis Stribeck curve (breakaway stiction_ratio x the sliding level, decaying as exp(-(v/v_s)^2)) x tanh"},
       robot_friction, gantry_friction},
      {{"quadratic_drag", true, true, {{"c_x", 1500.0}, {"c_y", 1500.0}, {"c_psi", 0.0}},
        "per DOF -c u sqrt(u^2 + u0^2), u0 5 mm/s (smooth at rest); yaw c_psi with r0 0.01 rad/s"},
       [](const EffectSpec& e, RobotTruth& r) {
         r.tp.quad_drag.on = true;
         r.tp.quad_drag.c_x_nspm2 = param(e, "c_x");
         r.tp.quad_drag.c_y_nspm2 = param(e, "c_y");
         r.tp.quad_drag.c_psi_nmspr2 = param(e, "c_psi");
       },
       [](const EffectSpec& e, GantryTruth& g) {
         g.gp.quad_drag.on = true;
         g.gp.quad_drag.c_nspm2 = param(e, g.lateral ? "c_y" : "c_x");
       }},
      {{"screw_traction_loss", true, false, {{"screw", 0}, {"loss", 0.6}, {"t_on_s", 0.0}},
        "one screw loses the fraction loss of its traction, at its contact point"},
       [](const EffectSpec& e, RobotTruth& r) {
         r.tp.loss.on = true;
         r.tp.loss.screw = static_cast<int>(param(e, "screw"));
         if (r.tp.loss.screw < 0 || r.tp.loss.screw > 3)
           throw std::invalid_argument("screw_traction_loss: screw must be 0..3");
         r.tp.loss.factor = 1.0 - param(e, "loss");
         r.tp.loss.t_on_s = param(e, "t_on_s");
       }},
      {{"traction_saturation", true, true, {{"long_max_n", 12.0}, {"lat_max_n", 4.0}, {"sharpness", 0.0}},
        "per screw and axis f / (1 + |f / f_max|^n)^(1/n) (n = sharpness; 0: f_max tanh(f / f_max))"},
       [](const EffectSpec& e, RobotTruth& r) {
         r.tp.saturation.on = true;
         r.tp.saturation.long_max_n = param(e, "long_max_n");
         r.tp.saturation.lat_max_n = param(e, "lat_max_n");
         r.tp.saturation.sharpness = param(e, "sharpness");
       },
       [](const EffectSpec& e, GantryTruth& g) {
         g.gp.saturation.on = true;
         g.gp.saturation.max_n = param(e, g.lateral ? "lat_max_n" : "long_max_n");
         g.gp.saturation.sharpness = param(e, "sharpness");
       }},
      {{"force_lag", true, true, {{"tau_s", 0.15}, {"damping", 0.8}}, "second-order build-up of traction"},
       [](const EffectSpec& e, RobotTruth& r) {
         r.tp.lag.on = true;
         r.tp.lag.tau_s = param(e, "tau_s");
         r.tp.lag.damping = param(e, "damping");
       },
       [](const EffectSpec& e, GantryTruth& g) {
         g.gp.lag.on = true;
         g.gp.lag.tau_s = param(e, "tau_s");
         g.gp.lag.damping = param(e, "damping");
       }},
      {{"screw_dead_band", true, true, {{"omega_rpm", 2.0}, {"corner_frac", 0.1}},
        "smooth dead band: softplus corner of width corner_frac w0 (0: omega - w0 tanh(omega / w0))"},
       [](const EffectSpec& e, RobotTruth& r) {
         r.tp.dead_band.on = true;
         r.tp.dead_band.omega_dead_rpm = param(e, "omega_rpm");
         r.tp.dead_band.corner_rpm = param(e, "corner_frac") * param(e, "omega_rpm");
       },
       [](const EffectSpec& e, GantryTruth& g) {
         g.gp.dead_band.on = true;
         g.gp.dead_band.omega_dead_rpm = param(e, "omega_rpm");
         g.gp.dead_band.corner_rpm = param(e, "corner_frac") * g.gp.dead_band.omega_dead_rpm;
       }},
      {{"terrain_slope", true, false, {{"roll_deg", 0.0}, {"pitch_deg", 2.0}},
        "3-D incline: ground normal R_y(pitch) R_x(roll) e_z"},
       [](const EffectSpec& e, RobotTruth& r) {
         r.tp.incline.on = true;
         r.tp.incline.roll_rad = deg_to_rad(param(e, "roll_deg"));
         r.tp.incline.pitch_rad = deg_to_rad(param(e, "pitch_deg"));
       }},
      {{"resistance_offset", true, false, {{"asym", 0.2}},
        "front contacts plough (1 + asym), rear (1 - asym) x their drag"},
       [](const EffectSpec& e, RobotTruth& r) {
         r.tp.offset.on = true;
         r.tp.offset.asym = param(e, "asym");
       }},
      {{"pose_time_offset", true, false, {{"dt_s", 0.1}}, "pose at t is the true pose at t - dt_s"}},
      {{"imu_heading_bias", true, false, {{"bias_rad", 0.05}}, "imu_psi = psi + bias"}},
      {{"imu_heading_drift", true, false, {{"drift_radps", 3e-4}}, "imu_psi = psi + drift t"}},
      {{"terrain_change", true, false,
        {{"t_frac", 0.5}, {"sigma_scale", 0.7}, {"drag_scale", 1.3}, {"width_s", 0.5}},
        "sigma and drag scaled from t_frac of the run on (tanh blend)"},
       [](const EffectSpec& e, RobotTruth& r) {
         r.tp.terrain_change.on = true;
         r.tp.terrain_change.t_s = param(e, "t_frac") * r.seconds;
         r.tp.terrain_change.width_s = param(e, "width_s");
         r.tp.terrain_change.sigma_scale = param(e, "sigma_scale");
         r.tp.terrain_change.drag_scale = param(e, "drag_scale");
       }},
      {{"paper_params", true, true,
        {{"sigma_long", 1.0}, {"sigma_lat", 1.0}, {"D_x", 1.0}, {"D_y", 1.0}, {"D_psi", 1.0}},
        "the paper's sigma, D multiplied by these factors"},
       [](const EffectSpec& e, RobotTruth& r) {
         TerrainParams t = r.model.terrain;
         t.sigma_long *= param(e, "sigma_long");
         t.sigma_lat *= param(e, "sigma_lat");
         t.D_x *= param(e, "D_x");
         t.D_y *= param(e, "D_y");
         t.D_psi *= param(e, "D_psi");
         r.model = make_model(r.model.robot, t);
       },
       [](const EffectSpec& e, GantryTruth& g) {
         g.gp.sigma *= param(e, g.lateral ? "sigma_lat" : "sigma_long");
         g.gp.drag *= param(e, g.lateral ? "D_y" : "D_x");
       }},
      {{"soft_patch", true, true, {{"extra", 2.0}, {"radius_m", 0.2}, {"at_frac", 0.5}},
        "OUTSIDE the library: a disc (gantry: a stretch of rail) of soft ground, drag x (1 + extra), "
        "placed where the base path passes once, near at_frac of the run (gantry: at at_frac of the rail)"},
       [](const EffectSpec& e, RobotTruth& r) {  // placed on the base path by generate_robot_log
         r.tp.soft_patch.on = true;
         r.tp.soft_patch.extra = param(e, "extra");
         r.tp.soft_patch.radius_m = param(e, "radius_m");
       },
       [](const EffectSpec& e, GantryTruth& g) {  // a stretch of 2 radius_m centred at at_frac of the rail
         g.gp.soft_patch.on = true;
         g.gp.soft_patch.centre_m = param(e, "at_frac") * g.rail_m;
         g.gp.soft_patch.half_length_m = param(e, "radius_m");
         g.gp.soft_patch.extra = param(e, "extra");
       }},
  };
  return t;
}

const EffectRow& row_of(const std::string& id) {
  for (const auto& r : effect_rows())
    if (r.info.id == id) return r;
  std::string known;
  for (const auto& r : effect_rows()) known += (known.empty() ? "" : ", ") + r.info.id;
  throw std::invalid_argument("unknown effect '" + id + "' (known: " + known + ")");
}

const EffectInfo& info_of(const std::string& id) { return row_of(id).info; }

// Parameter value of the effect, its default if not given.
double param(const EffectSpec& e, const std::string& name) {
  const auto it = e.params.find(name);
  if (it != e.params.end()) return it->second;
  for (const auto& [n, v] : info_of(e.id).params)
    if (n == name) return v;
  throw std::logic_error("effect " + e.id + " has no parameter " + name);
}

// Ideal speed-controlled screw over one coupling step: omega' = (target - omega) / tau, exact.
// Returns the mean speed over the step (what moves the robot and turns the shaft).
Vec4 ideal_screw_step(Vec4& omega_rpm, const Vec4& target_rpm, double tau_s, double h_s) {
  const double a = std::exp(-h_s / tau_s);
  const Vec4 start = omega_rpm;
  omega_rpm = target_rpm + a * (start - target_rpm);
  return target_rpm + (start - target_rpm) * (tau_s / h_s * (1.0 - a));
}

// Encoder: counts of a shaft angle (in revolutions); the speed reported for a 10 ms window is
// the count difference (docs/model-notes.md: 48 counts per motor revolution, ~369:1), in 0.01 rpm.
double encoder_rpm(double rev_prev, double rev_now, double counts_per_rev) {
  const double counts = std::floor(rev_now * counts_per_rev) - std::floor(rev_prev * counts_per_rev);
  const double rpm = counts / counts_per_rev / kTick_s * 60.0;
  return std::round(rpm * 100.0) / 100.0;
}

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

// The effect's row of effect_rows() applied to the robot's truth, and to the gantry's.
void apply_robot_effect(const EffectSpec& e, double seconds, TruthParams& tp, Model& truth_model) {
  RobotTruth r{tp, truth_model, seconds};
  if (const RobotForm form = row_of(e.id).robot) form(e, r);
}

void apply_gantry_effect(const EffectSpec& e, bool lateral, double rail_m, GantryTruthParams& gp) {
  GantryTruth g{gp, lateral, rail_m};
  if (const GantryForm form = row_of(e.id).gantry) form(e, g);
}

// The effects to apply ("none" entries dropped).
std::vector<EffectSpec> active_effects(const LogGenConfig& cfg) {
  std::vector<EffectSpec> out;
  for (const EffectSpec& e : cfg.effects)
    if (e.id != "none") out.push_back(e);
  return out;
}

const EffectSpec* find_effect(const std::vector<EffectSpec>& effects, const std::string& id) {
  for (const EffectSpec& e : effects)
    if (e.id == id) return &e;
  return nullptr;
}

double wrap(double a) { return wrap_angle(a); }

}  // namespace

const std::vector<EffectInfo>& known_effects() {
  static const std::vector<EffectInfo> infos = [] {
    std::vector<EffectInfo> v;
    for (const EffectRow& r : effect_rows()) v.push_back(r.info);
    return v;
  }();
  return infos;
}

EffectSpec parse_effect_spec(const std::string& text) {
  EffectSpec e;
  const auto colon = text.find(':');
  e.id = text.substr(0, colon);
  const EffectInfo& info = info_of(e.id);
  if (colon == std::string::npos) return e;
  std::stringstream rest(text.substr(colon + 1));
  std::string item;
  while (std::getline(rest, item, ',')) {
    if (item.empty()) continue;
    const auto eq = item.find('=');
    if (eq == std::string::npos)
      throw std::invalid_argument("effect " + e.id + ": '" + item + "' is not name=value");
    const std::string name = item.substr(0, eq), value = item.substr(eq + 1);
    bool known = false;
    std::string names;
    for (const auto& [n, v] : info.params) {
      known = known || n == name;
      names += (names.empty() ? "" : ", ") + n;
    }
    if (!known) throw std::invalid_argument("effect " + e.id + " has no parameter '" + name + "' (known: " + names + ")");
    std::size_t used = 0;
    double x = 0;
    try {
      x = std::stod(value, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != value.size() || !std::isfinite(x))
      throw std::invalid_argument("effect " + e.id + ": parameter " + name + " = '" + value + "' is not a number");
    e.params[name] = x;
  }
  return e;
}

LogGenResult generate_robot_log(const Model& nominal, const LogGenConfig& cfg, std::ostream& out) {
  const std::vector<EffectSpec> effects = active_effects(cfg);
  for (const EffectSpec& e : effects) {
    if (!info_of(e.id).robot) throw std::invalid_argument("effect " + e.id + " applies to gantry logs only");
    for (const EffectSpec& o : effects)
      if (&o != &e && o.id == e.id) throw std::invalid_argument("effect " + e.id + " given twice");
  }
  if (!(cfg.seconds > 0)) throw std::invalid_argument("--seconds must be > 0");
  const auto n_ticks = static_cast<std::size_t>(std::lround(cfg.seconds / kTick_s)) + 1;

  // Base truth = the nominal linear model (docs/robot-sim.md "Base truth of the log generator").
  // The physical base: the robot the firmware-in-the-loop chain drives (TruthParams' defaults).
  TruthParams base;
  base.coriolis = cfg.physical_base;
  base.nominal_yaw_time_constant = !cfg.physical_base;
  base.substep_s = 0.001;  // no stiff dry force in the base: 1 ms RK4 is exact to ~1e-9
  if (cfg.physical_base && cfg.blocking_rpm > 0 && cfg.terrain == "sand") {
    base.blocking.on = true;
    base.blocking.omega_block_rpm = cfg.blocking_rpm;
  }
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

  // One pass of the physics; base_rms: run the base alongside for the effect-size report.
  struct Pass {
    std::vector<TruthRow> rows;
    std::vector<Vec4> omega_meas;
    Vec3 rms = Vec3::Zero();
  };
  auto run = [&](const TruthParams& p, const Model& mdl, bool with_base) {
    Pass ps;
    ps.rows.reserve(n_ticks);
    ps.omega_meas.reserve(n_ticks);
    TrueRobot robot(mdl, p);
    TrueRobot base_robot(nominal, base);
    Vec4 omega = Vec4::Zero(), rev = rev0, rev_prev = rev0;
    Vec3 sq = Vec3::Zero();
    double next_reset_s = 0.0;
    for (std::size_t k = 0; k < n_ticks; ++k) {
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
      if (k + 1 == n_ticks) break;
      for (int j = 0; j < 10; ++j) {
        const Vec4 mean_rpm = ideal_screw_step(omega, cmd[k], cfg.ideal_tau_s, kCouple_s);
        robot.step(mean_rpm, kCouple_s);
        if (with_base) base_robot.step(mean_rpm, kCouple_s);
        rev += mean_rpm * (kCouple_s / 60.0);
      }
    }
    if (with_base) ps.rms = (sq / static_cast<double>(n_ticks)).cwiseSqrt();
    return ps;
  };

  if (tp.soft_patch.on) {
    // Put the patch on the base path, where the robot passes once: among the path's positions
    // between 30 and 70 % of the run, the one the robot's footprint (about 0.35 m around the
    // centre) covers for the shortest time; ties go to the one nearest at_frac of the run.
    const Pass probe = run(base, nominal, false);
    const double frac = std::clamp(param(*patch_spec, "at_frac"), 0.0, 1.0);
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
    const ScrewMount& sc0 = nominal.screws[0];
    tp.soft_patch.x_m = eb[0] + cb * sc0.x_m - sb * sc0.y_m;
    tp.soft_patch.y_m = eb[1] + sb * sc0.x_m + cb * sc0.y_m;
    char note[160];
    std::snprintf(note, sizeof note, "soft_patch centre (%.3f, %.3f) m radius %.2f m (base path at t = %.1f s)",
                  tp.soft_patch.x_m, tp.soft_patch.y_m, tp.soft_patch.radius_m, probe.rows[best].t_s);
    res.notes.push_back(note);
  }
  bool physical = false;
  for (const EffectSpec& e : effects)
    physical = physical || !(e.id == "pose_time_offset" || e.id == "imu_heading_bias" || e.id == "imu_heading_drift");
  Pass ps = run(tp, truth_model, physical);
  res.effect_rms = ps.rms;

  // Where the effects act (any of them).
  const auto screws = nominal.screws;
  for (TruthRow& r : ps.rows) {
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

  // Sensors. The camera: white Gaussian noise, one frame per 1 / pose_rate_hz; with a time
  // offset its frame stamped t shows the pose at t - dt (linear interpolation between rows).
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
  res.truth = std::move(ps.rows);
  return res;
}

LogGenResult generate_gantry_log(const TerrainParams& terrain, double mass_kg, const LogGenConfig& cfg,
                                 std::ostream& out) {
  const std::vector<EffectSpec> effects = active_effects(cfg);
  if (effects.size() > 1) throw std::invalid_argument("a gantry log takes one hidden effect");
  const EffectSpec e = effects.empty() ? EffectSpec{} : effects.front();
  if (!info_of(e.id).gantry) throw std::invalid_argument("effect " + e.id + " applies to robot logs only");
  if (!(cfg.seconds > 0)) throw std::invalid_argument("--seconds must be > 0");
  if (!(mass_kg > 0)) throw std::invalid_argument("gantry mass must be > 0");
  const bool lateral = cfg.gantry == GantryAxis::lateral;
  const std::string& id = e.id;
  const auto n_ticks = static_cast<std::size_t>(std::lround(cfg.seconds / kTick_s)) + 1;
  const double rail_m = 0.5;

  // eqs. (11)-(14): m x'' = -D u + sigma B omega, B_x = [-1, -1], B_y = [-1, 1].
  GantryTruthParams gp;
  gp.mass_kg = mass_kg;
  gp.sigma = lateral ? terrain.sigma_lat : terrain.sigma_long;
  gp.drag = lateral ? terrain.D_y : terrain.D_x;
  gp.b = lateral ? std::array<double, 2>{-1.0, 1.0} : std::array<double, 2>{-1.0, -1.0};
  apply_gantry_effect(e, lateral, rail_m, gp);
  const std::array<double, 2>& b = gp.b;
  const bool patch = gp.soft_patch.on;
  TrueGantry gantry(gp);
  const double patch_c = gp.soft_patch.centre_m, patch_r = gp.soft_patch.half_length_m;

  // Runs along the rail (the paper's 0.5 m), reversing at its ends: single-dof at 5, 10, 20 rpm
  // (jittered), manual at random speeds 3-22 rpm; 1-2 s standing between runs.
  std::mt19937_64 rng(cfg.seed * 7919 + 29);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  auto run_speed = [&](int n) {
    if (cfg.trajectory == Trajectory::single_dof) {
      const double speeds[] = {5.0, 10.0, 20.0};
      return speeds[n % 3] * (0.9 + 0.2 * u01(rng));
    }
    return 3.0 + 19.0 * u01(rng);
  };
  std::mt19937_64 noise_rng(cfg.seed * 2654435761ULL + 13);
  std::normal_distribution<double> n01(0.0, 1.0);
  GantryLogWriter log(out, {{"format", kGantryLogFormat},
                            {"axis", lateral ? "lateral" : "longitudinal"},
                            {"terrain", cfg.terrain},
                            {"mass_kg", [&] {
                               char buf[32];
                               std::snprintf(buf, sizeof buf, "%g", mass_kg);
                               return std::string(buf);
                             }()}});
  LogGenResult res;
  res.truth.reserve(n_ticks);
  GantryState& s = gantry.state();
  s.x_m = 0.05;
  double dir = 1.0, speed = run_speed(0), rest_until = 0.0, sq = 0;
  int run_no = 0;
  std::array<double, 2> rev{u01(rng), u01(rng)}, rev_prev = rev;
  Vec4 omega = Vec4::Zero(), target = Vec4::Zero();
  double force_window_n = 0.0;
  // Base alongside for the effect size (same commands, no effect, reset every segment).
  double base_x = s.x_m, base_u = 0, next_reset = 0;
  const double a_base = std::exp(-gp.drag / mass_kg * kCouple_s);
  for (std::size_t k = 0; k < n_ticks; ++k) {
    const double t = static_cast<double>(k) * kTick_s;
    // Command: a run until the end of the rail, then rest and reverse.
    if (t >= rest_until) {
      const bool at_end = (dir > 0 && s.x_m >= rail_m - 0.05) || (dir < 0 && s.x_m <= 0.05);
      if (at_end) {
        dir = -dir;
        speed = run_speed(++run_no);
        rest_until = t + 1.0 + u01(rng);
      }
    }
    const double w_cmd = t < rest_until ? 0.0 : dir * speed;
    // + x needs sigma b . omega > 0: omega_i = w b_i (|b_i| = 1).
    target = Vec4(w_cmd * b[0], w_cmd * b[1], 0, 0);
    GantrySample g;
    g.t_s = t;
    for (int i = 0; i < 2; ++i)
      g.omega_rpm[static_cast<std::size_t>(i)] =
          k == 0 ? 0.0 : encoder_rpm(rev_prev[static_cast<std::size_t>(i)], rev[static_cast<std::size_t>(i)], cfg.counts_per_rev);
    rev_prev = rev;
    // The force sensor's reading: the traction averaged over the same 10 ms window as the
    // encoder speed (its anti-aliasing filter), so both columns describe the same interval.
    g.force_n = (k == 0 ? 0.0 : force_window_n / 10.0) + cfg.gantry_force_noise_n * n01(noise_rng);
    force_window_n = 0.0;
    g.position_m = s.x_m + cfg.gantry_position_noise_m * n01(noise_rng);
    log.write(g);
    bool acting = id != "none";
    if (patch) acting = std::fabs(s.x_m - patch_c) < patch_r;
    res.truth.push_back({t, Vec3(s.x_m, 0, 0), Vec3(s.u_mps, 0, 0), acting});
    if (t >= next_reset - 1e-9) {
      base_x = s.x_m;
      base_u = s.u_mps;
      next_reset += cfg.size_segment_s;
    }
    sq += (s.x_m - base_x) * (s.x_m - base_x);
    if (k + 1 == n_ticks) break;
    for (int j = 0; j < 10; ++j) {
      const Vec4 mean_rpm = ideal_screw_step(omega, target, cfg.ideal_tau_s, kCouple_s);
      for (int h = 0; h < 2; ++h) gantry.step(mean_rpm, kCouple_s / 2);
      force_window_n += gantry.traction_n(mean_rpm);
      for (int i = 0; i < 2; ++i) rev[static_cast<std::size_t>(i)] += mean_rpm[i] * (kCouple_s / 60.0);
      // Base: exact first-order step of m u' = -D u + sigma_nominal B omega.
      const double sig0 = lateral ? terrain.sigma_lat : terrain.sigma_long;
      const double drag0 = lateral ? terrain.D_y : terrain.D_x;
      const double u_ss = sig0 * (b[0] * mean_rpm[0] + b[1] * mean_rpm[1]) / drag0;
      const double a0 = std::exp(-drag0 / mass_kg * kCouple_s);
      const double u_new = u_ss + a0 * (base_u - u_ss);
      base_x += u_ss * kCouple_s + (base_u - u_ss) * (1 - a0) * mass_kg / drag0;
      base_u = u_new;
    }
  }
  (void)a_base;
  res.effect_rms = Vec3(std::sqrt(sq / static_cast<double>(n_ticks)), 0, 0);
  if (patch) {
    char note[120];
    std::snprintf(note, sizeof note, "soft_patch on the rail from %.3f to %.3f m", patch_c - patch_r, patch_c + patch_r);
    res.notes.push_back(note);
  }
  return res;
}

void write_truth(const LogGenResult& r, std::ostream& out) {
  CsvLogWriter w(out, {{"format", "auger-sim-truth v1"}},
                 {"t_s", "x_m", "y_m", "psi_rad", "u_mps", "v_mps", "r_radps", "acting"});
  for (const TruthRow& t : r.truth) {
    const double row[8] = {t.t_s, t.eta[0], t.eta[1], t.eta[2], t.zeta[0], t.zeta[1], t.zeta[2], t.acting ? 1.0 : 0.0};
    w.write_row(row, 8);
  }
}

}  // namespace auger::sim
