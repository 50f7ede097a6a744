// Dynamics eqs. (5)-(7): exact step against the closed form, sub-stepped pose against a fine
// reference, and the gantry check of docs/model-notes.md.
#include <catch2/catch.hpp>

#include "auger/dynamics.hpp"
#include "auger/effect.hpp"
#include "auger/model_file.hpp"

using namespace auger;

namespace {
Model sand_model() {
  return make_model(RobotParams{}, TerrainParams{"sand", 0.812, 0.247, 560.33, 320.08, 11.46});
}
}  // namespace

TEST_CASE("linear part matches the closed-form step response at every sample") {
  const Model m = sand_model();
  DynamicsData data(m);
  const Vec4 omega(-10, 7, 15, -3);
  const Vec3 tau = m.SB * omega;
  Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
  double t = 0;
  for (int k = 0; k < 200; ++k) {
    dynamics_step(m, data, eta, zeta, omega, 0.01);
    t += 0.01;
    for (int d = 0; d < 3; ++d) {
      const double v_inf = tau[d] / m.D_diag[d];
      CHECK(zeta[d] == Approx(v_inf * (1 - std::exp(-m.D_diag[d] * t / m.M_diag[d]))).margin(1e-14));
    }
  }
  CHECK((zeta - steady_velocity(m, omega)).norm() < 3e-3 * steady_velocity(m, omega).norm());  // yaw: I_z / D_psi = 0.32 s
}

TEST_CASE("pure motion along one DOF: the pose is the exact integral") {
  const Model m = sand_model();
  DynamicsData data(m);
  const Vec4 fwd(-15, -15, 15, 15);
  Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
  for (int k = 0; k < 100; ++k) dynamics_step(m, data, eta, zeta, fwd, 0.01);
  const double u_inf = m.SB.row(0).dot(fwd) / m.D_diag[0], T = m.M_diag[0] / m.D_diag[0];
  CHECK(eta.x() == Approx(u_inf * (1.0 - T * (1 - std::exp(-1.0 / T)))).epsilon(1e-8));
  CHECK(std::fabs(eta.y()) < 1e-15);
  CHECK(std::fabs(eta.z()) < 1e-15);
  // docs/model-notes.md red flag: the paper's sand set is faster than no slip at 15 rpm forward.
  CHECK(u_inf == Approx(0.087).margin(0.001));
  CHECK(kinematic_body_velocity(m, fwd)[0] == Approx(0.070).margin(0.001));
}

TEST_CASE("sub-stepped pose converges to a fine reference for combined motion") {
  const Model m = sand_model();
  const Vec4 omega(-20, 5, 18, -12);
  auto run = [&](int n_sub, double dt) {
    DynamicsData data(m);
    Vec3 eta(0.1, -0.2, 3.0), zeta(0.05, -0.02, 0.4);
    const int steps = static_cast<int>(std::lround(2.0 / dt));
    for (int k = 0; k < steps; ++k) dynamics_step(m, data, eta, zeta, omega, dt, n_sub);
    return std::make_pair(eta, zeta);
  };
  const auto fine = run(50, 0.001);
  const auto coarse = run(4, 0.01);
  CHECK((coarse.first.head<2>() - fine.first.head<2>()).norm() < 1e-8);
  CHECK(std::fabs(wrap_angle(coarse.first.z() - fine.first.z())) < 1e-12);
  CHECK((coarse.second - fine.second).norm() < 1e-12);
}

TEST_CASE("gantry check: 20 rpm on sand gives 0.061 m/s long. and 0.130 m/s lat. (65 and 80 %)") {
  const ModelFile g = load_model_file(AUGER_MODELS_DIR "/gantry.toml");
  const TerrainParams& sand = g.find_terrain("sand")->params;
  const double mass = *g.gantry_mass_kg;
  // The module is screws 0 and 1; its B_x, B_y are their columns of the robot's B.
  RobotParams p;
  const Mat34 B = allocation_matrix(p, screw_table(p));
  CHECK(B.block<2, 2>(0, 0) == (Eigen::Matrix2d() << -1, -1, -1, 1).finished());
  const Eigen::Vector2d fwd(-20, -20), side(-20, 20);
  const double tau_x = sand.sigma_long * B.row(0).head<2>().dot(fwd);  // eq. (12)
  const double tau_y = sand.sigma_lat * B.row(1).head<2>().dot(side);  // eq. (14)
  double u = 0, v = 0;
  for (int k = 0; k < 300; ++k) {
    u = first_order_step(mass, sand.D_x, u, tau_x, 0.01);  // eq. (11)
    v = first_order_step(mass, sand.D_y, v, tau_y, 0.01);  // eq. (13)
  }
  CHECK(u == Approx(0.061).margin(0.0005));
  CHECK(v == Approx(0.130).margin(0.0005));
  const double surface = p.r_s_m * 20 * kRpmToRadps;
  CHECK(u / (surface * std::tan(p.phi_rad)) == Approx(0.65).margin(0.01));
  CHECK(v / surface == Approx(0.80).margin(0.01));
}

TEST_CASE("first-order step handles no damping and gives the exact gain") {
  double gain = 0;
  CHECK(first_order_step(2.0, 0.0, 1.0, 4.0, 0.5, &gain) == Approx(2.0));
  CHECK(gain == Approx(0.25));
  CHECK(first_order_displacement(2.0, 0.0, 1.0, 4.0, 0.5) == Approx(0.5 + 0.25));
  const double v1 = first_order_step(29, 560, 0.1, 10, 0.01, &gain);
  const double v2 = first_order_step(29, 560, 0.1, 10.001, 0.01);
  CHECK((v2 - v1) / 0.001 == Approx(gain).epsilon(1e-6));
}

TEST_CASE("the step's exponentials kept per step length follow the step length and the model, to the bit") {
  // dynamics_step keeps exp(-D dt / M) per step length (StepDecay): a step of another length, or
  // the same workspace used with another model's M and D, must not reuse them.
  const Model sand = sand_model();
  const Model grass = make_model(RobotParams{}, TerrainParams{"frozen_grass", 0.4, 0.16, 509.8, 210.5, 4.52});
  DynamicsData data(sand);
  const Vec4 omega(-10, 7, 15, -3);
  Vec3 eta = Vec3::Zero(), zeta(0.01, -0.02, 0.05);
  const double steps[] = {0.01, 0.01, 0.013, 0.013, 0.01, 0.002, 0.01};
  for (int pass = 0; pass < 2; ++pass) {
    const Model& m = pass == 0 ? sand : grass;
    for (double dt : steps) {
      Vec3 expect, tau;
      DynamicsData fresh(m);
      drive_force(m, fresh, omega, dt, tau);  // eq. (7) as dynamics_step sums it
      for (int k = 0; k < 3; ++k) expect[k] = first_order_step(m.M_diag[k], m.D_diag[k], zeta[k], tau[k], dt);
      const double psi = wrap_angle(eta.z() + first_order_displacement(m.M_diag[2], m.D_diag[2], zeta[2], tau[2], dt));
      dynamics_step(m, data, eta, zeta, omega, dt, 1);  // one sub-step: the step itself
      for (int k = 0; k < 3; ++k) CHECK(zeta[k] == expect[k]);
      CHECK(eta.z() == psi);
    }
  }
}

TEST_CASE("traction saturation's shares kept in the workspace are those computed afresh, to the bit") {
  // The saturation keeps each screw's and axis's last load and share in the run's state, for the
  // sub-steps of a step; another sharpness (another model in the same workspace) or another load
  // must not reuse them.
  auto saturated = [](double sharpness) {
    EffectConfig c;
    c.id = "traction_saturation";
    c.params = {{"force_max_long_n", 6.0}, {"force_max_lat_n", 2.0}, {"sharpness", sharpness}};
    return make_model(RobotParams{}, TerrainParams{"sand", 0.812, 0.247, 560.33, 320.08, 11.46},
                      {EffectRegistry::builtin().create(c)});
  };
  const Model soft = saturated(2.0), sharp = saturated(8.0);
  const Vec4 speeds[] = {{-20, -4, 6, 18}, {-20, -4, 6, 18}, {-20, -4, 6, 19}, {0, 0, 0, 0}, {-20, -4, 6, 18}};
  {  // At these loads the sharpness matters, so a share kept from the other model would show.
    Vec3 a, b;
    DynamicsData one(soft), two(sharp);
    drive_force(soft, one, speeds[0], 0.01, a);
    drive_force(sharp, two, speeds[0], 0.01, b);
    REQUIRE((a - b).norm() > 1e-3);
  }
  DynamicsData kept(soft);
  for (int pass = 0; pass < 2; ++pass) {
    const Model& m = pass == 0 ? soft : sharp;
    for (const Vec4& omega : speeds) {
      Vec3 expect, tau;
      DynamicsData fresh(m);
      drive_force(m, fresh, omega, 0.01, expect);
      drive_force(m, kept, omega, 0.01, tau);
      for (int k = 0; k < 3; ++k) CHECK(tau[k] == expect[k]);
    }
  }
}
