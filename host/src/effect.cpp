// Effect registry and the shipped effects.
#include "auger/effect.hpp"

#include <algorithm>
#include <cmath>

#include "auger/input_limits.hpp"
#include "effects/effects.hpp"

namespace auger {

namespace {
// A message that quotes what the file holds (a key, a string value) could be megabytes long: it
// is cut, control bytes and bytes that are not UTF-8 escaped, and the place named instead.
std::string bounded(const std::string& message, int line, int column) {
  constexpr std::size_t kMax = 300;
  bool plain = message.size() <= kMax;
  for (unsigned char c : message) plain = plain && c >= 0x20 && c < 0x7f;
  if (plain) return message;
  std::string q = quote_input(message, kMax);  // 'text'... (N bytes)
  q = q.substr(1, q.rfind('\'') - 1);
  if (message.size() > kMax)
    q += "... (a message of " + std::to_string(message.size()) + " bytes, cut: see the file at line " +
         std::to_string(line) + ", column " + std::to_string(column) + ")";
  return q;
}
}  // namespace

ConfigError::ConfigError(std::string file, int line, int column, const std::string& message)
    : std::runtime_error(file + ":" + std::to_string(line) + ":" + std::to_string(column) + ": " +
                         bounded(message, line, column)),
      file_(std::move(file)),
      line_(line),
      column_(column) {}

void EffectRegistry::add(Entry entry) {
  if (entries_.count(entry.id)) throw std::invalid_argument("effect id registered twice: " + entry.id);
  // Every factory and description sees one value per spec: a caller that gives only the first
  // values (an effect given a form parameter since) gets the specs' defaults for the rest.
  auto padded = [id = entry.id, specs = entry.params](const std::vector<double>& v) {
    if (v.size() > specs.size())
      throw std::invalid_argument("effect '" + id + "' takes " + std::to_string(specs.size()) + " values, not " +
                                  std::to_string(v.size()));
    std::vector<double> all = v;
    for (std::size_t k = v.size(); k < specs.size(); ++k) all.push_back(specs[k].default_value);
    return all;
  };
  if (entry.make) entry.make = [padded, make = std::move(entry.make)](const std::vector<double>& v) { return make(padded(v)); };
  if (entry.describe)
    entry.describe = [padded, describe = std::move(entry.describe)](const std::vector<double>& v) {
      return describe(padded(v));
    };
  std::string id = entry.id;
  entries_.emplace(std::move(id), std::move(entry));
}

std::shared_ptr<const Effect> EffectRegistry::create(const EffectConfig& c) const {
  auto it = entries_.find(c.id);
  if (it == entries_.end()) {
    std::string known;
    for (const auto& [id, e] : entries_) known += (known.empty() ? "" : ", ") + id;
    throw ConfigError(c.file, c.line, c.column, "unknown effect '" + c.id + "' (known: " + known + ")");
  }
  const Entry& e = it->second;
  std::vector<double> values(e.params.size());
  std::vector<bool> given(e.params.size(), false);
  for (const auto& p : c.params) {
    auto spec = std::find_if(e.params.begin(), e.params.end(),
                             [&](const ParamSpec& s) { return s.name == p.name; });
    if (spec == e.params.end() &&
        std::find(e.text_params.begin(), e.text_params.end(), p.name) != e.text_params.end())
      throw ConfigError(c.file, p.line, p.column, "effect '" + c.id + "': '" + p.name + "' must be a text, not a number");
    if (spec == e.params.end()) {
      std::string known;
      for (const auto& s : e.params) known += (known.empty() ? "" : ", ") + s.name;
      throw ConfigError(c.file, p.line, p.column,
                        "effect '" + c.id + "' has no parameter '" + p.name + "' (known: " + known + ")");
    }
    if (p.online && !spec->online) {
      // A sensor's parameter offsets a measurement, it makes no force: the online estimator's
      // regression on eq. (6) cannot see it (online_estimator.hpp).
      const bool sensor = e.needs_imu || c.id.rfind("imu_", 0) == 0 || c.id == "pose_time_offset";
      throw ConfigError(c.file, p.online_line, p.online_column,
                        "effect '" + c.id + "': '" + p.name + "' cannot be estimated online (" +
                            (sensor ? "a sensor's offset, not a force of eq. (6)" : "its effect gives no regressor for it") +
                            "); parameters that may be online: " + online_parameter_list(*this));
    }
    const auto k = static_cast<std::size_t>(spec - e.params.begin());
    values[k] = p.value;
    given[k] = true;
  }
  std::vector<std::string> texts(e.text_params.size());
  std::vector<bool> text_given(e.text_params.size(), false);
  for (const auto& p : c.texts) {
    const auto at = std::find(e.text_params.begin(), e.text_params.end(), p.name);
    if (at == e.text_params.end())
      throw ConfigError(c.file, p.line, p.column,
                        "effect '" + c.id + "': '" + p.name + "' must be a number, not a text");
    texts[static_cast<std::size_t>(at - e.text_params.begin())] = p.value;
    text_given[static_cast<std::size_t>(at - e.text_params.begin())] = true;
  }
  for (std::size_t k = 0; k < e.text_params.size(); ++k)
    if (!text_given[k])
      throw ConfigError(c.file, c.line, c.column, "effect '" + c.id + "' needs the text '" + e.text_params[k] + "'");
  for (std::size_t k = 0; k < e.params.size(); ++k) {
    if (given[k]) continue;
    if (e.params[k].required)
      throw ConfigError(c.file, c.line, c.column,
                        "effect '" + c.id + "' needs parameter '" + e.params[k].name + "'");
    values[k] = e.params[k].default_value;
  }
  try {
    return e.build(values, texts);
  } catch (const std::invalid_argument& ex) {
    throw ConfigError(c.file, c.line, c.column, "effect '" + c.id + "': " + ex.what());
  }
}

void register_builtin_effects(EffectRegistry& r) {
  // The library's list: one register_* per file of host/src/effects/ (docs/workbench.md).
  effects::register_friction(r);
  effects::register_drive(r);
  effects::register_terrain(r);
  effects::register_sensors(r);
  effects::register_body(r);
  effects::register_term(r);
}

std::string online_parameter_list(const EffectRegistry& registry) {
  std::string list;
  for (const auto& [id, e] : registry.entries()) {
    std::string names;
    for (const ParamSpec& p : e.params)
      if (p.online) names += (names.empty() ? "" : ", ") + p.name;
    if (!names.empty()) list += (list.empty() ? "" : "; ") + id + " (" + names + ")";
  }
  return list.empty() ? "none" : list;
}

const EffectRegistry& EffectRegistry::builtin() {
  static const EffectRegistry registry = [] {
    EffectRegistry r;
    register_builtin_effects(r);
    return r;
  }();
  return registry;
}

// ---------------------------------------------------------------- CoulombFriction
CoulombFriction::CoulombFriction(const Vec3& limit, double smooth_mps) : limit_(limit), smooth_mps_(smooth_mps) {}
const std::string& CoulombFriction::id() const {
  static const std::string s = "coulomb_friction";
  return s;
}
std::vector<std::pair<std::string, double>> CoulombFriction::params() const {
  return {{"force_x_n", limit_.x()}, {"force_y_n", limit_.y()}, {"torque_psi_nm", limit_.z()},
          {"smooth_mps", smooth_mps_}};
}

void CoulombFriction::body_force(const Model& m, const EffectContext& ctx, Vec3& force_n, double*) const {
  // Implicit (time-stepping) friction: the hard sign is the force that would bring the DOF to
  // rest at the step's end, clamped to the friction level. Moving fast: -limit sign(v); at rest
  // with a weak drive: exactly cancels it (sticks); never reverses the motion within a step. The
  // tanh form is linearly implicit: -L tanh(v / s) linearized at the step's start speed v0 and
  // solved at its end (one tanh per DOF; exact at a steady speed, stable however steep the tanh:
  // its slope only damps), never beyond the stop either.
  for (int k = 0; k < 3; ++k) {
    const double stop = -ctx.zeta_free[k] / ctx.gain[k];
    if (!(smooth_mps_ > 0)) {
      force_n[k] = std::clamp(stop, -limit_[k], limit_[k]);
      continue;
    }
    // In yaw the contacts slide at r hypot(l_x, l_y), as for stick-slip.
    const double smooth = smooth_mps_ / effects::contact_speed_per_unit(m, k);
    const double v0 = ctx.zeta[k], t = std::tanh(v0 / smooth);
    const double slope = limit_[k] * (1.0 - t * t) / smooth;  // -df/dv >= 0
    const double f = (-limit_[k] * t - slope * (ctx.zeta_free[k] - v0)) / (1.0 + ctx.gain[k] * slope);
    force_n[k] = stop > 0 ? std::clamp(f, -limit_[k], stop) : std::clamp(f, stop, limit_[k]);
  }
}

// ---------------------------------------------------------------- ScrewDeadBand
ScrewDeadBand::ScrewDeadBand(double omega_dead_rpm, double shift, double asymmetry)
    : omega_dead_rpm_(omega_dead_rpm), shift_(shift), asymmetry_(asymmetry) {}
const std::string& ScrewDeadBand::id() const {
  static const std::string s = "screw_dead_band";
  return s;
}
std::vector<std::pair<std::string, double>> ScrewDeadBand::params() const {
  return {{"omega_dead_rpm", omega_dead_rpm_}, {"shift", shift_}, {"asymmetry", asymmetry_}};
}
double ScrewDeadBand::effective_rpm(double omega_rpm) const {
  const double band_rpm = omega_dead_rpm_ * (omega_rpm > 0 ? 1 + asymmetry_ : 1 - asymmetry_);
  const double speed_rpm = std::fabs(omega_rpm);
  if (speed_rpm <= band_rpm) return 0.0;
  // The ramp (speed - band) / shift meets the nominal line at band / (1 - shift).
  const double pushed_rpm = shift_ > 0 ? std::min(speed_rpm, (speed_rpm - band_rpm) / shift_) : speed_rpm;
  return std::copysign(pushed_rpm, omega_rpm);
}
void ScrewDeadBand::drive_force(const Model& model, const Vec4& omega_rpm, double sigma_scale, double, Vec3& tau_n,
                                double*) const {
  for (int i = 0; i < 4; ++i) {
    const double w = omega_rpm[i];
    const double lost_rpm = w - effective_rpm(w);
    if (lost_rpm != 0) tau_n -= sigma_scale * model.SB.col(i) * lost_rpm;  // eq. (7), screw i's lost speed
  }
}

// ---------------------------------------------------------------- ImuHeadingBias
ImuHeadingBias::ImuHeadingBias(double bias_rad, double t_step_s, double before_rad)
    : bias_rad_(bias_rad), t_step_s_(t_step_s), before_rad_(before_rad) {}
const std::string& ImuHeadingBias::id() const {
  static const std::string s = "imu_heading_bias";
  return s;
}
std::vector<std::pair<std::string, double>> ImuHeadingBias::params() const {
  return {{"bias_rad", bias_rad_}, {"t_step_s", t_step_s_}, {"before_rad", before_rad_}};
}
void ImuHeadingBias::sensors(const Model&, const Vec3&, const Vec3&, SensorValues& v) const {
  v.imu_psi_rad = wrap_angle(v.imu_psi_rad + (t_step_s_ > 0 && !v.live && v.t_s < t_step_s_ ? before_rad_ : bias_rad_));
}

void predict_sensors(const Model& model, const Vec3& eta, const Vec3& zeta, SensorValues& v) {
  v.pose = eta;
  v.imu_psi_rad = eta.z();
  v.imu_r_radps = zeta.z();
  for (const auto& e : model.effects) e->sensors(model, eta, zeta, v);
}

}  // namespace auger
