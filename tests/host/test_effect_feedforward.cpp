// The feedforward of the model's effect forces (ControllerConfig::effect_feedforward, eq. (6)):
// the allocation is asked for the PID's force minus the effects' (off: the PID's alone, bit for
// bit), an applied online estimate reaches it, a non-finite force latches a fault, a huge one is
// clamped to the drive's reach, a drag is taken at the reference's velocity and dry friction not
// at all, and on a slope it cuts the tracking error of the closed loop.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>

#include "alloc_counter.hpp"
#include "closed_loop.hpp"
#include "auger/controller.hpp"
#include "auger/effect.hpp"
#include "auger/online_estimator.hpp"

using namespace auger;

namespace {
const TerrainParams kSand{"sand", 0.812, 0.247, 560.33, 320.08, 11.46};

std::shared_ptr<const Effect> slope(double ix, double iy) {
  return EffectRegistry::builtin().entries().at("terrain_slope").make({ix, iy});
}

// A force the test sets (fed forward only: the dynamics do not see it, so the estimate stays sane).
class FixedFeedforward final : public Effect {
 public:
  explicit FixedFeedforward(const Vec3& f) : f_(f) {}
  const std::string& id() const override {
    static const std::string s = "fixed_feedforward";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override { return {}; }
  bool feedforward_force(const Model&, const Vec3&, const Vec3&, Vec3& force_n) const override {
    force_n = f_;
    return true;
  }

 private:
  Vec3 f_;
};

// The slope's body force as eq. (6) has it, computed here from its definition (not the effect's code).
Vec3 slope_force(double ix, double iy, double psi) {
  const double fx = -29.0 * 9.81 * std::sin(ix), fy = -29.0 * 9.81 * std::sin(iy);
  return Vec3(std::cos(psi) * fx + std::sin(psi) * fy, -std::sin(psi) * fx + std::cos(psi) * fy, 0.0);
}

ControllerConfig config(bool feedforward) {
  ControllerConfig c;
  c.allocator.kind = AllocatorKind::pseudo_inverse;  // S B omega = tau exactly while unsaturated
  c.gamma_per_s = Vec3::Constant(1.0);
  c.effect_feedforward = feedforward;
  return c;
}

std::vector<Waypoint> turns() { return {{0.0, Vec3(0.03, 0.02, 0.4)}, {1.5, Vec3(0.0, 0.04, -0.4)}}; }
}  // namespace

TEST_CASE("effect feedforward: the screws are asked for the PID's force minus the slope's, off as before") {
  const Model m = make_model(RobotParams{}, kSand, {slope(0.05, -0.02)});
  // Two controllers on the same inputs (the plant moved by the one with the feedforward):
  // the same estimate and PID terms, so their allocations differ by the feedforward alone.
  Controller off(m, config(false)), ff(m, config(true));
  for (Controller* c : {&off, &ff}) {
    c->set_waypoints(turns());
    c->set_enabled(true);
  }
  DynamicsData plant(m);
  Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
  std::array<ScrewTelemetry, 4> tel{};
  int compared = 0;
  for (int k = 0; k < 300; ++k) {
    const double t_s = 0.01 * k;
    const std::array<ScrewTelemetry, 4> tel_in = tel;
    SensorInput s;
    s.has_pose = k % 10 == 0;
    s.pose = eta;
    s.has_imu_psi = s.has_imu_r = true;
    s.imu_psi_rad = eta.z();
    s.imu_r_radps = zeta.z();
    const std::array<double, 4> sp_off = off.step(t_s, tel_in, s);
    const std::array<double, 4> sp_ff = test::closed_loop_cycle(ff, m, plant, eta, zeta, tel, t_s, k % 10 == 0);
    // Off: the PID's force allocated, bit for bit.
    AllocationResult today;
    allocate(m, off.config().allocator, off.pid_terms().tau_n, today);
    for (int i = 0; i < 4; ++i) REQUIRE(sp_off[std::size_t(i)] == today.omega_rpm[i]);
    REQUIRE(off.effect_feedforward_n() == Vec3::Zero());
    // On: the same PID terms; the feedforward is the slope's force at the estimated heading.
    REQUIRE(ff.pid_terms().tau_n == off.pid_terms().tau_n);
    REQUIRE(ff.eta_estimate() == off.eta_estimate());
    const Vec3 f = slope_force(0.05, -0.02, ff.eta_estimate().z());
    INFO("step " << k << ", feedforward " << ff.effect_feedforward_n().transpose() << " N, slope " << f.transpose());
    REQUIRE((ff.effect_feedforward_n() - f).norm() < 1e-9);
    if (ff.allocation().scale_primary < 1 || ff.allocation().scale_secondary < 1) continue;  // yaw saturates
    const Vec4 w(sp_ff[0], sp_ff[1], sp_ff[2], sp_ff[3]);
    REQUIRE((m.SB * w - (off.pid_terms().tau_n - f)).norm() < 1e-9);
    ++compared;
  }
  CHECK(compared > 200);  // the comparison ran unsaturated on most steps
  CHECK(std::fabs(eta.z()) > 0.08);  // the heading turned, and the slope's body force with it
}

TEST_CASE("effect feedforward: an applied online estimate of the slope is fed forward") {
  Model applied = make_model(RobotParams{}, kSand, {slope(0, 0)});  // the file's inclines 0, online
  const std::vector<OnlineEffectParam> params{{0, 0, "terrain_slope.incline_x_rad", "rad", 0, -0.35, 0.35, 0.175},
                                              {0, 1, "terrain_slope.incline_y_rad", "rad", 0, -0.35, 0.35, 0.175}};
  set_effect_parameters(applied, params, VecE(0.05, -0.02, 0));
  const Model in_file = make_model(RobotParams{}, kSand, {slope(0.05, -0.02)});
  Controller a(applied, config(true)), b(in_file, config(true));
  for (Controller* c : {&a, &b}) {
    c->set_waypoints(turns());
    c->set_enabled(true);
  }
  std::array<ScrewTelemetry, 4> tel{};
  SensorInput s;
  s.has_pose = true;
  s.pose = Vec3(0, 0, 0.4);
  for (int k = 0; k < 50; ++k) {
    const auto& sa = a.step(0.01 * k, tel, s);
    const auto& sb = b.step(0.01 * k, tel, s);
    REQUIRE(sa == sb);
  }
  CHECK(a.effect_feedforward_n() == b.effect_feedforward_n());
  CHECK(a.effect_feedforward_n().norm() > 10);  // 29 kg on 0.05 rad: 14 N
}

TEST_CASE("effect feedforward: a non-finite effect force latches a fault, a huge one is clamped") {
  std::array<ScrewTelemetry, 4> tel{};
  SensorInput s;
  s.has_pose = true;
  s.pose = Vec3::Zero();
  {
    const Model m = make_model(RobotParams{}, kSand, {std::make_shared<FixedFeedforward>(Vec3(0, NAN, 0))});
    Controller off(m, config(false));
    off.set_enabled(true);
    off.step(0.0, tel, s);
    CHECK(off.fault().empty());  // not consulted when off
    Controller c(m, config(true));
    c.set_waypoints({{0.0, Vec3(0.2, 0, 0)}});
    c.set_enabled(true);
    for (int k = 0; k < 3; ++k) {
      const auto& sp = c.step(0.01 * k, tel, s);
      for (double w : sp) CHECK(w == 0.0);
    }
    CHECK(c.fault().find("non-finite effect force for the feedforward") != std::string::npos);
    CHECK(c.fault().find("fixed_feedforward") != std::string::npos);
    CHECK_FALSE(c.enabled());
  }
  {
    const Model m = make_model(RobotParams{}, kSand, {std::make_shared<FixedFeedforward>(Vec3(-1e6, 0, 0))});
    Controller c(m, config(true));
    c.set_enabled(true);
    const auto& sp = c.step(0.0, tel, s);
    const double reach_n = 23.0 * m.SB.row(0).cwiseAbs().sum();
    CHECK(c.effect_feedforward_n().x() == -reach_n);
    CHECK(c.fault().empty());
    for (double w : sp) {
      CHECK(std::isfinite(w));
      CHECK(std::fabs(w) <= 23.0 + 1e-9);
    }
  }
}

TEST_CASE("effect feedforward: no heap allocation per step") {
  const Model m = make_model(RobotParams{}, kSand, {slope(0.05, -0.02)});
  Controller c(m, config(true));
  c.set_waypoints(turns());
  c.set_enabled(true);
  DynamicsData plant(m);
  Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
  std::array<ScrewTelemetry, 4> tel{};
  test::closed_loop_cycle(c, m, plant, eta, zeta, tel, 0.0, true);
  alloc_counter::start();
  for (int k = 1; k < 200; ++k) test::closed_loop_cycle(c, m, plant, eta, zeta, tel, 0.01 * k, k % 10 == 0);
  CHECK(alloc_counter::stop() == 0);
  CHECK(c.effect_feedforward_n().norm() > 10);
}

namespace {
// RMS of the true position against the reference (eq. (18)) over [from_s, to_s] of a closed loop
// on the core's model with a slope, plant and controller alike, from rest.
double tracking_rms_m(bool feedforward, double from_s, double to_s, const std::vector<Waypoint>& wps) {
  const Model m = make_model(RobotParams{}, kSand, {slope(0.05, 0.03)});
  ControllerConfig cfg;  // Table 5's sand gains, the null-space allocator
  cfg.effect_feedforward = feedforward;
  Controller c(m, cfg);
  c.set_waypoints(wps);
  c.set_enabled(true);
  DynamicsData plant(m);
  Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
  std::array<ScrewTelemetry, 4> tel{};
  double sum = 0;
  int n = 0;
  for (int k = 0; 0.01 * k <= to_s; ++k) {
    test::closed_loop_cycle(c, m, plant, eta, zeta, tel, 0.01 * k, k % 10 == 0);
    if (0.01 * k < from_s) continue;
    sum += (eta.head<2>() - c.reference().eta_d.head<2>()).squaredNorm();
    ++n;
  }
  return std::sqrt(sum / n);
}
}  // namespace

TEST_CASE("effect feedforward: on a slope it cuts the closed loop's tracking error") {
  // 0.05 / 0.03 rad pull 14 / 8.5 N; the PID's integral takes seconds to learn that. Measured
  // (1-4 s, the 0.2 m square's first legs at the default gamma): 0.0446 m off, 0.0041 m on.
  const std::vector<Waypoint> wps{{0.0, Vec3(0.2, 0, 0)}, {1.5, Vec3(0.2, 0.2, 0)}, {3.0, Vec3(0, 0.2, 0)}};
  const double off = tracking_rms_m(false, 1.0, 4.0, wps), on = tracking_rms_m(true, 1.0, 4.0, wps);
  INFO("tracking RMS 1-4 s: feedforward off " << off << " m, on " << on << " m");
  CHECK(off > 0.03);
  CHECK(on < off / 4);
}

TEST_CASE("effect feedforward: a drag at the reference's velocity, dry friction not at all") {
  const auto& reg = EffectRegistry::builtin().entries();
  const Model m = make_model(RobotParams{}, kSand,
                             {reg.at("quadratic_drag").make({400, 300, 2}), reg.at("coulomb_friction").make({20, 10, 0.5})});
  Controller c(m, config(true));
  c.set_waypoints({{0.0, Vec3(0.3, -0.2, 0.5)}});
  c.set_enabled(true);
  std::array<ScrewTelemetry, 4> tel{};
  SensorInput s;
  s.has_pose = true;
  s.pose = Vec3(0, 0, 0.3);
  for (int k = 0; k < 30; ++k) c.step(0.01 * k, tel, s);  // the robot held still: its estimate stays near rest
  const Vec3 v = rotation_J(c.eta_estimate().z()).transpose() * c.reference().eta_d_dot;
  REQUIRE(v.cwiseAbs().minCoeff() > 1e-4);  // the reference moves in every DOF
  const Vec3 drag(-400 * v.x() * std::fabs(v.x()), -300 * v.y() * std::fabs(v.y()), -2 * v.z() * std::fabs(v.z()));
  INFO("feedforward " << c.effect_feedforward_n().transpose() << " N, drag at the reference " << drag.transpose());
  CHECK((c.effect_feedforward_n() - drag).norm() < 1e-12);
}
