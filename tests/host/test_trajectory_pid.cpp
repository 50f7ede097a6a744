// Reference generation eq. (18) (stable form) and tracking PID eqs. (19)-(21).
#include <catch2/catch.hpp>

#include <sstream>

#include "auger/log.hpp"
#include "auger/tracking_pid.hpp"
#include "auger/trajectory.hpp"

using namespace auger;

TEST_CASE("exact reference step equals a fine double-Euler integration of eq. (18), stable form") {
  const Vec3 gamma(0.1, 0.5, 2.0);
  ReferenceState exact, euler;
  reference_reset(exact, Vec3(0, 0, 0));
  exact.eta_d_dot = Vec3(0.1, -0.2, 0.3);
  euler = exact;
  const Vec3 eta_p(1.0, -0.5, 0.7);
  for (int k = 0; k < 500; ++k) reference_step(gamma, exact, eta_p, 0.01);
  const double h = 1e-5;
  for (int k = 0; k < 500000; ++k) {
    const Vec3 acc = gamma.cwiseAbs2().cwiseProduct(eta_p - euler.eta_d) - 2 * gamma.cwiseProduct(euler.eta_d_dot);
    euler.eta_d_dot += h * acc;
    euler.eta_d += h * euler.eta_d_dot;
  }
  CHECK((exact.eta_d - euler.eta_d).norm() < 1e-4);
  CHECK((exact.eta_d_dot - euler.eta_d_dot).norm() < 1e-4);
}

TEST_CASE("reference from rest is critically damped: converges without overshoot") {
  ReferenceState r;
  reference_reset(r, Vec3::Zero());
  const Vec3 gamma = default_gamma_per_s();
  CHECK(gamma == Vec3::Constant(0.1));
  double max_x = 0;
  for (int k = 0; k < 20000; ++k) {
    reference_step(gamma, r, Vec3(0.5, 0, 0), 0.01);
    max_x = std::max(max_x, r.eta_d.x());
  }
  CHECK(max_x <= 0.5);
  CHECK(r.eta_d.x() == Approx(0.5).margin(1e-5));
  CHECK(std::fabs(r.eta_d_dot.x()) < 1e-5);
}

TEST_CASE("heading set-points are approached the short way round") {
  ReferenceState r;
  reference_reset(r, Vec3(0, 0, 3.0));
  for (int k = 0; k < 100; ++k) reference_step(Vec3::Constant(2.0), r, Vec3(0, 0, -3.0), 0.01);
  CHECK(r.eta_d.z() > 3.0);  // through pi, not back through zero
  CHECK(r.eta_d.z() < 2 * kPi - 3.0 + 1e-9);
}

TEST_CASE("waypoints: active one by time, checked order, from CSV with errors located") {
  std::vector<Waypoint> w = {{0.0, Vec3(0, 0, 0)}, {5.0, Vec3(1, 0, 0)}, {10.0, Vec3(1, 1, 0)}};
  CHECK(active_waypoint(w, -1.0) == -1);
  CHECK(active_waypoint(w, 4.99) == 0);
  CHECK(active_waypoint(w, 5.0, 0) == 1);
  CHECK(active_waypoint(w, 100.0, 1) == 2);
  CHECK(active_waypoint(w, 1.0, 2) == 0);  // a stale hint is not trusted
  w[2].t_s = 5.0;
  CHECK_THROWS_AS(check_waypoints(w), std::invalid_argument);
  std::stringstream ok("# square\npsi_rad,t_s,x_m,y_m,speed\n0,0,0,0,1\n1.57,10,0.5,0,1\n");
  const auto loaded = read_waypoints_csv(ok, "sq.csv");
  REQUIRE(loaded.size() == 2);
  CHECK(loaded[1].eta_p == Vec3(0.5, 0, 1.57));
  std::stringstream bad("t_s,x_m,y_m,psi_rad\n0,0,0,0\n1,0,,0\n");
  try {
    read_waypoints_csv(bad, "sq.csv");
    FAIL("accepted an empty waypoint field");
  } catch (const LogError& e) {
    CHECK(e.line() == 3);
    CHECK(e.column() == 5);
  }
}

TEST_CASE("PID works in the body frame with wrapped heading, eq. (20) uses velocity") {
  PidGains g = table5_gains("sand");
  CHECK(g.kp.head<2>() == Eigen::Vector2d(150, 150));
  CHECK(g.kd.x() == 30);
  CHECK(g.ki.x() == 1.2);
  const PidGains grass = table5_gains("frozen_grass");
  CHECK(grass.kp.x() == 160);
  CHECK(grass.kd.y() == 90);
  CHECK(grass.ki.x() == 1.5);
  g.ki.setZero();
  PidState s;
  PidTerms out;
  ReferenceState ref;
  reference_reset(ref, Vec3(1.0, 0, kPi / 2 + 0.01));
  // Robot at the origin facing +y (psi = pi/2): a world error along +x is body -y.
  tracking_pid(g, s, Vec3(0, 0, kPi / 2), Vec3::Zero(), ref, out);
  CHECK(out.error_body.x() == Approx(0).margin(1e-12));
  CHECK(out.error_body.y() == Approx(-1.0));
  CHECK(out.tau_n.y() == Approx(-150.0));
  // Heading error across +-pi is the short one.
  reference_reset(ref, Vec3(0, 0, 3.1));
  tracking_pid(g, s, Vec3(0, 0, -3.1), Vec3::Zero(), ref, out);
  CHECK(out.error_body.z() == Approx(6.2 - 2 * kPi));
  // Reference world velocity along +x seen from a robot facing +y, minus its own velocity.
  ref.eta_d_dot = Vec3(0.1, 0, 0);
  tracking_pid(g, s, Vec3(0, 0, kPi / 2), Vec3(0, 0.02, 0), ref, out);
  CHECK(out.rate_error.y() == Approx(-0.1 - 0.02));
}

TEST_CASE("integral accumulates per step and is clamped") {
  PidGains g = table5_gains("sand");
  g.kp.setZero();
  g.kd.setZero();
  PidState s;
  PidTerms out;
  ReferenceState ref;
  reference_reset(ref, Vec3(0.01, 0, 0));
  tracking_pid(g, s, Vec3::Zero(), Vec3::Zero(), ref, out);
  CHECK(out.tau_n.x() == Approx(1.2 * 0.01));
  for (int k = 0; k < 100000; ++k) tracking_pid(g, s, Vec3::Zero(), Vec3::Zero(), ref, out);
  CHECK(out.tau_n.x() == Approx(g.integral_limit.x()));
}
