// The hidden effects of the log generator (log_gen.hpp): one row per effect with its parameters,
// their defaults, and its physics in the true robot and on the gantry; the --effect parser.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "log_gen_internal.hpp"

namespace auger::sim {
namespace loggen {

namespace {

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

// The soft patch on the robot's terrain: placed on the base path by generate_robot_log.
void robot_soft_patch(const EffectSpec& e, RobotTruth& r) {
  r.tp.soft_patch.on = true;
  r.tp.soft_patch.extra = param(e, "extra");
  r.tp.soft_patch.radius_m = param(e, "radius_m");
}

// On the gantry: a stretch of 2 radius_m centred at at_frac of the rail.
void gantry_soft_patch(const EffectSpec& e, GantryTruth& g) {
  g.gp.soft_patch.on = true;
  g.gp.soft_patch.centre_m = param(e, "at_frac") * g.rail_m;
  g.gp.soft_patch.half_length_m = param(e, "radius_m");
  g.gp.soft_patch.extra = param(e, "extra");
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
       robot_soft_patch, gantry_soft_patch},
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

}  // namespace

const EffectInfo& info_of(const std::string& id) { return row_of(id).info; }

double param(const EffectSpec& e, const std::string& name) {
  const auto it = e.params.find(name);
  if (it != e.params.end()) return it->second;
  for (const auto& [n, v] : info_of(e.id).params)
    if (n == name) return v;
  throw std::logic_error("effect " + e.id + " has no parameter " + name);
}

// The effect's row of effect_rows() applied.
void apply_robot_effect(const EffectSpec& e, double run_s, TruthParams& tp, Model& truth_model) {
  RobotTruth r{tp, truth_model, run_s};
  if (const RobotForm form = row_of(e.id).robot) form(e, r);
}

void apply_gantry_effect(const EffectSpec& e, bool lateral, double rail_m, GantryTruthParams& gp) {
  GantryTruth g{gp, lateral, rail_m};
  if (const GantryForm form = row_of(e.id).gantry) form(e, g);
}

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

}  // namespace loggen

const std::vector<EffectInfo>& known_effects() {
  static const std::vector<EffectInfo> infos = [] {
    std::vector<EffectInfo> v;
    for (const loggen::EffectRow& r : loggen::effect_rows()) v.push_back(r.info);
    return v;
  }();
  return infos;
}

EffectSpec parse_effect_spec(const std::string& text) {
  EffectSpec e;
  const auto colon = text.find(':');
  e.id = text.substr(0, colon);
  const EffectInfo& info = loggen::info_of(e.id);
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

}  // namespace auger::sim
