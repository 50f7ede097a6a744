// Kinematics eqs. (1)-(4) and B of eq. (10), built from the per-screw table, against the
// paper's printed matrices.
#include <catch2/catch.hpp>

#include <Eigen/SVD>

#include "auger/model.hpp"

using namespace auger;

namespace {
Model paper_model() {
  TerrainParams sand{"sand", 0.812, 0.247, 560.33, 320.08, 11.46};
  return make_model(RobotParams{}, sand);
}
}  // namespace

TEST_CASE("K_i built from the table is the printed eq. (4), K_f the printed eq. (2)") {
  const Model m = paper_model();
  const double t = std::tan(kPi / 6), k = 0.15 + 0.30 / t;
  CHECK(m.kappa_m == Approx(0.6696).epsilon(1e-4));
  Mat43 K_i_printed;
  K_i_printed << -1 / t, -1, -k,  //
      -1 / t, 1, -k,              //
      1 / t, 1, -k,               //
      1 / t, -1, -k;
  CHECK((m.K_i - K_i_printed).cwiseAbs().maxCoeff() < 1e-12);
  Mat34 K_f_printed;
  K_f_printed << -t, -t, t, t,  //
      -1, 1, 1, -1,             //
      -1 / k, -1 / k, -1 / k, -1 / k;
  K_f_printed /= 4;
  CHECK((m.K_f - K_f_printed).cwiseAbs().maxCoeff() < 1e-12);
  CHECK((m.K_f * m.K_i - Mat3::Identity()).cwiseAbs().maxCoeff() < 1e-12);
}

TEST_CASE("each row of K_i is rigid-body consistent: -a_i y_i + b_i x_i = c_i = -kappa") {
  for (double phi_deg : {20.0, 30.0, 45.0, 60.0}) {
    RobotParams p;
    p.phi_rad = deg_to_rad(phi_deg);
    const auto screws = screw_table(p);
    const Mat43 K = inverse_kinematics_matrix(p, screws);
    for (int i = 0; i < 4; ++i) {
      const auto& s = screws[static_cast<std::size_t>(i)];
      CHECK(-K(i, 0) * s.y_m + K(i, 1) * s.x_m == Approx(K(i, 2)));
      CHECK(K(i, 2) == Approx(-kappa_m(p)));
    }
    // A pure rotation: each screw's no-slip speed matches its contact point's velocity.
    const Vec3 zeta(0.02, -0.01, 0.3);
    for (int i = 0; i < 4; ++i) {
      const auto& s = screws[static_cast<std::size_t>(i)];
      const double cu = zeta[0] - zeta[2] * s.y_m, cv = zeta[1] + zeta[2] * s.x_m;
      CHECK(K.row(i).dot(zeta) == Approx(K(i, 0) * cu + K(i, 1) * cv));
    }
  }
}

TEST_CASE("eqs. (1) and (3) invert each other in rpm") {
  const Model m = paper_model();
  const Vec3 zeta(0.05, -0.03, 0.1);
  CHECK((kinematic_body_velocity(m, kinematic_screw_speeds_rpm(m, zeta)) - zeta).norm() < 1e-12);
  // Forward at 15 rpm on every screw pattern: no-slip u = r_s tan(phi) omega.
  const Vec4 fwd(-15, -15, 15, 15);
  CHECK(kinematic_body_velocity(m, fwd)[0] == Approx(0.0775 * std::tan(kPi / 6) * 15 * kRpmToRadps));
}

TEST_CASE("mecanum limit: phi = 45 deg gives kappa = l_x + l_y and ros2 mecanum_drive_controller") {
  RobotParams p;
  p.phi_rad = kPi / 4;
  const double lx = p.l_x_m, ly = p.l_y_m, k = lx + ly;
  CHECK(kappa_m(p) == Approx(k));
  const Mat43 K = inverse_kinematics_matrix(p, screw_table(p));
  // ros2_controllers mecanum_drive_controller, wheel speed * r = row . [vx, vy, wz], rows in our
  // screw order (front-right, rear-right, rear-left, front-left).
  Mat43 ros2;
  ros2 << 1, 1, k,  //
      1, -1, k,     //
      1, 1, -k,     //
      1, -1, -k;
  // Equal up to the right modules' mirrored mounting (a per-module direction sign).
  const Vec4 direction(-1, -1, 1, 1);
  CHECK((K - direction.asDiagonal() * ros2).cwiseAbs().maxCoeff() < 1e-12);
}

TEST_CASE("B built from the table is the printed eq. (10); S B has null space [-1, 1, -1, 1]") {
  const Model m = paper_model();
  const double c = -0.15 * std::sin(deg_to_rad(26.5));
  Mat34 B_printed;
  B_printed << -1, -1, 1, 1,  //
      -1, 1, 1, -1,           //
      c, c, c, c;
  CHECK((m.B - B_printed).cwiseAbs().maxCoeff() < 1e-15);
  CHECK(c == Approx(-0.0669).epsilon(1e-3));
  // x/y rows of B point where the no-slip motion of K_i points, screw by screw.
  for (int i = 0; i < 4; ++i) {
    CHECK(m.B(0, i) == (m.K_i(i, 0) > 0 ? 1 : -1));
    CHECK(m.B(1, i) == (m.K_i(i, 1) > 0 ? 1 : -1));
  }
  CHECK((m.SB * Vec4(-1, 1, -1, 1)).norm() < 1e-15);
  Eigen::JacobiSVD<Mat34> svd(m.SB, Eigen::ComputeFullV);
  CHECK(svd.singularValues().minCoeff() > 1e-3);  // rank 3
  const Vec4 n = svd.matrixV().col(3);
  CHECK(std::fabs(n.dot(m.null_space)) == Approx(1.0));
  CHECK((m.SB * m.SB_pinv - Mat3::Identity()).cwiseAbs().maxCoeff() < 1e-12);
}

TEST_CASE("wrap_angle maps to (-pi, pi]") {
  CHECK(wrap_angle(kPi) == Approx(kPi));
  CHECK(wrap_angle(-kPi) == Approx(kPi));
  CHECK(wrap_angle(3 * kPi) == Approx(kPi));
  CHECK(wrap_angle(2 * kPi + 0.1) == Approx(0.1));
  CHECK(wrap_angle(-0.1 - 4 * kPi) == Approx(-0.1));
}
