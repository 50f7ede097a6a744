// The workbench engine's simulation (simulation.hpp): the model chosen for a log, run against
// it, its errors, windows, regimes and what `compare` reports. The effect search is in
// search.cpp, search_diagnose.cpp and explain.cpp.
#include "simulation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <stdexcept>

#include "auger/model_file.hpp"

namespace auger::wb {

namespace {

bool finite(double v) { return std::isfinite(v); }

// Prediction minus measurement; headings wrapped so that 3.1 vs -3.1 is a small error.
double channel_error(int c, double pred, double meas) {
  const double e = pred - meas;
  return c >= kPsi ? wrap_angle(e) : e;
}

}  // namespace

// ------------------------------------------------------------------------------- model
namespace {

// The rail holds the gantry's yaw: huge inertia and damping keep r at zero (the lumped yaw row
// of B would otherwise turn it).
constexpr double kGantryYawDamping = 1e12;

// The paper's tables (docs/model-notes.md; the same values as models/robot.toml, models/gantry.toml).
TerrainParams robot_terrain(const std::string& name, bool* known) {
  *known = true;
  if (name == "frozen_grass") return {"frozen_grass", 0.4, 0.16, 509.81, 210.50, 4.52};
  *known = name == "sand" || name.empty();
  return {"sand", 0.812, 0.247, 560.33, 320.08, 11.46};
}
TerrainParams gantry_terrain(const std::string& name, bool* known) {
  *known = true;
  if (name == "gravel") return {"gravel", 0.297, 0.0853, 214.78, 23.52, kGantryYawDamping};
  *known = name == "sand" || name.empty();
  return {"sand", 0.812, 0.247, 529.95, 76.1307, kGantryYawDamping};
}

// The gantry as the robot model: screws 0 and 1 (B_x = [-1, -1], B_y = [-1, 1]), mass of module
// plus load, yaw locked by a huge inertia (the rail holds it).
RobotParams gantry_robot(double mass_kg) {
  RobotParams r;
  r.m_kg = mass_kg;
  r.I_z_kgm2 = 1e12;
  return r;
}

}  // namespace

std::vector<std::string> table_terrains(bool gantry) {
  return gantry ? std::vector<std::string>{"sand", "gravel"} : std::vector<std::string>{"sand", "frozen_grass"};
}

ModelChoice choose_model(const Dataset& data, const std::string& model_path, const std::string& terrain) {
  ModelChoice mc;
  const std::string named = terrain.empty() ? data.terrain : terrain;
  const std::string wanted = named.empty() ? "sand" : named;
  if (model_path.empty()) {
    bool known = false;
    TerrainParams t = data.gantry ? gantry_terrain(wanted, &known) : robot_terrain(wanted, &known);
    mc.terrain = t.name;
    mc.source = std::string("the paper's tables (") + (data.gantry ? "Table 2" : "Table 3") + ", terrain " + t.name +
                (known ? "" : "; log terrain '" + wanted + "' unknown, sand used") + ")";
    mc.model = data.gantry ? make_model(gantry_robot(data.gantry_mass_kg), t) : make_model(RobotParams{}, t);
    return mc;
  }
  ModelFile f = load_model_file(model_path);
  const TerrainEntry* te = f.find_terrain(wanted);
  if (!te) {
    if (f.terrains.empty()) throw ConfigError(model_path, 1, 1, "model file has no [terrain.NAME]");
    // Another terrain's parameters are not this log's: only a log that names no terrain takes
    // the model's one terrain.
    std::string have;
    for (const auto& t : f.terrains) have += (have.empty() ? "" : ", ") + t.params.name;
    if (!named.empty() || f.terrains.size() > 1)
      throw ConfigError(model_path, 1, 1,
                        "no [terrain." + wanted + "] for the log " + data.path +
                            (named.empty()             ? " (it names no terrain: sand is assumed)"
                             : terrain.empty()         ? " (its `# terrain:`)"
                                                       : " (--terrain)") +
                            "; the model file has " + have);
    te = &f.terrains.front();
  }
  mc.terrain = te->params.name;
  mc.source = model_path + " (terrain " + mc.terrain + ")";
  for (const EffectConfig& c : f.effects) {
    mc.online.emplace_back();
    for (const EffectParamValue& p : c.params)
      if (p.online) mc.online.back().push_back(p.name);
  }
  if (data.gantry) {
    TerrainParams t = te->params;
    t.D_psi = kGantryYawDamping;
    std::vector<std::shared_ptr<const Effect>> effects;
    for (const auto& c : f.effects) effects.push_back(EffectRegistry::builtin().create(c));
    const double mass = f.gantry_mass_kg ? *f.gantry_mass_kg : data.gantry_mass_kg;
    mc.model = make_model(gantry_robot(mass), t, std::move(effects));
  } else {
    mc.model = build_model(f, mc.terrain);
  }
  return mc;
}

// ------------------------------------------------------------------------------- simulation
namespace {

bool pose_measured(const Dataset& d, std::size_t k) {
  const auto& m = d.meas[k];
  return finite(m[kX]) && finite(m[kY]) && finite(m[kPsi]);
}

}  // namespace

void simulate(const Model& model, const Dataset& data, const SimOptions& o, Prediction& out, std::size_t begin,
              std::size_t end) {
  out.pred.assign(data.size(), ChannelValues{kNaN, kNaN, kNaN, kNaN});
  out.force_n.assign(data.gantry ? data.size() : 0, kNaN);
  out.segment_start.clear();
  simulate_range(model, data, o, out, begin, end);
}

void simulate_range(const Model& model, const Dataset& data, const SimOptions& o, Prediction& out,
                    std::size_t begin, std::size_t end) {
  const std::size_t n = data.size();
  end = std::min(end, n);
  if (begin >= end) return;
  DynamicsData dyn(model);
  Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
  SensorValues sv;
  // Poses compared with the model at another time than their row's: their capture time where the
  // log has one (augerd's pose_capture_t_s), and pose_delay_s earlier (effect pose_time_offset).
  const bool capture_times = data.pose_t_s.size() == n;
  const bool delayed = o.pose_delay_s != 0 || capture_times;
  auto pose_time = [&](std::size_t k) {
    const double tc = capture_times ? data.pose_t_s[k] : kNaN;
    return (finite(tc) ? tc : data.t_s[k]) - o.pose_delay_s;
  };
  const bool imu_heading = o.imu_heading && data.active[kImuPsi];
  bool started = false;
  double seg_t0 = 0;
  std::size_t seg_begin = begin;

  // Rigid shift of a finished segment so that its first anchor_s match the measurements on
  // average: the start pose is one noisy sample, the average of ~200 is not. The dynamics do
  // not depend on where the robot is or which way it points (except terrain_slope, a small
  // second-order change), so rotating and translating the segment is exact.
  // Pose rows pose_delay_s late (effect pose_time_offset): the camera's columns show the state
  // at t - pose_delay_s, interpolated in the segment's own prediction; the IMU and the screw
  // speeds share the robot's clock and stay.
  std::vector<Vec3> shifted;
  // The model's poses over the warm-up before the segment (in the segment's frame), so that a
  // pose row late by pose_delay_s at the segment's start is compared with the state before it.
  std::vector<Vec3> warm_pose;
  std::vector<double> warm_t;
  auto shift_poses = [&](std::size_t b, std::size_t e) {
    if (!delayed || b >= e) return;
    shifted.resize(e - b);
    std::size_t j = b;
    for (std::size_t k = b; k < e; ++k) {
      const double want = pose_time(k);
      if (want < data.t_s[b] && !warm_t.empty() && want >= warm_t.front()) {
        std::size_t i = 0;
        while (i + 1 < warm_t.size() && warm_t[i + 1] <= want) ++i;
        const Vec3 p1 = i + 1 < warm_t.size() ? warm_pose[i + 1]
                                             : Vec3(out.pred[b][kX], out.pred[b][kY], out.pred[b][kPsi]);
        const double t1 = i + 1 < warm_t.size() ? warm_t[i + 1] : data.t_s[b];
        const double a = t1 > warm_t[i] ? (want - warm_t[i]) / (t1 - warm_t[i]) : 0.0;
        shifted[k - b] = Vec3((1 - a) * warm_pose[i].x() + a * p1.x(), (1 - a) * warm_pose[i].y() + a * p1.y(),
                              warm_pose[i].z() + a * wrap_angle(p1.z() - warm_pose[i].z()));
        continue;
      }
      const double ts = std::clamp(want, data.t_s[b], data.t_s[e - 1]);
      while (j + 1 < e && data.t_s[j + 1] <= ts) ++j;
      while (j > b && data.t_s[j] > ts) --j;
      const std::size_t j1 = std::min(j + 1, e - 1);
      const double a = j1 > j ? (ts - data.t_s[j]) / (data.t_s[j1] - data.t_s[j]) : 0.0;
      const auto& p0 = out.pred[j];
      const auto& p1 = out.pred[j1];
      shifted[k - b] = Vec3((1 - a) * p0[kX] + a * p1[kX], (1 - a) * p0[kY] + a * p1[kY],
                            p0[kPsi] + a * wrap_angle(p1[kPsi] - p0[kPsi]));
    }
    for (std::size_t k = b; k < e; ++k) {
      out.pred[k][kX] = shifted[k - b].x();
      out.pred[k][kY] = shifted[k - b].y();
      out.pred[k][kPsi] = wrap_angle(shifted[k - b].z());
    }
  };
  auto anchor = [&](std::size_t b, std::size_t e) {
    shift_poses(b, e);
    if (o.anchor_s <= 0 || b >= e) return;
    double sum[3] = {0, 0, 0};
    std::size_t cnt[3] = {0, 0, 0};
    for (std::size_t k = b; k < e && data.t_s[k] - data.t_s[b] <= o.anchor_s; ++k)
      for (int c = 0; c < 3; ++c) {
        if (c == kPsi && imu_heading) continue;
        const double m = data.meas[k][static_cast<std::size_t>(c)], p = out.pred[k][static_cast<std::size_t>(c)];
        if (finite(m) && finite(p)) {
          sum[c] += channel_error(c, p, m);
          ++cnt[c];
        }
      }
    const double dx = cnt[0] ? sum[0] / static_cast<double>(cnt[0]) : 0;
    const double dy = cnt[1] ? sum[1] / static_cast<double>(cnt[1]) : 0;
    double dpsi = cnt[2] ? sum[2] / static_cast<double>(cnt[2]) : 0;
    // The heading from the IMU where the log has one: the segment turned so that the model's IMU
    // heading (the heading with the model's IMU effects, a bias say) matches the IMU's over the
    // window. An IMU heading's noise is white and averages away in a second; a tracking camera's
    // wanders (docs/workbench.md "Noise floor"), and the 2 s mean of a camera noise that wanders
    // over 0.85 s left a start heading 2.6 mrad off, which turned every later pose with it (a
    // clean log at 1.9 times the IMU's noise floor). An IMU bias the model lacks then shows in the
    // camera's heading instead of the IMU's, where the same effect mends it.
    if (o.heading_from_imu && !imu_heading && data.active[kImuPsi]) {
      double s = 0;
      std::size_t m = 0;
      for (std::size_t k = b; k < e && data.t_s[k] - data.t_s[b] <= o.anchor_s; ++k) {
        const double q = out.pred[k][kImuPsi], y = data.meas[k][kImuPsi];
        if (finite(q) && finite(y)) {
          s += wrap_angle(q - y);
          ++m;
        }
      }
      if (m >= 10) dpsi = s / static_cast<double>(m);
    }
    const double x0 = out.pred[b][kX], y0 = out.pred[b][kY];
    const double c = std::cos(-dpsi), s = std::sin(-dpsi);
    for (std::size_t k = b; k < e; ++k) {
      auto& p = out.pred[k];
      if (!finite(p[kX])) continue;
      const double rx = p[kX] - x0, ry = p[kY] - y0;
      p[kX] = x0 + c * rx - s * ry - dx;
      p[kY] = y0 + s * rx + c * ry - dy;
      p[kPsi] = wrap_angle(p[kPsi] - dpsi);
      if (finite(p[kImuPsi])) p[kImuPsi] = wrap_angle(p[kImuPsi] - dpsi);
    }
  };

  for (std::size_t k = begin; k < end; ++k) {
    const double t = data.t_s[k];
    const bool boundary = !started || (o.segment_s > 0 && t - seg_t0 >= o.segment_s);
    if (boundary && is_start_row(data, k)) {
      if (started) anchor(seg_begin, k);
      started = true;
      seg_t0 = t;
      seg_begin = k;
      out.segment_start.push_back(k);
      // The velocity and the effects' state (a lag, a stuck friction) at the start are the
      // model's own: run it over the warm_s before the start from rest at the steady velocity
      // of the screw speeds then, and keep only its velocity and state.
      std::size_t kw = k;
      while (kw > 0 && t - data.t_s[kw - 1] <= o.warm_s) --kw;
      const Vec4 w0 = data.omega_rpm[kw];
      zeta = steady_velocity(model, w0);
      dyn.reset(model);
      // A zero-length step at w0 starts stateful drive effects (force_lag) at the steady force
      // of w0 too: the first step's speed is the mean over the step that follows, and a run
      // starting with the log's first row would otherwise begin with its force already built up.
      drive_force(model, dyn, w0, 0.0, dyn.tau_drive_n);
      Vec3 eta_w = Vec3::Zero();
      warm_t.clear();
      warm_pose.clear();
      for (std::size_t i = kw; i < k; ++i) {
        if (delayed) {
          warm_t.push_back(data.t_s[i]);
          warm_pose.push_back(eta_w);
        }
        const double dt = data.t_s[i + 1] - data.t_s[i];
        const Vec4 w = data.omega_rpm[i + 1];
        dyn.t_s = data.t_s[i];
        dynamics_step(model, dyn, eta_w, zeta, w, std::min(dt, 0.1), o.n_sub);
      }
      eta = start_pose(data, k);
      // Warm-up poses into the segment's frame: the warm-up's end is the start pose.
      const double dpsi = eta.z() - eta_w.z(), c = std::cos(dpsi), sn = std::sin(dpsi);
      for (Vec3& q : warm_pose) {
        const double rx = q.x() - eta_w.x(), ry = q.y() - eta_w.y();
        q = Vec3(eta.x() + c * rx - sn * ry, eta.y() + sn * rx + c * ry, wrap_angle(q.z() + dpsi));
      }
      if (kw == k) dyn.tau_drive_n = model.SB * data.omega_rpm[k];  // no warm-up: the nominal force
    }
    if (!started) continue;
    if (imu_heading && finite(data.meas[k][kImuPsi])) eta.z() = data.meas[k][kImuPsi];  // Fig. 9 variant
    sv.t_s = t;
    predict_sensors(model, eta, zeta, sv);
    // In the IMU-heading variant the IMU is an input, not something the model predicts.
    out.pred[k] = {sv.pose.x(), sv.pose.y(), sv.pose.z(), imu_heading ? kNaN : sv.imu_psi_rad};
    // The gantry's load cell measures the drive force over the interval ending here.
    if (!out.force_n.empty()) out.force_n[k] = dyn.tau_drive_n[data.axis == "lateral" ? 1 : 0];
    if (k + 1 < n) {
      const double dt = data.t_s[k + 1] - t;
      // A row's omega is the encoder's mean over the interval ending at its t_s (module
      // telemetry, docs/log-format.md), so the speed over [t_k, t_k+1] is row k+1's.
      const Vec4 w = data.omega_rpm[k + 1];
      dyn.t_s = t;
      dynamics_step(model, dyn, eta, zeta, w, std::min(dt, 0.1), o.n_sub);
    }
  }
  if (started) anchor(seg_begin, end);
}

// ------------------------------------------------------------------------------- errors
ErrorStats error_stats(const Dataset& data, const Prediction& p, const ChannelValues& noise, std::size_t begin,
                       std::size_t end) {
  ErrorStats s;
  end = std::min(end, data.size());
  std::array<double, kChannels> sum{};
  for (std::size_t k = begin; k < end; ++k)
    for (int c = 0; c < kChannels; ++c) {
      if (!data.active[static_cast<std::size_t>(c)]) continue;
      const double m = data.meas[k][static_cast<std::size_t>(c)], q = p.pred[k][static_cast<std::size_t>(c)];
      if (!finite(m) || !finite(q)) continue;
      const double e = channel_error(c, q, m);
      sum[static_cast<std::size_t>(c)] += e * e;
      ++s.n[static_cast<std::size_t>(c)];
    }
  for (int c = 0; c < kChannels; ++c) {
    const auto cc = static_cast<std::size_t>(c);
    if (!s.n[cc]) continue;
    s.rms[cc] = std::sqrt(sum[cc] / static_cast<double>(s.n[cc]));
    s.ratio_to_noise[cc] = s.rms[cc] / noise[cc];
  }
  return s;
}

ErrorStats one_step_error(const Model& model, const Dataset& data, const ChannelValues& noise) {
  // From each measured pose to the next one (the camera may run slower than the log): what
  // the model adds over one measurement interval.
  Prediction p;
  p.pred.assign(data.size(), ChannelValues{kNaN, kNaN, kNaN, kNaN});
  DynamicsData dyn(model);
  SensorValues sv;
  std::size_t k = 0;
  while (k < data.size() && !pose_measured(data, k)) ++k;
  while (k + 1 < data.size()) {
    std::size_t j = k + 1;
    while (j < data.size() && !pose_measured(data, j)) ++j;
    if (j >= data.size()) break;
    if (data.t_s[j] - data.t_s[k] <= 0.5) {
      const auto& m = data.meas[k];
      Vec3 eta(m[kX], m[kY], m[kPsi]);
      Vec3 zeta = steady_velocity(model, data.omega_rpm[k]);
      dyn.reset(model);
      dyn.t_s = data.t_s[k];
      for (std::size_t i = k; i < j; ++i)
        dynamics_step(model, dyn, eta, zeta, data.omega_rpm[i + 1], data.t_s[i + 1] - data.t_s[i], 1);
      sv.t_s = data.t_s[j];
      predict_sensors(model, eta, zeta, sv);
      p.pred[j] = {sv.pose.x(), sv.pose.y(), sv.pose.z(), kNaN};
    }
    k = j;
  }
  return error_stats(data, p, noise);
}

SimOptions window_sim_options(const SimOptions& options, double window_s) {
  SimOptions o = options;
  o.segment_s = window_s;
  o.anchor_s = std::min(o.anchor_s, 0.2 * window_s);
  // 1 s (3 of the paper's yaw time constants) for 5 s windows, or the model's own settling time
  o.warm_s = std::max(std::min(o.warm_s, 0.2 * window_s), o.settle_s);
  return o;
}

std::vector<Window> window_errors(const Model& model, const Dataset& data, const ChannelValues& noise,
                                  double window_s, const SimOptions& options) {
  const SimOptions o = window_sim_options(options, window_s);
  Prediction p;
  simulate(model, data, o, p);
  std::vector<Window> out;
  for (std::size_t s = 0; s < p.segment_start.size(); ++s) {
    const std::size_t b = p.segment_start[s];
    const std::size_t e = s + 1 < p.segment_start.size() ? p.segment_start[s + 1] : data.size();
    const ErrorStats st = error_stats(data, p, noise, b, e);
    for (int c = 0; c < kChannels; ++c) {
      const auto cc = static_cast<std::size_t>(c);
      if (!data.active[cc] || st.n[cc] < 5) continue;
      out.push_back({data.t_s[b], data.t_s[e - 1], c, st.rms[cc], st.ratio_to_noise[cc]});
    }
  }
  return out;
}

std::vector<Window> worst_windows(const std::vector<Window>& windows, std::size_t n) {
  std::vector<Window> w = windows;
  std::sort(w.begin(), w.end(), [](const Window& a, const Window& b) { return a.ratio_to_noise > b.ratio_to_noise; });
  if (w.size() > n) w.resize(n);
  return w;
}

// ------------------------------------------------------------------------------- regimes
namespace {

// Regime labels as indices into fixed tables (error_by_regime labels 360 000 samples; strings
// per sample would cost more than the simulation).
const char* const kMotion[] = {"still", "x", "y", "yaw", "combined"};
const char* const kSpeed[] = {"0-5 rpm", "5-12 rpm", "12+ rpm"};
const char* const kPhase[] = {"accelerating", "steady", "coasting"};
const char* const kDirection[] = {"none", "forward", "backward", "left", "right", "counter-clockwise", "clockwise"};
const char* const kHeading[] = {"heading -45..45 deg", "heading 45..135 deg", "heading -135..-45 deg",
                                "heading 135..225 deg"};
constexpr int kKinds = 5;
const char* const kKindName[kKinds] = {"motion", "speed", "phase", "direction", "heading"};
const char* const* const kTables[kKinds] = {kMotion, kSpeed, kPhase, kDirection, kHeading};
constexpr int kTableSize[kKinds] = {5, 3, 3, 7, 4};

// The heading of every row for its regime: the camera's (or, in a log without one, the IMU's)
// nearest measured heading within 1 s. Labelled from camera rows alone, a 20 Hz camera's log of
// 150 s counted 30 s of headings.
std::vector<double> row_headings(const Dataset& data) {
  const int c = data.active[kPsi] ? kPsi : kImuPsi;
  std::vector<double> h(data.size(), kNaN);
  if (data.gantry) return h;
  std::vector<double> age(data.size(), kNaN);
  for (std::size_t k = 0, last = data.size(); k < data.size(); ++k) {  // the last one measured
    if (finite(data.meas[k][static_cast<std::size_t>(c)])) last = k;
    if (last < data.size() && data.t_s[k] - data.t_s[last] <= 1.0) {
      h[k] = data.meas[last][static_cast<std::size_t>(c)];
      age[k] = data.t_s[k] - data.t_s[last];
    }
  }
  for (std::size_t k = data.size(), next = data.size(); k-- > 0;) {  // the next one, where nearer
    if (finite(data.meas[k][static_cast<std::size_t>(c)])) next = k;
    const double dt = next < data.size() ? data.t_s[next] - data.t_s[k] : kNaN;
    if (dt <= 1.0 && !(age[k] <= dt)) h[k] = data.meas[next][static_cast<std::size_t>(c)];
  }
  return h;
}

// mean_speed[k] = mean |omega| of row k; rate from its change over +-0.25 s; heading[k] from row_headings.
std::array<int, kKinds> classify_codes(const Model& model, const Dataset& data, std::size_t k,
                                       const std::vector<double>& mean_speed, const std::vector<double>& heading,
                                       std::size_t& a, std::size_t& b) {
  std::array<int, kKinds> c{};
  const Vec4& w = data.omega_rpm[k];
  const Vec3 z = steady_velocity(model, w);  // eq. (6) at rest: what the screws ask for
  // A DOF "moves" when its commanded speed is above a small absolute level.
  const bool mv[3] = {std::fabs(z[0]) > 0.01, std::fabs(z[1]) > 0.01, std::fabs(z[2]) > 0.02};
  const int count = mv[0] + mv[1] + mv[2];
  c[0] = count == 0 ? 0 : count > 1 ? 4 : mv[0] ? 1 : mv[1] ? 2 : 3;
  const double speed = mean_speed[k];
  c[1] = speed < 5 ? 0 : speed < 12 ? 1 : 2;
  while (a < k && data.t_s[k] - data.t_s[a] > 0.25) ++a;
  while (a > 0 && data.t_s[k] - data.t_s[a - 1] <= 0.25) --a;
  if (b < k) b = k;
  while (b + 1 < data.size() && data.t_s[b + 1] - data.t_s[k] <= 0.25) ++b;
  while (b > k && data.t_s[b] - data.t_s[k] > 0.25) --b;
  const double dt = data.t_s[b] - data.t_s[a];
  const double rate = dt > 0 ? (mean_speed[b] - mean_speed[a]) / dt : 0;
  c[2] = rate > 4 ? 0 : rate < -4 || (count == 0 && speed < 0.5) ? 2 : 1;
  // Direction of the dominant commanded DOF (normalised by typical speeds 0.1 m/s, 0.1 rad/s).
  const double nz[3] = {std::fabs(z[0]), std::fabs(z[1]), std::fabs(z[2])};
  const int dom = static_cast<int>(std::max_element(nz, nz + 3) - nz);
  c[3] = count == 0 ? 0 : dom == 0 ? (z[0] > 0 ? 1 : 2) : dom == 1 ? (z[1] > 0 ? 3 : 4) : (z[2] > 0 ? 5 : 6);
  const double psi = heading[k];
  if (data.gantry || !finite(psi)) c[4] = -1;
  else {
    const double deg = psi * 180 / kPi;
    c[4] = std::fabs(deg) <= 45 ? 0 : deg > 45 && deg <= 135 ? 1 : deg < -45 && deg >= -135 ? 2 : 3;
  }
  return c;
}

std::vector<double> mean_speeds(const Dataset& data) {
  std::vector<double> s(data.size());
  for (std::size_t k = 0; k < data.size(); ++k) s[k] = data.omega_rpm[k].cwiseAbs().mean();
  return s;
}

}  // namespace

RegimeLabels classify_sample(const Model& model, const Dataset& data, std::size_t k) {
  const std::vector<double> ms = mean_speeds(data), heading = row_headings(data);
  std::size_t a = k, b = k;
  const auto c = classify_codes(model, data, k, ms, heading, a, b);
  RegimeLabels L;
  L.motion = kMotion[c[0]];
  L.speed = kSpeed[c[1]];
  L.phase = kPhase[c[2]];
  L.direction = kDirection[c[3]];
  L.heading = c[4] < 0 ? "" : kHeading[c[4]];
  return L;
}

std::vector<RegimeRow> error_by_regime(const Model& model, const Dataset& data, const Prediction& p,
                                       const ChannelValues& noise) {
  struct Acc {
    double seconds = 0;
    std::array<double, kChannels> sum{};
    std::array<std::size_t, kChannels> n{};
  };
  std::array<std::array<Acc, 7>, kKinds> acc{};
  const std::vector<double> ms = mean_speeds(data), heading = row_headings(data);
  std::size_t a = 0, b = 0;
  for (std::size_t k = 0; k < data.size(); ++k) {
    const auto codes = classify_codes(model, data, k, ms, heading, a, b);
    const double dt = k + 1 < data.size() ? data.t_s[k + 1] - data.t_s[k] : 0;
    std::array<double, kChannels> e2{};
    std::array<bool, kChannels> has{};
    for (int c = 0; c < kChannels; ++c) {
      const auto cc = static_cast<std::size_t>(c);
      const double m = data.meas[k][cc], q = p.pred[k][cc];
      if (!data.active[cc] || !finite(m) || !finite(q)) continue;
      const double e = channel_error(c, q, m);
      e2[cc] = e * e;
      has[cc] = true;
    }
    for (int kind = 0; kind < kKinds; ++kind) {
      if (codes[static_cast<std::size_t>(kind)] < 0) continue;
      Acc& x = acc[static_cast<std::size_t>(kind)][static_cast<std::size_t>(codes[static_cast<std::size_t>(kind)])];
      x.seconds += dt;
      for (std::size_t c = 0; c < kChannels; ++c)
        if (has[c]) {
          x.sum[c] += e2[c];
          ++x.n[c];
        }
    }
  }
  std::vector<RegimeRow> rows;
  for (int kind = 0; kind < kKinds; ++kind)
    for (int i = 0; i < kTableSize[kind]; ++i) {
      const Acc& x = acc[static_cast<std::size_t>(kind)][static_cast<std::size_t>(i)];
      if (x.seconds <= 0) continue;
      RegimeRow r;
      r.kind = kKindName[kind];
      r.label = kTables[kind][i];
      r.seconds = x.seconds;
      for (std::size_t c = 0; c < kChannels; ++c)
        if (x.n[c]) {
          r.rms[c] = std::sqrt(x.sum[c] / static_cast<double>(x.n[c]));
          r.ratio_to_noise[c] = r.rms[c] / noise[c];
        }
      rows.push_back(r);
    }
  return rows;
}

// ------------------------------------------------------------------------------- compare
SimOptions sim_options_for(const Model& model) {
  SimOptions o;
  o.pose_delay_s = pose_delay_s(model);
  // The warm-up before a segment spans five of the model's slowest time constants M / D
  // (eq. (8)): a segment that starts mid-turn must start at the model's own yaw rate, and with a
  // yaw time constant of 2.3 s the fixed 2 s left 42 % of a turn's transient at the start (a
  // window after a turn at 20 times the noise floor on a log with a slow yaw).
  double tau_s = 0;
  for (int k = 0; k < 3; ++k)
    if (model.D_diag[k] > 0 && std::isfinite(model.M_diag[k] / model.D_diag[k]))
      tau_s = std::max(tau_s, model.M_diag[k] / model.D_diag[k]);
  o.settle_s = std::min(5.0 * tau_s, kMaxWarm_s);
  o.warm_s = std::max(o.warm_s, o.settle_s);
  return o;
}

CompareResult compare(const Dataset& data, ModelChoice mc) {
  CompareResult r;
  r.model = std::move(mc);
  const Model& m = r.model.model;
  r.noise_floor = estimate_noise_floor(data, &r.noise_colour);
  r.segment_floor = segment_floor(r.noise_floor, r.noise_colour);
  SimOptions o = sim_options_for(m);
  SimOptions ol = o;
  ol.segment_s = 0;  // Table 4: open loop from the first pose
  simulate(m, data, ol, r.open_loop);
  r.open_loop_err = error_stats(data, r.open_loop, r.segment_floor);
  simulate(m, data, o, r.segments);
  r.segments_err = error_stats(data, r.segments, r.segment_floor);
  if (data.active[kImuPsi] && data.has_pose()) {  // without a pose nothing is left to compare
    SimOptions oi = o;
    oi.imu_heading = true;
    simulate(m, data, oi, r.imu_heading);
    r.imu_heading_err = error_stats(data, r.imu_heading, r.segment_floor);
  }
  r.one_step_err = one_step_error(m, data, r.noise_floor);
  r.windows = window_errors(m, data, r.segment_floor, 5.0, o);
  r.worst = worst_windows(r.windows, 5);
  r.regimes = error_by_regime(m, data, r.segments, r.segment_floor);
  return r;
}

}  // namespace auger::wb
