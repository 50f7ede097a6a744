// Effect interface and registry: creation by id with checked parameters, and the shipped effects
// against their closed-form behaviour.
#include <cmath>
#include <algorithm>
#include <memory>
#include <vector>

#include <catch2/catch.hpp>

#include "auger/dynamics.hpp"
#include "auger/effect.hpp"

using namespace auger;

namespace {
const TerrainParams kSand{"sand", 0.812, 0.247, 560.33, 320.08, 11.46};

EffectConfig config(const std::string& id, std::vector<EffectParamValue> params) {
  EffectConfig c;
  c.id = id;
  c.params = std::move(params);
  c.file = "fx.toml";
  c.line = 7;
  c.column = 1;
  return c;
}
}  // namespace

TEST_CASE("registry creates effects by id and rejects unknown ids and parameters with file and line") {
  const EffectRegistry& r = EffectRegistry::builtin();
  CHECK(r.has("coulomb_friction"));
  auto e = r.create(config("coulomb_friction", {{"force_x_n", 3, 8, 1}}));
  CHECK(e->id() == "coulomb_friction");
  try {
    r.create(config("magic", {}));
    FAIL("accepted an unknown id");
  } catch (const ConfigError& ex) {
    CHECK(ex.line() == 7);
    CHECK_THAT(ex.what(), Catch::StartsWith("fx.toml:7:1:") && Catch::Contains("magic"));
  }
  try {
    r.create(config("coulomb_friction", {{"force_x_n", 3, 8, 1}, {"mu", 0.5, 9, 1}}));
    FAIL("accepted an unknown parameter");
  } catch (const ConfigError& ex) {
    CHECK(ex.line() == 9);
    CHECK_THAT(ex.what(), Catch::Contains("'mu'"));
  }
  CHECK_THROWS_AS(r.create(config("screw_dead_band", {})), ConfigError);  // required parameter
  CHECK_THROWS_AS(r.create(config("coulomb_friction", {{"force_y_n", -1, 8, 1}})), ConfigError);
  EffectRegistry mine;
  register_builtin_effects(mine);
  CHECK_THROWS_AS(register_builtin_effects(mine), std::invalid_argument);  // duplicate ids
}

TEST_CASE("Coulomb friction: holds below the level, sliding at (tau - F) / D above, stops without reversing") {
  const Vec3 F(20, 6, 0.5);
  const Model m = make_model(RobotParams{}, kSand, {std::make_shared<CoulombFriction>(F)});
  DynamicsData data(m);
  Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
  // Forward drive of 0.812 * 4 * 5 = 16.2 N < 20 N: the robot does not move at all.
  const Vec4 slow(-5, -5, 5, 5);
  for (int k = 0; k < 100; ++k) dynamics_step(m, data, eta, zeta, slow, 0.01);
  CHECK(zeta.norm() == 0.0);
  CHECK(eta.norm() == 0.0);
  CHECK(data.tau_effect_n.x() == Approx(-m.SB.row(0).dot(slow)));
  // 15 rpm: 48.7 N > 20 N, steady u = (tau - F) / D_x.
  const Vec4 fast(-15, -15, 15, 15);
  for (int k = 0; k < 300; ++k) dynamics_step(m, data, eta, zeta, fast, 0.01);
  CHECK(zeta.x() == Approx((m.SB.row(0).dot(fast) - F.x()) / m.D_diag.x()).epsilon(1e-9));
  // Screws stopped: it decelerates faster than viscous alone, reaches zero in finite time and stays.
  bool reversed = false;
  int stopped_at = -1;
  for (int k = 0; k < 100; ++k) {
    dynamics_step(m, data, eta, zeta, Vec4::Zero(), 0.01);
    reversed = reversed || zeta.x() < 0;
    if (stopped_at < 0 && zeta.x() == 0.0) stopped_at = k;
  }
  CHECK_FALSE(reversed);
  CHECK(stopped_at >= 0);
  CHECK(stopped_at < 10);  // viscous alone would take about 5 time constants (25 steps) to 1 %
  CHECK(zeta.x() == 0.0);
}

TEST_CASE("Coulomb friction's tanh form: creeps below the level, slides above, tends to the hard sign") {
  const Vec3 F(20, 6, 0.5);
  const double smooth_mps = 0.01;
  const Model m = make_model(RobotParams{}, kSand, {std::make_shared<CoulombFriction>(F, smooth_mps)});
  // The steady speed of tau - F tanh(u / smooth) - D u = 0, by bisection (the test's own solve).
  auto steady = [&](double tau_n) {
    double lo = 0, hi = tau_n / m.D_diag.x();
    for (int i = 0; i < 200; ++i) {
      const double u = 0.5 * (lo + hi);
      (tau_n - F.x() * std::tanh(u / smooth_mps) - m.D_diag.x() * u > 0 ? lo : hi) = u;
    }
    return 0.5 * (lo + hi);
  };
  for (const Vec4& drive : {Vec4(-5, -5, 5, 5), Vec4(-15, -15, 15, 15)}) {
    DynamicsData data(m);
    Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
    for (int k = 0; k < 400; ++k) dynamics_step(m, data, eta, zeta, drive, 0.01);
    const double tau_n = m.SB.row(0).dot(drive);
    CAPTURE(tau_n);
    // Below the level (16.2 N against 20 N) the hard sign sticks; the tanh form creeps, slower
    // than without friction by far.
    CHECK(zeta.x() == Approx(steady(tau_n)).epsilon(1e-6));
    CHECK(zeta.x() > 0);
    CHECK(zeta.x() < tau_n / m.D_diag.x());
    // Stopped, it decelerates to rest without reversing.
    bool reversed = false;
    for (int k = 0; k < 300; ++k) {
      dynamics_step(m, data, eta, zeta, Vec4::Zero(), 0.01);
      reversed = reversed || zeta.x() < 0;
    }
    CHECK_FALSE(reversed);
    CHECK(std::fabs(zeta.x()) < 1e-6);
  }
  // A sliding speed of 0.1 micrometre per second is the hard sign: the slow drive holds (it
  // creeps at atanh(16.2 / 20) times that).
  const Model hard = make_model(RobotParams{}, kSand, {std::make_shared<CoulombFriction>(F, 1e-7)});
  DynamicsData data(hard);
  Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
  for (int k = 0; k < 100; ++k) dynamics_step(hard, data, eta, zeta, Vec4(-5, -5, 5, 5), 0.01);
  CHECK(std::fabs(zeta.x()) < 1e-6);
  CHECK_THROWS_AS(EffectRegistry::builtin().entries().at("coulomb_friction").make({1, 1, 0, -0.01}), std::invalid_argument);
}

TEST_CASE("dead band removes the force of slow screws only") {
  const Model m = make_model(RobotParams{}, kSand, {std::make_shared<ScrewDeadBand>(2.0)});
  DynamicsData data(m);
  Vec3 tau;
  const Vec4 omega(1.5, -10, 1.9, 12);
  drive_force(m, data, omega, 0.01, tau);
  CHECK((tau - m.SB * Vec4(0, -10, 0, 12)).norm() < 1e-12);
}

namespace {
// The drive force of eq. (7) through a traction saturation of the given parameters, and its model.
std::pair<Model, Vec3> saturated_drive(double long_n, double lat_n, double p, double pooling, double ellipse,
                                       const Vec4& omega) {
  const Model m = make_model(RobotParams{}, kSand,
                             {EffectRegistry::builtin().create(config("traction_saturation", {{"force_max_long_n", long_n},
                                                                                             {"force_max_lat_n", lat_n},
                                                                                             {"sharpness", p},
                                                                                             {"pooling", pooling},
                                                                                             {"ellipse", ellipse}}))});
  DynamicsData data(m);
  Vec3 tau;
  drive_force(m, data, omega, 0.01, tau);
  return {m, tau};
}
}  // namespace

TEST_CASE("traction saturation: each screw's own force, or pooled, the footprint's total saturating per axis") {
  const EffectRegistry& reg = EffectRegistry::builtin();
  const double L = 6, Ly = 2, p = 4;
  auto sat = [&](double f, double limit) { return f / std::pow(1 + std::pow(std::fabs(f / limit), p), 1 / p); };
  auto tau_with = [&](double pooling, const Vec4& omega) { return saturated_drive(L, Ly, p, pooling, 0, omega); };
  const Vec4 omega(-20, -4, 6, 18);  // unequal screws: the two forms differ
  {  // Each screw's own: x and y of each column saturated apart.
    const auto [m, tau] = tau_with(0, omega);
    double x = 0, y = 0;
    for (int i = 0; i < 4; ++i) {
      const Vec3 f = m.SB.col(i) * omega[i];
      x += sat(f.x(), L);
      y += sat(f.y(), Ly);
    }
    CHECK(tau.x() == Approx(x));
    CHECK(tau.y() == Approx(y));
  }
  {  // Pooled: the total along each axis against four screws' limit, whatever the split.
    const auto [m, tau] = tau_with(1, omega);
    const Vec3 total = m.SB * omega;
    CHECK(tau.x() == Approx(4 * sat(total.x() / 4, L)));
    CHECK(tau.y() == Approx(4 * sat(total.y() / 4, Ly)));
    const Vec3 own = tau_with(0, omega).second;
    CHECK(std::fabs(tau.x() - own.x()) > 0.05 * std::fabs(own.x()));
  }
  // Equal screws: the footprint's total and the screws' own are the same.
  const Vec4 even(-10, -10, 10, 10);
  CHECK((tau_with(1, even).second - tau_with(0, even).second).norm() < 1e-9);
  CHECK_THROWS_AS(reg.create(config("traction_saturation", {{"pooling", 1.5}})), ConfigError);
  // A caller that gives the values of before the form parameter gets its default.
  const auto& entry = reg.entries().at("traction_saturation");
  const auto before = entry.make({L, Ly, p});
  CHECK(before->params().size() == 5);
  CHECK(before->params()[3].second == 0.0);
  CHECK(before->params()[4].second == 0.0);
  CHECK(entry.describe({L, Ly, p}).find("each screw's thrust") == 0);
  CHECK_THROWS_AS(entry.make({L, Ly, p, 0, 0, 1}), std::invalid_argument);
}

TEST_CASE("traction saturation's friction ellipse: the axes share one limit on the norm of their loads") {
  const EffectRegistry& reg = EffectRegistry::builtin();
  const double L = 6, Ly = 2, p = 20;  // nearly a clip
  auto tau_with = [&](double pooling, double ellipse, const Vec4& omega) {
    return saturated_drive(L, Ly, p, pooling, ellipse, omega);
  };
  auto sat = [&](double n) { return 1 / std::pow(1 + std::pow(n, p), 1 / p); };
  {  // One screw's own force: (x / L, y / Ly) on an ellipse, both axes scaled by the same share.
    const Vec4 omega(0, 0, 0, 20);
    const auto [m, tau] = tau_with(0, 1, omega);
    const Vec3 f = m.SB.col(3) * omega[3];
    const double n = std::hypot(f.x() / L, f.y() / Ly);
    REQUIRE(n > 1.5);  // well beyond the limit: the ellipse and the box differ
    CHECK(tau.x() == Approx(f.x() * sat(n)));
    CHECK(tau.y() == Approx(f.y() * sat(n)));
    CHECK(tau.z() == Approx(f.z() * sat(n)));
    // Per axis, each saturates apart and keeps more.
    const Vec3 box = tau_with(0, 0, omega).second;
    CHECK(std::fabs(box.x()) > 1.2 * std::fabs(tau.x()));
    // The resulting force lies on the ellipse (a near-clip): (x / L)^2 + (y / Ly)^2 = 1.
    CHECK(std::hypot(tau.x() / L, tau.y() / Ly) == Approx(1).epsilon(0.05));
  }
  {  // The footprint's total, clipped as one: the norm of (x, y, yaw over the lever arm) shared.
    const Vec4 omega(-20, -4, 6, 18);
    const auto [m, tau] = tau_with(1, 1, omega);
    const Vec3 total = m.SB * omega;
    const double lever_m = std::fabs(m.SB(2, 0) / m.SB(1, 0));
    const double n = std::sqrt(std::pow(total.x() / 4 / L, 2) + std::pow(total.y() / 4 / Ly, 2) +
                               std::pow(total.z() / 4 / lever_m / Ly, 2));
    CHECK(tau.x() == Approx(total.x() * sat(n)));
    CHECK(tau.y() == Approx(total.y() * sat(n)));
    CHECK(tau.z() == Approx(total.z() * sat(n)));
  }
  // Below every limit, nothing changes, whatever the form.
  const Vec4 slow(0.1, -0.1, 0.1, 0.1);
  const auto [m0, tau0] = tau_with(0.5, 0.7, slow);
  CHECK((tau0 - m0.SB * slow).norm() < 1e-9 * (m0.SB * slow).norm());
  CHECK_THROWS_AS(reg.create(config("traction_saturation", {{"ellipse", -0.1}})), ConfigError);
}

TEST_CASE("dead band: other widths forward and backward, a gate, a dead zone or a ramp back to the nominal") {
  // Written from the band's physics: below the band no thrust; above it the thrust speed ramps
  // from 0 at the band with slope 1 / shift until it meets the nominal line (at band / (1 - shift)).
  auto thrust_rpm = [](double w, double band_rpm, double shift) {
    const double a = std::fabs(w);
    if (a <= band_rpm) return 0.0;
    if (shift == 0 || a >= band_rpm / (1 - shift)) return w;
    return std::copysign((a - band_rpm) / shift, w);
  };
  const EffectRegistry& r = EffectRegistry::builtin();
  for (double shift : {0.0, 0.25, 0.5, 1.0})
    for (double asym : {-0.5, 0.0, 0.4}) {
      const double mean = 2.0, fwd = mean * (1 + asym), back = mean * (1 - asym);
      const Model m = make_model(RobotParams{}, kSand,
                                 {r.create(config("screw_dead_band", {{"omega_dead_rpm", mean, 8, 1},
                                                                      {"shift", shift, 9, 1},
                                                                      {"asymmetry", asym, 10, 1}}))});
      DynamicsData data(m);
      for (double w0 : {-9.0, -3.1, -1.5, -0.5, 0.7, 1.9, 2.6, 3.3, 5.0, 12.0}) {
        const Vec4 omega(w0, -w0, 0.5 * w0, 2 * w0);
        Vec3 tau;
        drive_force(m, data, omega, 0.01, tau);
        Vec4 expect;
        for (int i = 0; i < 4; ++i) expect[i] = thrust_rpm(omega[i], omega[i] > 0 ? fwd : back, shift);
        INFO("shift " << shift << " asymmetry " << asym << " omega " << w0);
        CHECK((tau - m.SB * expect).norm() < 1e-9 * (1 + tau.norm()));
      }
    }
  // A file that gives only the width keeps the former default: a symmetric dead zone.
  const auto zone = r.create(config("screw_dead_band", {{"omega_dead_rpm", 1.5, 8, 1}}));
  CHECK(zone->params() == std::vector<std::pair<std::string, double>>{{"omega_dead_rpm", 1.5}, {"shift", 1.0}, {"asymmetry", 0.0}});
  for (auto bad : {std::pair<const char*, double>{"shift", 1.5}, {"shift", -0.1}, {"asymmetry", 1.2}})
    try {
      r.create(config("screw_dead_band", {{"omega_dead_rpm", 1.5, 8, 1}, {bad.first, bad.second, 9, 3}}));
      FAIL("accepted " << bad.first << " = " << bad.second);
    } catch (const ConfigError& ex) {
      CHECK_THAT(ex.what(), Catch::StartsWith("fx.toml:7:1:") && Catch::Contains(bad.first));  // the effect's line
    }
}

TEST_CASE("IMU heading bias changes what the IMU reports, not the pose") {
  const Model m = make_model(RobotParams{}, kSand, {std::make_shared<ImuHeadingBias>(0.2)});
  SensorValues v;
  predict_sensors(m, Vec3(1, 2, 3.1), Vec3(0, 0, 0.3), v);
  CHECK(v.pose == Vec3(1, 2, 3.1));
  CHECK(v.imu_psi_rad == Approx(wrap_angle(3.3)));
  CHECK(v.imu_r_radps == 0.3);
}

TEST_CASE("IMU heading drift: linear by default; settling, its rate decays and the heading error ends at bias + drift / k") {
  const EffectRegistry& reg = EffectRegistry::builtin();
  auto imu_at = [&](const std::vector<EffectParamValue>& params, double t_s, double* r_radps = nullptr) {
    const Model m = make_model(RobotParams{}, kSand, {reg.create(config("imu_heading_drift", params))});
    SensorValues v;
    v.t_s = t_s;
    predict_sensors(m, Vec3(0, 0, 0.5), Vec3(0, 0, 0.1), v);
    if (r_radps) *r_radps = v.imu_r_radps;
    return v.imu_psi_rad - 0.5;
  };
  double r = 0;
  // A model file of before the settling form: the linear drift.
  CHECK(imu_at({{"bias_rad", 0.01}, {"drift_radps", 1e-3}}, 100, &r) == Approx(0.11));
  CHECK(r == Approx(0.101));
  // Settling over 20 s: half the way after 20 ln 2 s, 0.01 + 1e-3 * 20 at the end, the rate decayed.
  const std::vector<EffectParamValue> settling{{"bias_rad", 0.01}, {"drift_radps", 1e-3}, {"settle_per_s", 0.05}};
  CHECK(imu_at(settling, 20 * std::log(2.0)) == Approx(0.01 + 0.5 * 0.02));
  CHECK(imu_at(settling, 400, &r) == Approx(0.03).epsilon(1e-6));
  CHECK(r == Approx(0.1).margin(1e-10));
  // Towards k = 0 the settling form joins the linear drift (no jump for the fit to see).
  CHECK(imu_at({{"bias_rad", 0.01}, {"drift_radps", 1e-3}, {"settle_per_s", 1e-9}}, 100) == Approx(0.11).epsilon(1e-6));
  CHECK_THROWS_AS(reg.create(config("imu_heading_drift", {{"settle_per_s", -0.01}})), ConfigError);
}

TEST_CASE("stick-slip friction: breakaway excess decays with the contacts' sliding speed, also in yaw") {
  const EffectRegistry& r = EffectRegistry::builtin();
  const double ratio = 2.0, v_s = 0.002;
  auto e = r.create(config("stick_slip_friction", {{"force_x_n", 6, 8, 1},
                                                   {"force_y_n", 2, 9, 1},
                                                   {"torque_psi_nm", 0.1, 10, 1},
                                                   {"breakaway_ratio", ratio, 11, 1},
                                                   {"stribeck_mps", v_s, 12, 1}}));
  const Model m = make_model(RobotParams{}, kSand, {});
  const double radius_m = std::hypot(m.robot.l_x_m, m.robot.l_y_m);
  EffectContext ctx;
  ctx.gain = Vec3(1e-3, 1e-3, 1e-2);
  ctx.zeta_free = Vec3(1, 1, 1);  // moving on: the force is minus the level
  Vec3 f = Vec3::Zero();
  // At rest: the breakaway level, ratio x sliding.
  ctx.zeta = Vec3::Zero();
  e->body_force(m, ctx, f, nullptr);
  CHECK(f.x() == Approx(-ratio * 6));
  CHECK(f.z() == Approx(-ratio * 0.1));
  // Sliding at v_s along x, and turning so that the contacts slide at v_s: the excess is 1/e of
  // the breakaway's in both (a yaw rate read as m/s would leave exp(-radius) of it instead).
  ctx.zeta = Vec3(v_s, 0, v_s / radius_m);
  e->body_force(m, ctx, f, nullptr);
  const double factor = 1 + (ratio - 1) * std::exp(-1.0);
  CHECK(f.x() == Approx(-6 * factor));
  CHECK(f.z() == Approx(-0.1 * factor));
  // Fast: the sliding level.
  ctx.zeta = Vec3(0.1, 0.1, 0.3);
  e->body_force(m, ctx, f, nullptr);
  CHECK(f.x() == Approx(-6).epsilon(1e-6));
  CHECK(f.y() == Approx(-2).epsilon(1e-6));
  CHECK(f.z() == Approx(-0.1).epsilon(1e-6));
}

namespace {
// The force along x of a force_lag model driven from rest at 0 rpm by a step to w_rpm at t = 0,
// sampled at the end of every step of h_s until t_end_s.
std::vector<double> lag_step_response(double tau_s, double delay_s, double h_s, double t_end_s, double w_rpm) {
  const Model m = make_model(RobotParams{}, kSand,
                             {EffectRegistry::builtin().entries().at("force_lag").make({tau_s, delay_s})});
  DynamicsData data(m);
  Vec3 tau;
  drive_force(m, data, Vec4::Zero(), 0.0, tau);  // a zero-length step: the state starts at rest
  std::vector<double> fx;
  const Vec4 w(w_rpm, w_rpm, -w_rpm, -w_rpm);  // straight along x (B's first row)
  for (double t = 0; t < t_end_s - 1e-9; t += h_s) {
    drive_force(m, data, w, h_s, tau);
    fx.push_back(tau.x());
  }
  return fx;
}
}  // namespace

TEST_CASE("force lag: a first-order lag after a dead time, the same for any step length") {
  const double tau_s = 0.3, w = -10;
  const double f_end = (make_model(RobotParams{}, kSand, {}).SB * Vec4(w, w, -w, -w)).x();
  REQUIRE(std::fabs(f_end) > 1);
  SECTION("no delay: the exact first-order step response at every step's end") {
    const auto fx = lag_step_response(tau_s, 0.0, 0.01, 1.0, w);
    for (std::size_t n = 0; n < fx.size(); ++n)
      CHECK(fx[n] == Approx(f_end * (1 - std::exp(-0.01 * static_cast<double>(n + 1) / tau_s))).margin(1e-9));
  }
  SECTION("a delay of whole steps shifts the response by exactly those steps, zero before") {
    const auto plain = lag_step_response(tau_s, 0.0, 0.01, 1.0, w);
    const auto late = lag_step_response(tau_s, 0.07, 0.01, 1.0, w);
    for (std::size_t n = 0; n < 7; ++n) CHECK(late[n] == Approx(0.0).margin(1e-9));
    for (std::size_t n = 7; n < late.size(); ++n) CHECK(late[n] == Approx(plain[n - 7]).margin(1e-9));
  }
  SECTION("a delay between steps: the continuous response within 0.5 % at every step's end") {
    const double d = 0.033;
    for (double h : {0.01, 0.0125, 0.004}) {
      const auto fx = lag_step_response(tau_s, d, h, 1.0, w);
      for (std::size_t n = 0; n < fx.size(); ++n) {
        const double t = h * static_cast<double>(n + 1);
        const double exact = t <= d ? 0.0 : f_end * (1 - std::exp(-(t - d) / tau_s));
        CHECK(std::fabs(fx[n] - exact) < 0.005 * std::fabs(f_end));
      }
    }
  }
  SECTION("a run starts at the steady force of its first speeds, which it keeps for the delay") {
    const Model m = make_model(RobotParams{}, kSand,
                               {EffectRegistry::builtin().entries().at("force_lag").make({tau_s, 0.05})});
    DynamicsData data(m);
    Vec3 tau;
    drive_force(m, data, Vec4(w, w, -w, -w), 0.0, tau);
    for (int n = 0; n < 5; ++n) {
      drive_force(m, data, Vec4::Zero(), 0.01, tau);
      CHECK(tau.x() == Approx(f_end).margin(1e-9));
    }
    drive_force(m, data, Vec4::Zero(), 0.01, tau);
    CHECK(std::fabs(tau.x()) < 0.98 * std::fabs(f_end));
  }
  SECTION("the delay is bounded") {
    CHECK_THROWS_WITH(EffectRegistry::builtin().entries().at("force_lag").make({0.2, 0.3}),
                      Catch::Contains("delay_s must be in [0, 0.2]"));
  }
}

namespace {
// The yaw torque of a yaw-only screw pattern through yaw_time_constant's soil spring, at the end
// of every step of h_s from a standstill (0 rpm) to w_rpm; and that pattern's steady torque.
std::vector<Vec3> spring_step_response(double spring_s, double damping, double h_s, double t_end_s, Vec4 w,
                                       Vec3* steady) {
  const Model m = make_model(RobotParams{}, kSand,
                             {EffectRegistry::builtin().entries().at("yaw_time_constant").make({0.3, spring_s, damping})});
  *steady = make_model(RobotParams{}, kSand, {}).SB * w;
  DynamicsData data(m);
  Vec3 tau;
  drive_force(m, data, Vec4::Zero(), 0.0, tau);
  std::vector<Vec3> out;
  for (double t = 0; t < t_end_s - 1e-9; t += h_s) {
    drive_force(m, data, w, h_s, tau);
    out.push_back(tau);
  }
  return out;
}
}  // namespace

TEST_CASE("yaw time constant's soil spring: the yaw torque through a second-order filter, the same for any step "
          "length") {
  const Vec4 w(10, 10, 10, 10);  // eq. (10): every screw the same yaw lever
  Vec3 steady;
  spring_step_response(0.5, 0.3, 0.01, 0.01, w, &steady);
  REQUIRE(std::fabs(steady.z()) > 1e-3);
  const double spring_s = 0.5, wn = 1 / spring_s;
  SECTION("below critical damping the turn's torque overshoots: the closed form within 1 % of the step") {
    const double z = 0.3, wd = wn * std::sqrt(1 - z * z);
    for (double h : {0.01, 0.004, 0.0125}) {
      double peak = 0;
      const auto r = spring_step_response(spring_s, z, h, 4.0, w, &steady);
      for (std::size_t n = 0; n < r.size(); ++n) {
        const double t = h * static_cast<double>(n + 1);
        const double exact =
            steady.z() * (1 - std::exp(-z * wn * t) * (std::cos(wd * t) + z / std::sqrt(1 - z * z) * std::sin(wd * t)));
        CHECK(std::fabs(r[n].z() - exact) < 0.01 * std::fabs(steady.z()));
        CHECK(r[n].x() == Approx(steady.x()).margin(1e-9));  // x and y pass untouched
        CHECK(r[n].y() == Approx(steady.y()).margin(1e-9));
        peak = std::max(peak, r[n].z() / steady.z());
      }
      CHECK(peak == Approx(1 + std::exp(-kPi * z / std::sqrt(1 - z * z))).epsilon(0.01));  // 1.37
    }
  }
  SECTION("above it, two lags: no overshoot, the closed form within 1 %") {
    const double z = 2, p1 = wn * (-z + std::sqrt(z * z - 1)), p2 = wn * (-z - std::sqrt(z * z - 1));
    const auto r = spring_step_response(spring_s, z, 0.01, 6.0, w, &steady);
    for (std::size_t n = 0; n < r.size(); ++n) {
      const double t = 0.01 * static_cast<double>(n + 1);
      const double exact = steady.z() * (1 + (p2 * std::exp(p1 * t) - p1 * std::exp(p2 * t)) / (p1 - p2));
      CHECK(std::fabs(r[n].z() - exact) < 0.01 * std::fabs(steady.z()));
      CHECK(r[n].z() / steady.z() <= 1.0 + 1e-9);
    }
  }
  SECTION("without a spring (its default) the torque passes as it is") {
    const auto r = spring_step_response(0, 0.3, 0.01, 0.5, w, &steady);
    for (const Vec3& t : r) CHECK(t.z() == Approx(steady.z()).margin(1e-12));
  }
}

TEST_CASE("rigid-body coupling: the rigid body's Coriolis terms; added mass adds inertia and, heavier sideways, a "
          "Munk moment that turns the robot broadside") {
  const EffectRegistry& reg = EffectRegistry::builtin();
  const double m = RobotParams{}.m_kg, u = 0.08, v = 0.05, r = 0.2;
  auto force = [&](const std::vector<EffectParamValue>& params, Vec3* M_diag = nullptr) {
    const Model model = make_model(RobotParams{}, kSand, {reg.create(config("rigid_body_coupling", params))});
    if (M_diag) *M_diag = model.M_diag;
    EffectContext ctx;
    ctx.zeta = Vec3(u, v, r);
    Vec3 f = Vec3::Zero();
    model.effects.front()->body_force(model, ctx, f, nullptr);
    return f;
  };
  Vec3 M;
  // The Munk moment is a real moment: in the model's lumped yaw units (about 1/17 of it).
  const double lump = yaw_lumping(make_model(RobotParams{}, kSand, {}));
  REQUIRE(lump == Approx(1.0 / 17).epsilon(0.1));
  // A model file of before the added mass: the rigid body alone, forces (m r v, -m r u), no moment.
  const Vec3 rigid = force({{"coupling", 1}}, &M);
  CHECK(rigid.x() == Approx(m * r * v));
  CHECK(rigid.y() == Approx(-m * r * u));
  CHECK(rigid.z() == Approx(0).margin(1e-12));
  CHECK(M[1] == Approx(m));
  // Heavier sideways by 2 m (Fossen's C(nu) of diag(m, 3 m)): the sway mass in the surge force,
  // the surge mass in the sway force, and (m11 - m22) u v in yaw: negative while the robot moves
  // forward and to its left, so it turns to the right, its side towards its path.
  const Vec3 heavy = force({{"coupling", 1}, {"added_sway", 2}}, &M);
  CHECK(heavy.x() == Approx(3 * m * r * v));
  CHECK(heavy.y() == Approx(-m * r * u));
  CHECK(heavy.z() == Approx(-2 * m * u * v * lump));
  CHECK(heavy.z() < 0);
  CHECK(M[1] == Approx(3 * m));
  CHECK(M[0] == Approx(m));
  // Soil ahead too (0.5 m): the surge mass in the sway force and the surge inertia; the Munk
  // moment from the difference of the two.
  const Vec3 both = force({{"coupling", 0}, {"added_sway", 2}, {"added_surge", 0.5}}, &M);
  CHECK(both.x() == Approx(2 * m * r * v));
  CHECK(both.y() == Approx(-0.5 * m * r * u));
  CHECK(both.z() == Approx(-1.5 * m * u * v * lump));
  CHECK(M[0] == Approx(1.5 * m));
  CHECK(M[1] == Approx(3 * m));
  CHECK_THROWS_AS(reg.create(config("rigid_body_coupling", {{"added_sway", -0.5}})), ConfigError);
  CHECK_THROWS_AS(reg.create(config("rigid_body_coupling", {{"added_surge", -0.5}})), ConfigError);
}

namespace {
// The force a screw_blocking effect puts on a robot whose contacts slide at 1 m/s along x (far
// above any blocked screw's limit, so each blocked contact resists with its whole limit), every
// screw at omega_rpm, one 10 ms step after another.
struct BlockingProbe {
  std::shared_ptr<const Effect> e;
  Model m;
  std::vector<double> state;
  explicit BlockingProbe(const std::vector<double>& values)
      : e(EffectRegistry::builtin().entries().at("screw_blocking").make(values)),
        m(make_model(RobotParams{}, kSand, {e})),
        state(e->state_size()) {
    e->reset_state(state.data());
  }
  double step(double omega_rpm) {
    EffectContext c;
    c.omega_rpm = Vec4::Constant(omega_rpm);
    c.dt_s = 0.01;
    c.zeta_free = Vec3(1, 0, 0);
    c.gain = Vec3(1e-3, 1e-3, 1e-3);
    Vec3 f;
    e->body_force(m, c, f, state.empty() ? nullptr : state.data());
    return -f.x();
  }
};
}  // namespace

TEST_CASE("resistance offset: the drag acts at the offset point; its moment in the model's lumped yaw units") {
  const EffectRegistry& reg = EffectRegistry::builtin();
  const double ox = 0.1, oy = -0.05, u = 0.08, v = 0.05, r = 0.2;
  const Model model = make_model(RobotParams{}, kSand,
                                 {reg.create(config("resistance_offset", {{"offset_x_m", ox}, {"offset_y_m", oy}}))});
  EffectContext ctx;
  ctx.zeta = ctx.zeta_free = Vec3(u, v, r);
  Vec3 f = Vec3::Zero();
  model.effects.front()->body_force(model, ctx, f, nullptr);
  const double Dx = model.D_diag.x(), Dy = model.D_diag.y();
  // The resistance point moves with (u - r o_y, v + r o_x): the extra drag is what the turn adds.
  CHECK(f.x() == Approx(Dx * r * oy));
  CHECK(f.y() == Approx(-Dy * r * ox));
  // The whole drag's real moment about the centre, scaled as the screws' moments are (about 1/17):
  // unscaled, a fit takes offsets 13-17 times too small from the yaw.
  const double fx = -Dx * (u - r * oy), fy = -Dy * (v + r * ox);
  CHECK(f.z() == Approx(yaw_lumping(model) * (ox * fy - oy * fx)));
  CHECK(std::fabs(f.z()) < 0.1 * std::fabs(ox * fy - oy * fx));
}

TEST_CASE("screw blocking: at once by default; sinking in over sink_s, freed only above release x the threshold") {
  const double force_n = 5, block_rpm = 2;
  SECTION("the default blocks at once and frees at once") {
    BlockingProbe p({force_n, block_rpm, 0.4});
    CHECK(p.state.empty());
    CHECK(p.step(0) == Approx(4 * force_n).epsilon(1e-3));
    CHECK(p.step(1.5 * block_rpm) == 0.0);  // above the fade (1.2 x the threshold)
    CHECK(p.step(block_rpm) == Approx(2 * force_n).epsilon(1e-3));  // half of each screw in the fade's middle
  }
  SECTION("sinking in: the resistance grows linearly over sink_s, then holds") {
    BlockingProbe p({force_n, block_rpm, 0.4, 0.5, 1});
    for (int k = 1; k <= 80; ++k) {
      CAPTURE(k);
      CHECK(p.step(0) == Approx(4 * force_n * std::min(1.0, k * 0.01 / 0.5)).epsilon(1e-3));
    }
    // Without hysteresis, speeding up past the threshold frees the screws; slowing again starts over.
    CHECK(p.step(1.5 * block_rpm) == 0.0);
    CHECK(p.step(0) == Approx(4 * force_n * 0.01 / 0.5).epsilon(1e-3));
  }
  SECTION("hysteresis: a sunk screw holds between the threshold and release x it, and is freed above") {
    BlockingProbe p({force_n, block_rpm, 0.4, 0.2, 2.5});
    for (int k = 0; k < 30; ++k) p.step(0);
    CHECK(p.step(1.5 * block_rpm) == Approx(4 * force_n).epsilon(1e-3));  // 3 rpm: above 2.4, below 4
    CHECK(p.step(2.0 * block_rpm) == Approx(4 * force_n).epsilon(1e-3));
    CHECK(p.step(3.5 * block_rpm) == 0.0);  // 7 rpm: above 2.5 x 2 rpm x 1.2
    CHECK(p.step(1.5 * block_rpm) == 0.0);  // freed, it does not block again between the two
    CHECK(p.step(0) == Approx(4 * force_n * 0.01 / 0.2).epsilon(1e-3));
  }
  const auto& entry = EffectRegistry::builtin().entries().at("screw_blocking");
  CHECK_THROWS_AS(entry.make({force_n, block_rpm, 0.4, -0.1, 1}), std::invalid_argument);
  CHECK_THROWS_AS(entry.make({force_n, block_rpm, 0.4, 0.5, 0.9}), std::invalid_argument);
}
