// engine_synth.hpp's synthetic logs.
#include "engine_synth.hpp"

#include <algorithm>
#include <cmath>
#include <random>

namespace auger::wb::test {


Vec4 drive_profile(double t, double piece_s, bool ramps) {
  const int piece = static_cast<int>(t / piece_s) % 8;
  const double ramp = ramps ? std::min(1.0, std::fmod(t, piece_s) / 0.8) : 1.0;
  const Vec4 fwd(-1, -1, 1, 1), lat(-1, 1, 1, -1), yaw(1, 1, 1, 1);
  Vec4 w;
  switch (piece) {
    case 0: w = 12 * fwd; break;
    case 1: w = 8 * lat; break;
    case 2: w = Vec4::Zero(); break;
    case 3: w = 10 * yaw; break;
    case 4: w = -15 * fwd; break;
    case 5: w = 6 * fwd + 6 * lat; break;
    case 6: w = -10 * lat + 3 * yaw; break;
    default: w = 18 * fwd - 4 * yaw; break;
  }
  return ramp * w;
}



Dataset synth(const Model& truth, const SynthOptions& o) {
  Dataset d;
  d.path = "synthetic";
  d.terrain = "sand";
  std::mt19937 rng(o.seed);
  std::normal_distribution<double> n01(0, 1);
  const double dt = 0.01;
  const auto n = static_cast<std::size_t>(o.seconds / dt) + 1;
  auto speed = [&](double t) {
    const double piece = std::floor(t / 4.0), golden = 0.6180339887;
    const double scale = o.drive_scale * (o.speed_sweep ? 0.15 + 0.85 * (piece * golden - std::floor(piece * golden)) : 1.0);
    if (o.drive) return o.drive(t);
    return o.steps && t <= 0 ? Vec4(Vec4::Zero()) : Vec4(scale * drive_profile(t, 4.0, !o.steps));
  };
  DynamicsData dyn(truth);
  Vec3 eta(0.5, -0.2, 0.3), zeta = Vec3::Zero();
  Vec3 force_n;
  drive_force(truth, dyn, speed(0), 0.0, force_n);  // at rest before t = 0: a lag starts from no force
  std::vector<Vec3> states(n);
  std::vector<double> imu(n);
  SensorValues sv;
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * dt;
    d.t_s.push_back(t);
    d.omega_rpm.push_back(speed(t));  // mean over the interval ending at t (log convention)
    states[k] = eta;
    sv.t_s = t;
    predict_sensors(truth, eta, zeta, sv);
    imu[k] = sv.imu_psi_rad;
    dyn.t_s = t;
    dynamics_step(truth, dyn, eta, zeta, speed(t + dt), dt, 4);
  }
  const auto delay = static_cast<std::size_t>(std::lround(o.pose_delay_s / dt));
  for (std::size_t k = 0; k < n; ++k) {
    ChannelValues m{kNaN, kNaN, kNaN, kNaN};
    const double t = d.t_s[k];
    const bool gap = o.gaps && std::fmod(t, 20.0) > 12.0 && std::fmod(t, 20.0) < 13.0;
    if (k % static_cast<std::size_t>(o.pose_every) == 0 && !gap) {
      const Vec3& s = states[k >= delay ? k - delay : 0];
      m[kX] = s.x() + o.pose_noise_m * n01(rng);
      m[kY] = s.y() + o.pose_noise_m * n01(rng);
      m[kPsi] = wrap_angle(s.z() + o.psi_noise_rad * n01(rng));
    }
    m[kImuPsi] = wrap_angle(imu[k] + o.imu_noise_rad * n01(rng));
    d.meas.push_back(m);
  }
  d.active = {true, true, true, true};
  return d;
}

Vec3 add_camera_colour(Dataset& d, unsigned seed, double corr_s, double corr2_s) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0, 1);
  const Vec3 sigma(0.003, 0.003, 0.005);
  Vec3 g = Vec3::Zero(), h = Vec3::Zero(), sum2 = Vec3::Zero();
  const double a = std::exp(-0.05 / corr_s), b = std::sqrt(1 - a * a);
  const double a2 = corr2_s > 0 ? std::exp(-0.05 / corr2_s) : 0, b2 = std::sqrt(1 - a2 * a2);
  std::size_t n = 0;
  for (auto& m : d.meas) {
    if (!std::isfinite(m[kX])) continue;
    g = a * g + b * Vec3(sigma.x() * n01(rng), sigma.y() * n01(rng), sigma.z() * n01(rng));
    if (corr2_s > 0) h = a2 * h + b2 * 0.5 * Vec3(sigma.x() * n01(rng), sigma.y() * n01(rng), sigma.z() * n01(rng));
    const Vec3 e = g + h;
    m[kX] += e.x();
    m[kY] += e.y();
    m[kPsi] = wrap_angle(m[kPsi] + e.z());
    sum2 += e.cwiseProduct(e);
    ++n;
  }
  return (sum2 / static_cast<double>(n)).cwiseSqrt();
}

ModelChoice nominal() {
  ModelChoice mc;
  mc.model = make_model(RobotParams{}, kSand);
  mc.source = "test";
  mc.terrain = "sand";
  return mc;
}

std::vector<double> test_values(const EffectRegistry::Entry& e, double duration_s) {
  std::vector<double> v;
  for (const auto& p : e.params) {
    double x = p.lower < 0 ? 0.5 * p.typical : p.typical;
    if (p.integer) x = 2;  // screw 2
    else if (!p.fitted) x = p.name == "t_change_s" ? duration_s * 0.45 : p.default_value;
    else if (p.log_scale) x = p.typical * 0.6;  // a limit that bites
    else if (p.name.find("factor") != std::string::npos) x = 0.7;
    else if (p.upper <= 1.0 && p.lower >= 0) x = std::min(0.6, x);  // fractions
    v.push_back(std::clamp(x, p.lower, p.upper));
  }
  return v;
}

const EffectRegistry::Entry& entry(const char* id) { return EffectRegistry::builtin().entries().at(id); }

ModelChoice with_effects(std::vector<std::shared_ptr<const Effect>> effects) {
  ModelChoice mc = nominal();
  mc.model = make_model(RobotParams{}, kSand, std::move(effects));
  return mc;
}

double param_of(const ExplainResult& r, const std::string& effect, const std::string& name) {
  for (const FittedEffect& fe : r.final_fitted)
    if (fe.effect == effect) return value_of(fe, name);
  return kNaN;
}

double value_of(const FittedEffect& e, const std::string& name) {
  for (const FitParam& p : e.params)
    if (p.name == name) return p.value;
  return kNaN;
}

}  // namespace auger::wb::test
