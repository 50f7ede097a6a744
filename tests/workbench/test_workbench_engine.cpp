// Unit tests of the workbench engine (host/wb_engine/workbench.hpp) on synthetic logs made here
// with the host model itself (not the simulator): noise floor, segment simulation, regimes,
// JSON, and for every effect of the library (present and future) that its parameters are
// recovered when the data was made with it.
#include <catch2/catch.hpp>

#include <limits>

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

#include "fitting.hpp"  // flag_params (the plausibility rule itself), make_part, fitted_effect
#include "workbench.hpp"

using namespace auger;
using namespace auger::wb;

namespace {

const TerrainParams kSand{"sand", 0.812, 0.247, 560.33, 320.08, 11.46};

// Screw speeds of a mixed drive: pieces of forward, lateral, yaw and combined motion with
// ramps (or steps) and stops (rpm), piece length piece_s.
Vec4 drive_profile(double t, double piece_s = 4.0, bool ramps = true) {
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

struct SynthOptions {
  double seconds = 60;
  double pose_noise_m = 0.003, psi_noise_rad = 0.005, imu_noise_rad = 0.005;
  int pose_every = 5;          // 20 Hz poses in a 100 Hz log
  double pose_delay_s = 0;     // poses show the state this much earlier
  bool gaps = true;            // a 1 s gap without poses every 20 s
  bool steps = false;          // speeds step (from rest at t = 0 straight to the first piece's)
  unsigned seed = 1;
};

// A log of the host model `truth` driven by drive_profile, noise added.
Dataset synth(const Model& truth, const SynthOptions& o) {
  Dataset d;
  d.path = "synthetic";
  d.terrain = "sand";
  std::mt19937 rng(o.seed);
  std::normal_distribution<double> n01(0, 1);
  const double dt = 0.01;
  const auto n = static_cast<std::size_t>(o.seconds / dt) + 1;
  auto speed = [&](double t) { return o.steps && t <= 0 ? Vec4(Vec4::Zero()) : drive_profile(t, 4.0, !o.steps); };
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

// Camera noise that wanders (first-order Gauss-Markov, correlation corr_s, stationary std 3 mm /
// 5 mrad), plus a second such process of correlation corr2_s (0: none) of half that std, added to
// the poses of a synthetic log; returns the std of what was added per channel.
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

// Parameter values for an effect to make data with: a clear but plausible size from each
// parameter's typical value (the registry's fitting metadata), so a new effect gets one too.
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

}  // namespace

TEST_CASE("noise floor: recovers white noise within 10 % with sparse poses and NaN gaps") {
  SynthOptions o;
  o.pose_noise_m = 0.004;
  o.psi_noise_rad = 0.007;
  o.imu_noise_rad = 0.002;
  const Dataset d = synth(nominal().model, o);
  const ChannelValues f = estimate_noise_floor(d);
  CHECK(f[kX] == Approx(0.004).epsilon(0.10));
  CHECK(f[kY] == Approx(0.004).epsilon(0.10));
  CHECK(f[kPsi] == Approx(0.007).epsilon(0.10));
  CHECK(f[kImuPsi] == Approx(0.002).epsilon(0.10));
  // Ten times the noise gives ten times the floor: it measures the noise, not the motion.
  o.pose_noise_m = 0.0004;
  const ChannelValues g = estimate_noise_floor(synth(nominal().model, o));
  CHECK(g[kX] == Approx(0.0004).epsilon(0.10));
}

TEST_CASE("simulation: the exact model reproduces a noise-free log; segments restart every segment_s") {
  SynthOptions o;
  o.pose_noise_m = o.psi_noise_rad = o.imu_noise_rad = 0;
  o.seconds = 80;
  const Model m = nominal().model;
  const Dataset d = synth(m, o);
  SimOptions so;
  so.n_sub = 4;
  Prediction p;
  simulate(m, d, so, p);
  const ChannelValues one{1, 1, 1, 1};
  const ErrorStats e = error_stats(d, p, one);
  // Left: the yaw transient older than the 2 s warm-up (I_z / D_psi = 0.32 s), ~1e-3 of any noise.
  CHECK(e.rms[kX] < 1e-5);
  CHECK(e.rms[kY] < 1e-5);
  CHECK(e.rms[kPsi] < 1e-5);
  CHECK(e.rms[kImuPsi] < 1e-5);
  // 80 s in 25 s segments: starts at 0, 25, 50, 75 s (each at the first measured pose).
  REQUIRE(p.segment_start.size() == 4);
  CHECK(d.t_s[p.segment_start[1]] == Approx(25.0));
  CHECK(d.t_s[p.segment_start[3]] == Approx(75.0));
  // A model with the wrong drag is far off the same log.
  ModelChoice wrong = nominal();
  TerrainParams t = kSand;
  t.D_x *= 1.3;
  wrong.model = make_model(RobotParams{}, t);
  Prediction pw;
  simulate(wrong.model, d, so, pw);
  CHECK(error_stats(d, pw, one).rms[kX] > 1e-3);
}

TEST_CASE("simulation: a lagged drive force starts from the speeds before the log, not the first step's") {
  // The robot rests at t = 0 and its screws step to speed at once (the first row's speed is 0,
  // the second's is not), as in a gantry run that starts with the log.
  SynthOptions o;
  o.pose_noise_m = o.psi_noise_rad = o.imu_noise_rad = 0;
  o.seconds = 30;
  o.steps = true;
  const Model m = make_model(RobotParams{}, kSand,
                             {EffectRegistry::builtin().entries().at("force_lag").make({0.5, 0.04})});
  const Dataset d = synth(m, o);
  REQUIRE(d.omega_rpm[0].norm() == 0);
  REQUIRE(d.omega_rpm[1].norm() > 10);
  SimOptions so;
  so.n_sub = 4;
  Prediction p;
  simulate(m, d, so, p);
  const ErrorStats e = error_stats(d, p, ChannelValues{1, 1, 1, 1});
  CHECK(e.rms[kX] < 1e-5);
  CHECK(e.rms[kY] < 1e-5);
  CHECK(e.rms[kPsi] < 1e-5);
}

TEST_CASE("compare: a log of the nominal model is at the noise floor; a missing effect is well above") {
  const Dataset d = synth(nominal().model, SynthOptions{});
  const CompareResult r = compare(d, nominal());
  for (int c : {kX, kY, kPsi, kImuPsi}) {
    CHECK(r.segments_err.ratio_to_noise[static_cast<std::size_t>(c)] > 0.9);
    CHECK(r.segments_err.ratio_to_noise[static_cast<std::size_t>(c)] < 1.15);
  }
  CHECK(!r.windows.empty());
  CHECK(r.worst.size() == 5);
  CHECK(r.worst[0].ratio_to_noise >= r.worst[4].ratio_to_noise);
  const Model with = make_model(RobotParams{}, kSand, {std::make_shared<CoulombFriction>(Vec3(8, 5, 0.3))});
  const CompareResult rw = compare(synth(with, SynthOptions{}), nominal());
  CHECK(rw.segments_err.ratio_to_noise[kX] > 3.0);
}

TEST_CASE("regimes: labels follow the screw speeds") {
  Dataset d;
  const Model m = nominal().model;
  const Vec4 fwd(-1, -1, 1, 1), lat(-1, 1, 1, -1), yaw(1, 1, 1, 1);
  for (int k = 0; k < 5; ++k) {
    d.t_s.push_back(k * 0.01);
    d.meas.push_back({0, 0, 0.0, kNaN});
  }
  d.active = {true, true, true, false};  // as load_dataset marks a log with poses and no IMU
  auto label = [&](const Vec4& w) {
    d.omega_rpm.assign(5, w);
    return classify_sample(m, d, 2);
  };
  CHECK(label(10 * fwd).motion == "x");
  CHECK(label(10 * fwd).direction == "forward");
  CHECK(label(-10 * fwd).direction == "backward");
  CHECK(label(10 * lat).motion == "y");
  CHECK(label(10 * yaw).motion == "yaw");
  CHECK(label(10 * fwd + 10 * lat).motion == "combined");
  CHECK(label(Vec4::Zero()).motion == "still");
  CHECK(label(3 * fwd).speed == "0-5 rpm");
  CHECK(label(15 * fwd).speed == "12+ rpm");
  CHECK(label(10 * fwd).heading == "heading -45..45 deg");
  d.omega_rpm = {Vec4::Zero(), 2 * fwd, 4 * fwd, 6 * fwd, 8 * fwd};
  CHECK(classify_sample(m, d, 2).phase == "accelerating");
}

TEST_CASE("JSON: one object, escaped strings, null for NaN, only active channels") {
  Json j;
  j.begin_object().num("a", 1.5).str("s", "say \"hi\"\n").begin_array("w").begin_object().boolean("b", true);
  j.end_object().num(nullptr, kNaN).end_array();
  j.channels("c", {1, 2, 3, 4}, {true, false, true, false}).end_object();
  CHECK(j.text() == "{\"a\":1.5,\"s\":\"say \\\"hi\\\"\\n\",\"w\":[{\"b\":true},null],\"c\":{\"x\":1,\"psi\":3}}");
}

TEST_CASE("JSON: numbers to 10 significant digits, whole ones as integers; bad UTF-8 replaced") {
  Json j;
  j.begin_object().num("third", 1.0 / 3).num("big", 1e12).num("neg", -2.5e-7).num("inf", std::numeric_limits<double>::infinity());
  j.str("path", std::string("log\xff\xfe.csv")).str("ok", "\xc3\xa9").end_object();
  CHECK(j.text() == "{\"third\":0.3333333333,\"big\":1000000000000,\"neg\":-2.5e-07,\"inf\":null,"
                    "\"path\":\"log\xef\xbf\xbd\xef\xbf\xbd.csv\",\"ok\":\"\xc3\xa9\"}");
}

TEST_CASE("JSON for a <script> element: no markup characters, the same value") {
  const nlohmann::ordered_json j = {{"label", "x </script><b>&amp;"}, {"y", json_number(0.29462699999999997, 6)}};
  const std::string text = json_for_script(j);
  CHECK(text.find_first_of("<>&") == std::string::npos);
  CHECK(nlohmann::ordered_json::parse(text) == j);
  CHECK(text.rfind("{\"label\":\"x \\u003c/script\\u003e\\u003cb\\u003e\\u0026amp;\",\"y\":", 0) == 0);
  // 6 significant digits (nlohmann's shortest form is not always the shortest: the same double).
  CHECK(nlohmann::ordered_json::parse(text)["y"].get<double>() == 0.294627);
}

TEST_CASE("every library effect: fitted from data made with it, the error falls to the noise floor",
          "[effects]") {
  // The same test applies to an effect added to the registry (docs/workbench.md): its typical
  // parameter sizes make the data, `fit` must bring every channel within 1.2x the noise floor.
  for (const auto& [id, entry] : EffectRegistry::builtin().entries()) {
    if (!entry.text_params.empty()) continue;  // a discovered term: its own test below
    SECTION(id) {
      SynthOptions o;
      o.seconds = 64;
      const std::vector<double> values = test_values(entry, o.seconds);
      std::vector<std::shared_ptr<const Effect>> effects{entry.make(values)};
      if (id == "pose_time_offset") {
        o.pose_delay_s = values[0];
        effects.clear();
      }
      const Dataset d = synth(make_model(RobotParams{}, kSand, effects), o);
      const FitResult r = fit(d, nominal(), {id});
      INFO(id << ": " << r.effects.back().description);
      for (int c = 0; c < kChannels; ++c) {
        INFO("channel " << channel_name(c) << " before " << r.err_before.ratio_to_noise[static_cast<std::size_t>(c)]);
        CHECK(r.err_after.ratio_to_noise[static_cast<std::size_t>(c)] < 1.2);
      }
      // The fitted model file loads back and gives the same error.
      const ModelFile mf = parse_model_file(r.model_toml, "fitted");
      const Model back = build_model(mf, "sand");
      Prediction p;
      simulate(back, d, sim_options_for(back), p);
      const ErrorStats back_err = error_stats(d, p, r.noise_floor);
      for (int c = 0; c < kChannels; ++c)
        CHECK(back_err.ratio_to_noise[static_cast<std::size_t>(c)] ==
              Approx(r.err_after.ratio_to_noise[static_cast<std::size_t>(c)]).epsilon(1e-6));
    }
  }
}

TEST_CASE("fit recovers the parameters of the effect that made the data") {
  SynthOptions o;
  o.seconds = 64;
  SECTION("quadratic drag") {
    const Model truth = make_model(RobotParams{}, kSand, {EffectRegistry::builtin().entries().at("quadratic_drag").make({3000, 2000, 0})});
    const FitResult r = fit(synth(truth, o), nominal(), {"quadratic_drag"});
    const auto& p = r.effects.back().params;
    CHECK(p[0].value == Approx(3000).epsilon(0.15));
    CHECK(p[1].value == Approx(2000).epsilon(0.15));
    CHECK(std::fabs(p[0].value - 3000) < 4 * p[0].sigma + 100);  // the uncertainty is honest
    // The paper's parameters stay where they were (they did not absorb the drag).
    CHECK(r.effects.front().params[2].value == Approx(560.33).epsilon(0.05));
  }
  SECTION("loss of traction: which screw and how much") {
    const Model truth = make_model(RobotParams{}, kSand, {EffectRegistry::builtin().entries().at("screw_traction_loss").make({1, 0.5})});
    const FitResult r = fit(synth(truth, o), nominal(), {"screw_traction_loss"});
    CHECK(r.effects.back().params[0].value == 1);
    CHECK(r.effects.back().params[1].value == Approx(0.5).margin(0.05));
  }
}

TEST_CASE("diagnose: ranks the effect that made the data first; no effect is not significant") {
  SynthOptions o;
  o.seconds = 70;
  DiagnoseOptions opt;
  opt.only = {"coulomb_friction", "quadratic_drag", "screw_dead_band", "paper_params", "force_lag"};
  const Model truth = make_model(RobotParams{}, kSand, {std::make_shared<CoulombFriction>(Vec3(8, 5, 0.3))});
  const DiagnoseResult r = diagnose(synth(truth, o), nominal(), opt);
  REQUIRE(r.candidates.size() == opt.only.size());
  CHECK(r.candidates[0].fitted.effect == "coulomb_friction");
  CHECK(r.significant);
  CHECK(r.candidates[0].heldout_ratio < 1.2);
  CHECK(r.candidates[0].delta_bic < r.candidates[1].delta_bic);
  CHECK(r.n_eff <= r.n);
  o.seed = 7;
  const DiagnoseResult none = diagnose(synth(nominal().model, o), nominal(), opt);
  CHECK_FALSE(none.significant);
  CHECK(none.nominal_heldout_ratio < 1.15);
}

namespace {

// A gantry log (one module on the rail, eqs. (11)-(17)) made with the workbench's own gantry
// model: constant-speed pieces both ways, position and load-cell force with noise.
Dataset synth_gantry(const std::vector<std::shared_ptr<const Effect>>& effects, unsigned seed) {
  Dataset d;
  d.path = "synthetic-gantry";
  d.gantry = true;
  d.axis = "longitudinal";
  d.terrain = "sand";
  d.active = {true, false, false, false};
  const ModelChoice mc = choose_model(d);
  const Model truth = make_model(mc.model.robot, mc.model.terrain, effects);
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0, 1);
  DynamicsData dyn(truth);
  Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
  const double dt = 0.01;
  auto omega = [](double t) {
    const double levels[6] = {-5, -12, 0, 8, -18, 3};
    const double w = levels[static_cast<int>(t / 6.0) % 6];
    return Vec4(w, w, 0, 0);
  };
  for (int k = 0; k <= 7200; ++k) {
    const double t = k * dt;
    d.t_s.push_back(t);
    d.omega_rpm.push_back(omega(t));
    d.meas.push_back({eta.x() + 0.002 * n01(rng), 0.0, 0.0, kNaN});
    d.force_n.push_back(dyn.tau_drive_n.x() + 0.3 * n01(rng));  // drive force of the interval ending at t
    dynamics_step(truth, dyn, eta, zeta, omega(t + dt), dt, 4);
  }
  return d;
}

}  // namespace

TEST_CASE("gantry: one DOF through the same machinery; the load cell separates a dead band from friction") {
  const Dataset none = synth_gantry({}, 3);
  const ModelChoice mc = choose_model(none);
  CHECK(mc.model.robot.m_kg == 16.0);
  const CompareResult r = compare(none, mc);
  CHECK(r.noise_floor[kX] == Approx(0.002).epsilon(0.15));
  CHECK(r.segments_err.ratio_to_noise[kX] < 1.15);
  CHECK(std::isnan(r.noise_floor[kY]));  // one channel only
  const auto& reg = EffectRegistry::builtin().entries();
  const Dataset band = synth_gantry({reg.at("screw_dead_band").make({2.5, 1})}, 4);
  DiagnoseOptions opt;
  opt.only = {"coulomb_friction", "screw_dead_band"};
  const DiagnoseResult dr = diagnose(band, choose_model(band), opt);
  REQUIRE(dr.candidates.size() == 2);
  CHECK(dr.candidates[0].fitted.effect == "screw_dead_band");
  CHECK(dr.candidates[0].fitted.params[0].value == Approx(2.5).epsilon(0.1));
  CHECK(dr.significant);
  CHECK_FALSE(diagnose(none, choose_model(none), opt).significant);
}

// ---- explain (issue 12), residual tests, coloured noise, flags ----

namespace {

const EffectRegistry::Entry& entry(const char* id) { return EffectRegistry::builtin().entries().at(id); }

ModelChoice with_effects(std::vector<std::shared_ptr<const Effect>> effects) {
  ModelChoice mc = nominal();
  mc.model = make_model(RobotParams{}, kSand, std::move(effects));
  return mc;
}

}  // namespace

TEST_CASE("explain: two effects at once are both named, jointly fitted, and the error falls to the noise") {
  SynthOptions o;
  o.seconds = 90;
  const Model truth = make_model(RobotParams{}, kSand,
                                 {entry("screw_dead_band").make({2.0, 1}), entry("resistance_offset").make({0.03, 0.0})});
  ExplainOptions eo;
  eo.only = {"screw_dead_band", "resistance_offset", "coulomb_friction", "quadratic_drag"};
  const ExplainResult r = explain({synth(truth, o)}, {nominal()}, eo);
  INFO(r.verdict);
  REQUIRE(r.steps.size() >= 3);
  CHECK(std::find(r.effects.begin(), r.effects.end(), "screw_dead_band") != r.effects.end());
  CHECK(std::find(r.effects.begin(), r.effects.end(), "resistance_offset") != r.effects.end());
  CHECK(r.effects.size() == 2);
  // The held-out error falls at every step and ends at the noise.
  for (std::size_t i = 1; i < r.steps.size(); ++i) CHECK(r.steps[i].heldout_combined < r.steps[i - 1].heldout_combined);
  for (int c = 0; c < kChannels; ++c) CHECK(r.final_ratio[static_cast<std::size_t>(c)] < 1.15);
  CHECK(r.verdict_kind == "noise");
  // The model file reads back to the model explain judged (same doubles).
  const Model back = build_model(parse_model_file(r.model_toml, "explained"), "sand");
  REQUIRE(back.effects.size() == r.final_models.front().model.effects.size());
  for (std::size_t e = 0; e < back.effects.size(); ++e) {
    const auto a = back.effects[e]->params(), b = r.final_models.front().model.effects[e]->params();
    for (std::size_t i = 0; i < a.size(); ++i) CHECK(a[i].second == b[i].second);
  }
  CHECK(back.terrain.D_x == r.final_models.front().model.terrain.D_x);
}

TEST_CASE("explain: a clean log adds nothing; an effect that does not pay for itself is dropped") {
  SynthOptions o;
  o.seconds = 70;
  o.seed = 5;
  ExplainOptions eo;
  eo.only = {"coulomb_friction", "quadratic_drag", "terrain_slope"};
  const ExplainResult clean = explain({synth(nominal().model, o)}, {nominal()}, eo);
  CHECK(clean.effects.empty());
  CHECK(clean.verdict_kind == "noise");
  // A model file that carries a dry friction the log does not have: the backward check (or the
  // first step) takes it out rather than keeping it at zero cost.
  const ModelChoice given = with_effects({entry("quadratic_drag").make({2000, 2000, 0})});
  const Model truth = make_model(RobotParams{}, kSand, {std::make_shared<CoulombFriction>(Vec3(8, 5, 0.3))});
  const ExplainResult r = explain({synth(truth, o)}, {given}, eo);
  INFO(r.verdict);
  CHECK(std::find(r.effects.begin(), r.effects.end(), "coulomb_friction") != r.effects.end());
  CHECK(std::find(r.effects.begin(), r.effects.end(), "quadratic_drag") == r.effects.end());
  bool dropped = false;
  for (const auto& s : r.steps)
    for (const auto& d : s.dropped) dropped = dropped || d == "quadratic_drag";
  CHECK(dropped);
}

TEST_CASE("diagnose --model refits the model's effects jointly with each candidate") {
  SynthOptions o;
  o.seconds = 70;
  const Model truth = make_model(RobotParams{}, kSand,
                                 {entry("screw_dead_band").make({2.0, 1}), std::make_shared<CoulombFriction>(Vec3(6, 4, 0.2))});
  // The model has the dead band at a wrong value: held fixed, a second effect cannot help.
  const ModelChoice given = with_effects({entry("screw_dead_band").make({0.8, 1})});
  DiagnoseOptions opt;
  opt.only = {"coulomb_friction", "quadratic_drag"};
  const DiagnoseResult r = diagnose(synth(truth, o), given, opt);
  REQUIRE(!r.candidates.empty());
  CHECK(r.refits_model);
  CHECK(r.candidates[0].fitted.effect == "coulomb_friction");
  REQUIRE(r.candidates[0].refitted.size() == 1);
  CHECK(r.candidates[0].refitted[0].params[0].value == Approx(2.0).epsilon(0.1));  // refitted, not held
  CHECK(r.candidates[0].heldout_ratio < 1.2);
}

TEST_CASE("residual tests: white residuals pass; a missing effect leaves residuals that follow the inputs") {
  SynthOptions o;
  o.seconds = 70;
  const Dataset clean = synth(nominal().model, o);
  const ResidualTests ok = residual_tests(nominal().model, clean, estimate_noise_floor(clean));
  CHECK(ok.white);
  CHECK(ok.independent);
  const Model truth = make_model(RobotParams{}, kSand, {entry("quadratic_drag").make({3000, 3000, 0})});
  const Dataset d = synth(truth, o);
  const ResidualTests bad = residual_tests(nominal().model, d, estimate_noise_floor(d));
  CHECK_FALSE(bad.white);
  CHECK_FALSE(bad.independent);
  CHECK(describe_residual_tests(bad).find("not white") != std::string::npos);
}

TEST_CASE("noise floor: a camera's coloured noise is found against the IMU heading; white noise is left alone") {
  SynthOptions o;
  o.seconds = 120;
  o.psi_noise_rad = 1e-9;  // the camera's noise is added below, coloured
  o.pose_noise_m = 1e-9;
  Dataset d = synth(nominal().model, o);
  NoiseColour white_colour;
  estimate_noise_floor(synth(nominal().model, SynthOptions{}), &white_colour);
  CHECK_FALSE(white_colour.applied);
  CHECK(white_colour.factor == Approx(1.0).margin(0.2));
  CHECK(white_colour.whiten.ar.empty());
  const Vec3 whole = add_camera_colour(d, 3, 0.3, 0);
  NoiseColour c;
  const ChannelValues floor = estimate_noise_floor(d, &c);
  CHECK(c.applied);
  // Against the noise this log really has: the IMU headings around each frame averaged, its
  // noise no longer rivals the camera's.
  CAPTURE(floor[kPsi], whole.z(), floor[kX], whole.x(), c.factor);
  CHECK(floor[kPsi] == Approx(whole.z()).epsilon(0.06));
  CHECK(floor[kX] == Approx(whole.x()).epsilon(0.15));
}

TEST_CASE("residual tests: a camera's coloured noise is no finding once whitened by its own filter; a missing effect still is") {
  SynthOptions o;
  o.seconds = 120;
  o.psi_noise_rad = 1e-9;
  o.pose_noise_m = 1e-9;
  // Two Gauss-Markov processes added (0.3 s and 0.08 s): not the first-order form of the robot
  // simulator's camera.
  Dataset d = synth(nominal().model, o);
  add_camera_colour(d, 5, 0.3, 0.08);
  NoiseColour c;
  const ChannelValues floor = estimate_noise_floor(d, &c);
  REQUIRE(c.applied);
  REQUIRE_FALSE(c.whiten.ar.empty());
  CHECK(c.whiten.frame_s == Approx(0.05));
  CHECK_FALSE(residual_tests(nominal().model, d, floor).white);  // the colour itself, untreated
  const ResidualTests ok = residual_tests(nominal().model, d, floor, c.whiten);
  CHECK(ok.white);
  CHECK(ok.independent);
  CHECK(describe_residual_tests(ok).find("colour filtered out, AR(") != std::string::npos);
  const Model truth = make_model(RobotParams{}, kSand, {entry("quadratic_drag").make({3000, 3000, 0})});
  Dataset bad = synth(truth, o);
  add_camera_colour(bad, 5, 0.3, 0.08);
  NoiseColour cb;
  const ChannelValues fb = estimate_noise_floor(bad, &cb);
  const ResidualTests t = residual_tests(nominal().model, bad, fb, cb.whiten);
  CHECK_FALSE(t.independent);
}

TEST_CASE("every effect parameter states a physical range, inside its bounds") {
  for (const auto& le : effect_library())
    for (const auto& p : le.params) {
      INFO(le.id << "." << p.name);
      CHECK(std::isfinite(p.physical_lower));
      CHECK(std::isfinite(p.physical_upper));
      CHECK(p.physical_lower < p.physical_upper);
      CHECK(p.physical_lower >= p.lower);
      CHECK(p.physical_upper <= p.upper);
    }
}

TEST_CASE("plausibility: an effect's value at the end of its range that the log bounds from one side is not implausible") {
  // screw_blocking's force at 150 N (its physical upper end): known to +- 10 N it is implausible;
  // +- 130 N is a bound (a blocked screw that never slides), flagged as not identified only. The
  // paper's parameters at the end of their range stay implausible however uncertain: that is
  // the sign of an effect they have taken up.
  SynthOptions o;
  o.seconds = 10;
  const Dataset d = synth(make_model(RobotParams{}, kSand), o);
  const Model base = nominal().model;
  search::Part blocking = search::make_part("screw_blocking", base, d);
  blocking.values[0] = blocking.specs[0].physical_upper;
  auto flags_of = [](const search::Part& p, std::size_t i, double sigma) {
    std::vector<FitParam> f(p.specs.size());
    for (std::size_t k = 0; k < f.size(); ++k) f[k].value = p.values[k];
    f[i].sigma = sigma;
    search::flag_params(f, p);
    return f;
  };
  const std::vector<FitParam> tight = flags_of(blocking, 0, 10.0), loose = flags_of(blocking, 0, 130.0);
  CHECK(search::any_implausible(tight));
  CHECK_FALSE(search::any_implausible(loose));
  CHECK(loose[0].flag.rfind("not identified", 0) == 0);
  CHECK(search::any_flag(loose));

  search::Part paper = search::make_part(search::kPaperParams, base, d);
  paper.values[3] = paper.specs[3].physical_lower;  // D_y a third of the paper's
  CHECK(search::any_implausible(flags_of(paper, 3, 0.9 * paper.values[3])));
}

namespace {

double param_of(const ExplainResult& r, const std::string& effect, const std::string& name) {
  for (const FittedEffect& fe : r.final_fitted)
    if (fe.effect == effect)
      for (const FitParam& p : fe.params)
        if (p.name == name) return p.value;
  return kNaN;
}

}  // namespace

TEST_CASE("explain: a change of terrain inside a held-out segment is placed there, not anywhere in the gap", "[slow]") {
  // 90 s: segments of 12.9 s, every third held out; 71 s lies in the held-out 64.3-77.1 s, where
  // no training segment can say when the terrain changed.
  SynthOptions o;
  o.seconds = 90;
  o.seed = 4;
  const Model truth = make_model(RobotParams{}, kSand, {entry("terrain_change").make({71.0, 0.65, 1.3})});
  ExplainOptions eo;
  eo.only = {"terrain_change", "coulomb_friction", "quadratic_drag"};
  const ExplainResult r = explain({synth(truth, o)}, {nominal()}, eo);
  INFO(r.verdict);
  REQUIRE(r.effects == std::vector<std::string>{"terrain_change"});
  REQUIRE(r.steps.size() >= 2);
  // The step that added the change reads its held-out segment at the noise: placed anywhere else
  // in the gap, that segment carries seconds of the wrong terrain.
  CHECK(r.steps[1].heldout_combined < 1.15);
  CHECK(param_of(r, "terrain_change", "t_change_s") == Approx(71.0).margin(0.5));
  for (int c = 0; c < kChannels; ++c) CHECK(r.final_ratio[static_cast<std::size_t>(c)] < 1.2);
}

TEST_CASE("explain: several logs of one robot are explained together with shared parameters", "[slow]") {
  SynthOptions o;
  o.seconds = 60;
  const Model truth = make_model(RobotParams{}, kSand, {std::make_shared<CoulombFriction>(Vec3(8, 5, 0.3))});
  std::vector<Dataset> logs;
  for (unsigned seed : {11u, 12u}) {
    o.seed = seed;
    logs.push_back(synth(truth, o));
    logs.back().path = "synthetic-" + std::to_string(seed);
  }
  ExplainOptions eo;
  eo.only = {"coulomb_friction", "quadratic_drag", "terrain_change"};
  const ExplainResult r = explain(logs, {nominal(), nominal()}, eo);
  INFO(r.verdict);
  REQUIRE(r.logs.size() == 2);
  REQUIRE(r.effects.size() == 1);
  CHECK(r.effects[0] == "coulomb_friction");
  CHECK(r.final_models.size() == 2);
  // One friction for both logs: the same parameters in both models.
  const auto a = r.final_models[0].model.effects.back()->params(), b = r.final_models[1].model.effects.back()->params();
  CHECK(a[0].second == b[0].second);
  CHECK(a[0].second == Approx(8).epsilon(0.15));
  for (int c = 0; c < kChannels; ++c) CHECK(r.final_ratio[static_cast<std::size_t>(c)] < 1.2);
}

TEST_CASE("model file: the terrain's comment says whether the paper's parameters were refitted or held") {
  const Model m = make_model(RobotParams{}, kSand);
  SynthOptions o;
  o.seconds = 10;
  const Dataset d = synth(m, o);
  search::Part paper = search::make_part(search::kPaperParams, m, d);
  REQUIRE_FALSE(paper.free.empty());
  auto comment = [&](const search::Part& p) {
    std::size_t k = 0;
    const FittedEffect fe = search::fitted_effect(p, m, {}, k);
    return fitted_model_file(m, d, {fe}).terrains.front().comment;
  };
  CHECK(comment(paper).find("re-identified") != std::string::npos);
  paper.free.clear();  // as explain holds them
  CHECK(comment(paper).find("not refitted here") != std::string::npos);
  CHECK(fitted_model_file(m, d, {}).terrains.front().comment.find("not refitted here") != std::string::npos);
}

namespace {

// Physics the library does not have, written here as a body would feel it (not in the term
// vocabulary's hard form): the rear-left screw's thread bites less when it turns backwards, its
// thrust falling by `loss` of eq. (7)'s through a smooth switch 0.5 rpm wide.
class BackwardThrustLoss final : public Effect {
 public:
  explicit BackwardThrustLoss(double loss) : loss_(loss) {}
  const std::string& id() const override {
    static const std::string s = "test_backward_thrust_loss";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override { return {{"loss", loss_}}; }
  void drive_force(const Model& model, const Vec4& omega_rpm, double sigma_scale, double, Vec3& tau_n,
                   double*) const override {
    const double w = omega_rpm[2];
    const double backward = 1.0 / (1.0 + std::exp(w / 0.25));  // 1 well below zero, 0 above
    tau_n -= loss_ * backward * sigma_scale * model.SB.col(2) * w;
  }

 private:
  double loss_;
};

}  // namespace

TEST_CASE("fit --add-term: a discovered term's coefficient recovered from physics made otherwise") {
  SynthOptions o;
  o.seconds = 90;
  o.seed = 7;
  const Model truth = make_model(RobotParams{}, kSand, {std::make_shared<BackwardThrustLoss>(0.35)});
  const Dataset d = synth(truth, o);
  const FitResult r = fit(d, nominal(), {}, false, {{"screw_2", "neg(omega_rpm)"}});
  REQUIRE(r.effects.size() == 2);
  CHECK(r.effects[1].effect == "term");
  INFO(r.effects[1].description);
  CHECK(r.effects[1].params[0].value == Approx(-0.35).epsilon(0.1));
  for (int c = 0; c < kChannels; ++c) CHECK(r.err_after.ratio_to_noise[static_cast<std::size_t>(c)] < 1.2);
  // The model file carries the term and reads back to the same error.
  const Model back = build_model(parse_model_file(r.model_toml, "fitted"), "sand");
  Prediction p;
  simulate(back, d, sim_options_for(back), p);
  const ErrorStats e = error_stats(d, p, r.noise_floor);
  for (int c = 0; c < kChannels; ++c)
    CHECK(e.ratio_to_noise[static_cast<std::size_t>(c)] == Approx(r.err_after.ratio_to_noise[static_cast<std::size_t>(c)]).epsilon(1e-6));
}

TEST_CASE("explain: physics outside the library is said so, with the missing term's form and no stand-in effect",
          "[slow]") {
  SynthOptions o;
  o.seconds = 120;
  o.seed = 8;
  const Model truth = make_model(RobotParams{}, kSand, {std::make_shared<BackwardThrustLoss>(0.35)});
  // (The library effects closest to it, which the search takes as stand-ins first: the whole
  // library takes four times as long and ends the same.)
  ExplainOptions eo;
  eo.only = {"screw_traction_loss", "traction_saturation", "terrain_slope", "resistance_offset"};
  const ExplainResult r = explain({synth(truth, o)}, {nominal()}, eo);
  INFO(r.verdict);
  CHECK(r.outside_library);
  CHECK(r.verdict_kind == "outside_library");
  REQUIRE(!r.discovered.empty());
  bool reads_screw_2 = false;
  for (const auto& g : r.discovered)
    for (const auto& t : g.terms)
      for (const auto& in : t.inputs) reads_screw_2 = reads_screw_2 || in == "omega_rpm_2";
  CHECK(reads_screw_2);
  // What the library's effects stood in for has left the model, and the terms reach the noise.
  CHECK(r.effects.empty());
  for (int c = 0; c < kChannels; ++c) CHECK(r.final_ratio[static_cast<std::size_t>(c)] < 1.2);
  // The model file carries the terms as effects `term`, and loads back.
  const Model back = build_model(parse_model_file(r.model_toml, "explained"), "sand");
  bool term = false;
  for (const auto& e : back.effects) term = term || e->id() == "term";
  CHECK(term);
}

TEST_CASE("explain: a parameter the log does not identify gives way to the simpler form; tiny effects leave",
          "[slow]") {
  // Hard Coulomb friction: stick-slip fits it with its Stribeck speed at the end of its range and
  // an uncertainty over its value; the final checks put Coulomb friction in its place.
  SynthOptions o;
  o.seconds = 90;
  o.seed = 3;
  const Model truth = make_model(RobotParams{}, kSand, {std::make_shared<CoulombFriction>(Vec3(8, 5, 0.3))});
  ExplainOptions eo;
  eo.only = {"coulomb_friction", "stick_slip_friction", "terrain_change", "pose_time_offset"};
  const ExplainResult r = explain({synth(truth, o)}, {nominal()}, eo);
  INFO(r.verdict);
  CHECK(r.effects == std::vector<std::string>{"coulomb_friction"});
  CHECK(r.verdict_kind == "noise");
  for (const auto& x : r.removed) {
    INFO(x.effect << ": " << x.why);
    CHECK(x.effect != "coulomb_friction");
  }
}

TEST_CASE("explain: the paper's parameters and a change of terrain are findings only when cross-validation confirms "
          "them", "[slow]") {
  SynthOptions o;
  o.seconds = 75;
  o.seed = 2;
  ExplainOptions eo;
  eo.only = {"coulomb_friction", "terrain_change"};
  auto paper_of = [](const ExplainResult& r) {
    for (const FittedEffect& fe : r.final_fitted)
      if (fe.effect == "paper_params") return fe;
    return FittedEffect{};
  };
  // Dry friction on the paper's own terrain: re-identified, sigma and D move a few per cent with
  // the noise; not confirmed on held-out segments, they are held at the paper's values (a reader
  // would take "sigma_long 0.79 N/rpm (was 0.812)" as a finding about this terrain).
  const Model friction = make_model(RobotParams{}, kSand, {std::make_shared<CoulombFriction>(Vec3(8, 5, 0.3))});
  const ExplainResult a = explain({synth(friction, o)}, {nominal()}, eo);
  INFO(a.verdict);
  CHECK(a.effects == std::vector<std::string>{"coulomb_friction"});
  CHECK(paper_of(a).effect == "paper_params");
  CHECK(paper_of(a).held);
  bool held_by_check = false;
  for (const RemovedEffect& x : a.removed) held_by_check = held_by_check || x.effect == "paper_params";
  CHECK(held_by_check);
  // The terrain's traction a third above the paper's throughout: re-identified, confirmed (and
  // not said as a change of terrain at some time).
  TerrainParams firmer = kSand;
  firmer.sigma_long *= 1.35;
  firmer.sigma_lat *= 1.35;
  const ExplainResult b = explain({synth(make_model(RobotParams{}, firmer), o)}, {nominal()}, eo);
  INFO(b.verdict);
  CHECK(b.effects.empty());
  CHECK_FALSE(paper_of(b).held);
  CHECK(param_of(b, "paper_params", "sigma_long") == Approx(0.812 * 1.35).epsilon(0.1));
}

TEST_CASE("explain: an effect taken in a near tie is named with its alternatives in the verdict", "[slow]") {
  // A dead band of 0.6 rpm costs about the constant force dry friction would on this driving
  // (screws well above the band): the log cannot tell them apart (1.5 rpm it can), and the
  // verdict must not pretend it can.
  SynthOptions o;
  o.seconds = 90;
  o.seed = 1;
  const Model truth = make_model(RobotParams{}, kSand, {entry("screw_dead_band").make({0.6, 1})});
  ExplainOptions eo;
  eo.only = {"screw_dead_band", "coulomb_friction", "stick_slip_friction"};
  const ExplainResult r = explain({synth(truth, o)}, {nominal()}, eo);
  INFO(r.verdict);
  for (const auto& st : r.steps) {
    if (st.added.empty() || st.alternatives.empty()) continue;
    INFO("step " << st.index << ": " << st.added << " with " << st.alternatives.size() << " alternatives");
    const bool kept = std::find(r.effects.begin(), r.effects.end(), st.added) != r.effects.end();
    const auto t = std::find_if(r.near_ties.begin(), r.near_ties.end(), [&](const NearTie& n) { return n.effect == st.added; });
    CHECK(kept == (t != r.near_ties.end()));
    if (t == r.near_ties.end()) continue;
    CHECK(t->with.size() == st.alternatives.size());
    CHECK(!t->tell_apart.empty());
    CHECK(r.verdict.find(st.added + " is a near tie with " + st.alternatives.front().fitted.effect) != std::string::npos);
  }
  CHECK(!r.near_ties.empty());
}
