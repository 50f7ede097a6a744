// The effects' parameters a model file marks `online = true` (auger/online_estimator.hpp): a slope
// recovered within its SD on data of the core's own model (bench/online_drive.hpp), a parameter
// the driving does not excite keeps its prior, the clamp to the physical range, no allocation,
// the model file's errors (file, line, column) for what cannot be online, and the estimates
// applied to the controller's model (augerd's `[online] apply`).
#include <catch2/catch.hpp>

#include <fstream>
#include <sstream>

#include "alloc_counter.hpp"
#include "closed_loop.hpp"
#include "auger/model_file.hpp"
#include "auger/online_estimator.hpp"
#include "online_drive.hpp"

using namespace auger;

namespace {
std::string robot_text() {
  std::ifstream in(AUGER_MODELS_DIR "/robot.toml");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str() + "\n";
}
Vec5 params_of(const Model& m) {
  Vec5 p;
  p << m.terrain.sigma_long, m.terrain.sigma_lat, m.terrain.D_x, m.terrain.D_y, m.terrain.D_psi;
  return p;
}
int lines_of(const std::string& text) { return static_cast<int>(std::count(text.begin(), text.end(), '\n')); }
// The robot's model file with `effects` appended (TOML text of [[effect]] tables).
ModelFile with_effects(const std::string& effects) { return parse_model_file(robot_text() + effects, "m.toml"); }
std::string slope(double ix, double iy, bool online) {
  const std::string o = online ? ", online = true }" : " }";
  return "[[effect]]\nid = \"terrain_slope\"\nincline_x_rad = { value = " + std::to_string(ix) + o +
         "\nincline_y_rad = { value = " + std::to_string(iy) + o + "\n";
}
OnlineConfig on() {
  OnlineConfig c;
  c.enabled = true;
  return c;
}
// Runs the estimator configured by `configured` (its online marks) on driving data of `truth`.
OnlineEstimator run(const ModelFile& configured, const ModelFile& truth, double seconds, OnlineDriveOptions o = {}) {
  const Model cm = build_model(configured, "sand"), tm = build_model(truth, "sand");
  OnlineEstimator est(cm, on(), online_effect_params(configured, EffectRegistry::builtin()));
  OnlineDrive drive(tm, tm, o);
  while (drive.t_s() < seconds - 1e-9) {
    drive.next();
    est.step(drive.omega_rpm, drive.zeta_meas, OnlineDrive::kDt, drive.eta_true());
  }
  return est;
}
std::string load_error(const std::string& effects) {
  try {
    build_model(with_effects(effects), "sand");
    online_effect_params(with_effects(effects), EffectRegistry::builtin());
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST_CASE("online effects: a slope of known incline is recovered within its SD, the terrain with it") {
  const ModelFile configured = with_effects(slope(0, 0, true));
  REQUIRE(online_effect_params(configured, EffectRegistry::builtin()).size() == 2);
  for (unsigned seed = 1; seed <= 4; ++seed) {
    OnlineDriveOptions o;
    o.seed = seed;
    const OnlineEstimator est = run(configured, with_effects(slope(0.08, -0.05, false)), 60, o);
    const OnlineEstimate& e = est.estimate();
    INFO("seed " << seed << ": incline_x " << e.effect_value[0] << " +- " << e.effect_sd[0] << " rad, incline_y "
                 << e.effect_value[1] << " +- " << e.effect_sd[1] << " rad; sigma_long " << e.value[0]);
    REQUIRE(e.effects == 2);
    CHECK(std::fabs(e.effect_value[0] - 0.08) < 2 * e.effect_sd[0]);
    CHECK(std::fabs(e.effect_value[1] + 0.05) < 2 * e.effect_sd[1]);
    CHECK(e.effect_sd.head<2>().maxCoeff() < 0.01);  // informed: from a prior SD of 0.175 rad
    CHECK(e.effect_informed.head<2>().minCoeff() == 1);
    CHECK(std::fabs(e.value[kSigmaLong] / 0.812 - 1) < 0.05);  // the slope is not read as traction
    CHECK(est.fallback().empty());
  }
  // Without the slope's columns the same data bias the terrain: what the extra columns are for.
  const OnlineEstimator plain = run(with_effects(""), with_effects(slope(0.08, -0.05, false)), 60);
  CHECK(plain.estimate().effects == 0);
  const Vec5 rel = (plain.estimate().value - params_of(build_model(with_effects(""), "sand"))).cwiseQuotient(
      params_of(build_model(with_effects(""), "sand")));
  INFO("without the slope's columns: relative errors " << rel.transpose() << ", changes " << plain.changes()
                                                       << ", fallback '" << plain.fallback() << "'");
  CHECK(rel.cwiseAbs().maxCoeff() > 0.2);
}

TEST_CASE("online effects: a parameter the driving does not excite keeps its prior, value and SD") {
  // Forward driving: u only, so quadratic drag along y sees no v |v|; along x it is informed.
  const std::string drag = "[[effect]]\nid = \"quadratic_drag\"\nc_x_nspm2 = { value = 100, online = true }\n"
                           "c_y_nspm2 = { value = 200, online = true }\n";
  OnlineDriveOptions o;
  o.forward_only = true;
  const ModelFile configured = with_effects(drag);
  const OnlineEstimator fresh(build_model(configured, "sand"), on(), online_effect_params(configured, EffectRegistry::builtin()));
  const OnlineEstimator est = run(configured, with_effects(drag), 30, o);
  CHECK(est.estimate().effect_value[1] == 200);
  CHECK(est.estimate().effect_sd[1] == fresh.estimate().effect_sd[1]);
  const ParamSpec& c_y = EffectRegistry::builtin().entries().at("quadratic_drag").params[1];
  REQUIRE(c_y.name == "c_y_nspm2");
  CHECK(fresh.estimate().effect_sd[1] == 0.25 * (c_y.physical_upper - c_y.physical_lower));  // a quarter of its range
  CHECK(est.estimate().effect_informed[1] == 0);
  CHECK(est.estimate().effect_informed[0] == 1);
  CHECK(est.estimate().effect_sd[0] < fresh.estimate().effect_sd[0]);
  CHECK(est.estimate().effect_value[0] >= 0);  // clamped to the physical range, from 0
}

TEST_CASE("online effects: the estimate is clamped to the physical range, without a fallback") {
  // 0.45 rad of true incline (the factory takes it, the library's physical range ends at 0.35).
  const OnlineEstimator est = run(with_effects(slope(0, 0, true)), with_effects(slope(0.45, 0, false)), 20);
  CHECK(est.estimate().effect_value[0] == Approx(0.35).margin(1e-12));
  CHECK(est.fallback().empty());  // an effect at its bound is not divergence
}

TEST_CASE("online effects: a step allocates nothing, the effects' columns, a change and the fallback included") {
  const ModelFile configured = with_effects(slope(0, 0, true) +
                                            "[[effect]]\nid = \"quadratic_drag\"\nc_x_nspm2 = { value = 10, online = true }\n");
  const Model cm = build_model(configured, "sand");
  const Model tm = build_model(with_effects(slope(0.1, 0, false)), "frozen_grass");
  OnlineEstimator est(cm, on(), online_effect_params(configured, EffectRegistry::builtin()));
  REQUIRE(est.estimate().effects == 3);
  OnlineDrive drive(cm, tm, OnlineDriveOptions{5.0});
  alloc_counter::start();
  for (int k = 0; k < 800; ++k) {
    drive.next();
    est.step(drive.omega_rpm, drive.zeta_meas, OnlineDrive::kDt, drive.eta_true());
  }
  const bool informed = est.estimate().effect_informed[0] == 1;
  for (int k = 0; k < 800; ++k) est.step(drive.omega_rpm, Vec3(5, 5, 5), OnlineDrive::kDt, drive.eta_true());  // diverges
  const long n = alloc_counter::stop();
  CHECK(est.windows() >= 159);
  CHECK(informed);
  CHECK_FALSE(est.fallback().empty());
  CHECK(est.estimate().effect_value[0] == 0);  // the fallback: back to the file's value
  // ... and so is the controller's.
  CHECK(est.control_effect_parameters()[0] == 0);
  CHECK(est.control_effect_parameters()[2] == 10);
  CHECK(est.control_parameters()[0] == cm.terrain.sigma_long);
  CHECK(n == 0);
}

TEST_CASE("online effects: a non-finite pose breaks the window when an effect is online") {
  const ModelFile configured = with_effects(slope(0, 0, true));
  OnlineEstimator est(build_model(configured, "sand"), on(), online_effect_params(configured, EffectRegistry::builtin()));
  for (int k = 0; k < 300; ++k) est.step(Vec4(10, 10, 10, 10), Vec3(0.01, 0, 0), 0.01);  // no pose given
  CHECK(est.windows() == 0);
}

TEST_CASE("online effects: the model file's errors name the file, line and column") {
  const int base = lines_of(robot_text());
  // A sensor's offset: refused, naming what may be online (and where the `online` key stands).
  std::string e = load_error("[[effect]]\nid = \"imu_heading_bias\"\nbias_rad = { value = 0.01, online = true }\n");
  CHECK(e.find("m.toml:" + std::to_string(base + 3) + ":37: effect 'imu_heading_bias': 'bias_rad' cannot be estimated online "
               "(a sensor's offset, not a force of eq. (6)); parameters that may be online: quadratic_drag (c_x_nspm2, "
               "c_y_nspm2, c_psi_nmspr2); terrain_slope (incline_x_rad, incline_y_rad)") == 0);
  // An effect without a regressor for it.
  e = load_error("[[effect]]\nid = \"coulomb_friction\"\nforce_x_n = { value = 5, online = true }\n");
  CHECK(e.find("m.toml:" + std::to_string(base + 3) + ":35: effect 'coulomb_friction': 'force_x_n' cannot be estimated "
               "online (its effect gives no regressor for it)") == 0);
  // A parameter the effect does not have.
  e = load_error("[[effect]]\nid = \"terrain_slope\"\nincline_z_rad = { value = 0, online = true }\n");
  CHECK(e.find("m.toml:" + std::to_string(base + 3) + ":17: effect 'terrain_slope' has no parameter 'incline_z_rad'") == 0);
  // The form of the inline table.
  e = load_error("[[effect]]\nid = \"terrain_slope\"\nincline_x_rad = { online = true }\n");
  CHECK(e.find("m.toml:" + std::to_string(base + 3) + ":17: 'incline_x_rad' needs 'value'") == 0);
  e = load_error("[[effect]]\nid = \"terrain_slope\"\nincline_x_rad = { value = 0, online = \"yes\" }\n");
  CHECK(e.find("m.toml:" + std::to_string(base + 3) + ":39: 'incline_x_rad.online' must be true or false") == 0);
  e = load_error("[[effect]]\nid = \"terrain_slope\"\nincline_x_rad = { value = 0, sd = 0.1 }\n");
  CHECK(e.find("unknown key 'sd' in 'incline_x_rad' (known: value, online)") != std::string::npos);
  // More than three.
  e = load_error(slope(0, 0, true) + "[[effect]]\nid = \"quadratic_drag\"\nc_x_nspm2 = { value = 1, online = true }\n"
                                     "c_y_nspm2 = { value = 1, online = true }\n");
  CHECK(e.find("m.toml:" + std::to_string(base + 8) + ":35: at most 3 effect parameters may be online") == 0);
  // A start outside the physical range.
  e = load_error(slope(0.5, 0, true));
  CHECK(e.find("m.toml:" + std::to_string(base + 3) + ":17: terrain_slope.incline_x_rad = 0.5 is outside its physical range -0.35..0.35 rad") == 0);
  // An unmarked incline of a slope with the other online: a note (the regression leaves it out).
  const std::string caveat = online_effect_caveats(
      with_effects("[[effect]]\nid = \"terrain_slope\"\nincline_x_rad = { value = 0, online = true }\nincline_y_rad = 0.1\n"),
      EffectRegistry::builtin());
  CHECK(caveat == "m.toml:" + std::to_string(base + 4) +
                      ": terrain_slope.incline_y_rad = 0.1 rad is not marked online: the online regression leaves its force "
                      "out (mark it online to estimate it with the rest)\n");
  CHECK(online_effect_caveats(with_effects(slope(0.1, 0.2, true)), EffectRegistry::builtin()).empty());
  CHECK(online_effect_caveats(with_effects(slope(0.1, 0.2, false)), EffectRegistry::builtin()).empty());
  // online = false is a plain parameter; the marks survive writing the file.
  CHECK(online_effect_params(with_effects(slope(0.1, 0, false)), EffectRegistry::builtin()).empty());
  const ModelFile f = with_effects(slope(0.1, 0.02, true));
  const ModelFile back = parse_model_file(write_model_file(f), "back.toml");
  const auto p = online_effect_params(back, EffectRegistry::builtin());
  REQUIRE(p.size() == 2);
  CHECK(p[0].name == "terrain_slope.incline_x_rad");
  CHECK(p[0].configured == 0.1);
  CHECK(p[1].configured == 0.02);
}

namespace {
// The controller's setpoints and estimated pose over 3 s of closed loop on `plant` (ideal
// screws, a camera pose every third cycle, the IMU every cycle), its model `model`.
std::vector<double> closed_loop(const Model& model, const Model& plant) {
  ControllerConfig cfg;
  cfg.gamma_per_s = Vec3::Constant(1.0);
  Controller c(model, cfg);
  c.set_waypoints({{0.0, Vec3(0.3, 0.2, 0.4)}});
  c.set_enabled(true);
  DynamicsData data(plant);
  Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
  std::array<ScrewTelemetry, 4> tel{};
  std::vector<double> out;
  for (int k = 0; k < 300; ++k) {
    const std::array<double, 4> sp = test::closed_loop_cycle(c, plant, data, eta, zeta, tel, 0.01 * k, k % 3 == 0);
    out.insert(out.end(), sp.begin(), sp.end());
    for (int i = 0; i < 3; ++i) out.push_back(c.eta_estimate()[i]);
  }
  return out;
}
}  // namespace

TEST_CASE("online effects applied: the controller with the slope's estimate steps as with the slope in the file") {
  const ModelFile marked = with_effects(slope(0, 0, true));
  Model applied = build_model(marked, "sand");
  set_effect_parameters(applied, online_effect_params(marked, EffectRegistry::builtin()), VecE(0.05, -0.02, 0));
  const Model in_file = build_model(with_effects(slope(0.05, -0.02, false)), "sand");
  const Model flat = build_model(marked, "sand");
  // On tilted ground (the truth is the file's slope): bit for bit the same controller, and not
  // the controller that keeps the file's 0.
  const std::vector<double> a = closed_loop(applied, in_file), b = closed_loop(in_file, in_file);
  CHECK(a == b);
  CHECK(closed_loop(flat, in_file) != b);
}

TEST_CASE("online effects applied: no allocation in the apply path; the fallback restores the file's values") {
  const ModelFile configured = with_effects(slope(0, 0, true) +
                                            "[[effect]]\nid = \"quadratic_drag\"\nc_x_nspm2 = { value = 10, online = true }\n");
  const Model cm = build_model(configured, "sand");
  const Model tm = build_model(with_effects(slope(0.08, 0, false)), "sand");
  const std::vector<OnlineEffectParam> params = online_effect_params(configured, EffectRegistry::builtin());
  OnlineEstimator est(cm, on(), params);
  Model ctl = cm;  // the controller's model, updated in place as augerd does (online_link.cpp)
  Controller c(ctl, ControllerConfig{});
  c.set_enabled(true);
  OnlineDrive drive(tm, tm, OnlineDriveOptions{});
  std::array<ScrewTelemetry, 4> tel{};
  SensorInput s;
  double t_s = 0;
  const auto cycle = [&](bool diverge) {
    if (!diverge) drive.next();  // diverging: the screws held, an absurd velocity
    t_s += OnlineDrive::kDt;
    for (int i = 0; i < 4; ++i) tel[std::size_t(i)] = {drive.omega_rpm[i], true};
    s.has_pose = true;
    s.pose = drive.eta_true();
    c.step(t_s, tel, s);
    est.step(drive.omega_rpm, diverge ? Vec3(5, 5, 5) : drive.zeta_meas, OnlineDrive::kDt, drive.eta_true());
    if (est.applied_changed()) {
      set_terrain_parameters(ctl, est.control_parameters());
      set_effect_parameters(ctl, est.effects(), est.control_effect_parameters());
    }
  };
  alloc_counter::start();
  for (int k = 0; k < 3000; ++k) cycle(false);
  const double incline_used = ctl.effect_overrides[0].value;
  for (int k = 0; k < 800; ++k) cycle(true);
  const long n = alloc_counter::stop();
  INFO("incline_x applied " << incline_used << " rad (truth 0.08), estimate " << est.estimate().effect_value[0]);
  // The estimate reached the controller's model (within 10 % of the truth), the slope's force with it.
  CHECK(std::fabs(incline_used - 0.08) < 0.008);
  CHECK(ctl.effect_overrides[0].effect == ctl.effects[0].get());
  CHECK_FALSE(est.fallback().empty());
  // The fallback: the file's values, in the override slots and so in the effects' forces.
  CHECK(ctl.effect_overrides[0].value == 0);
  CHECK(ctl.effect_overrides[1].value == 0);
  CHECK(ctl.effect_overrides[2].value == 10);
  CHECK(est.control_effect_parameters() == VecE(0, 0, 10));
  CHECK(n == 0);
}

TEST_CASE("online effects applied: a parameter's estimate is applied within its physical range only") {
  // 0.45 rad of true incline, the physical range ends at 0.35: the controller gets at most 0.35.
  const ModelFile configured = with_effects(slope(0, 0, true));
  const OnlineEstimator est = run(configured, with_effects(slope(0.45, 0, false)), 20);
  CHECK(est.control_effect_parameters()[0] <= 0.35);
  CHECK(est.control_effect_parameters()[0] > 0.3);
  Model m = build_model(configured, "sand");
  CHECK_THROWS_AS(set_effect_parameters(m, online_effect_params(configured, EffectRegistry::builtin()), VecE(NAN, 0, 0)),
                  std::invalid_argument);
}
