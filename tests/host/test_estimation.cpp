// Pose estimation: dead reckoning, the IMU-heading variant, and the EKF with finite-difference
// checks of every Jacobian.
#include <catch2/catch.hpp>

#include <random>
#include <vector>

#include "auger/effect.hpp"
#include "auger/estimation.hpp"

using namespace auger;

namespace {
const TerrainParams kSand{"sand", 0.812, 0.247, 560.33, 320.08, 11.46};

template <int Rows, class F>
Eigen::Matrix<double, Rows, 6> numeric_jacobian(F&& f, const Vec6& x, bool wrap_row2 = false) {
  Eigen::Matrix<double, Rows, 6> J;
  for (int j = 0; j < 6; ++j) {
    const double h = 1e-6;
    Vec6 xp = x, xm = x;
    xp[j] += h;
    xm[j] -= h;
    Eigen::Matrix<double, Rows, 1> d = f(xp) - f(xm);
    if (wrap_row2 && Rows > 2) d[2] = wrap_angle(d[2]);
    J.col(j) = d / (2 * h);
  }
  return J;
}
}  // namespace

TEST_CASE("dead reckoning is the dynamic model; the IMU variant takes the IMU heading") {
  const Model m = make_model(RobotParams{}, kSand);
  DeadReckoning dr(m);
  DynamicsData dyn(m);
  Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
  const Vec4 omega(-12, 4, 15, -6);
  for (int k = 0; k < 100; ++k) {
    dead_reckoning_step(m, dr, omega, 0.01);
    dynamics_step(m, dyn, eta, zeta, omega, 0.01);
  }
  CHECK((dr.eta - eta).norm() == 0.0);
  dead_reckoning_step(m, dr, omega, 0.01, 4.0);
  CHECK(dr.eta.z() == Approx(4.0 - 2 * kPi));
}

TEST_CASE("EKF process Jacobian matches finite differences") {
  const Model m = make_model(RobotParams{}, kSand);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 50; ++trial) {
    Vec6 x;
    x << u(rng), u(rng), 3.2 * u(rng), 0.1 * u(rng), 0.1 * u(rng), 0.5 * u(rng);
    const Vec3 tau(40 * u(rng), 15 * u(rng), 1.5 * u(rng));
    const double dt = trial % 3 == 0 ? 0.1 : 0.01;
    Mat6 F;
    ekf_process(m, x, tau, dt, &F);
    const auto Fn = numeric_jacobian<6>([&](const Vec6& xx) { return ekf_process(m, xx, tau, dt, nullptr); }, x);
    CHECK((F - Fn).cwiseAbs().maxCoeff() < 1e-7);
  }
}

TEST_CASE("EKF process model agrees with the sub-stepped dynamics") {
  const Model m = make_model(RobotParams{}, kSand);
  DynamicsData dyn(m);
  Vec3 eta(0.3, -0.1, 2.0), zeta(0.05, 0.02, 0.3);
  Vec6 x;
  x << eta, zeta;
  const Vec4 omega(-20, 10, 18, -5);
  for (int k = 0; k < 100; ++k) {
    dynamics_step(m, dyn, eta, zeta, omega, 0.01);
    x = ekf_process(m, x, m.SB * omega, 0.01, nullptr);
  }
  CHECK((x.head<2>() - eta.head<2>()).norm() < 1e-5);
  CHECK((x.tail<3>() - zeta).norm() < 1e-12);
}

TEST_CASE("EKF prediction includes the model's body-force effects (dry friction)") {
  // A model with Coulomb friction: the EKF's prediction alone (no measurements) must follow the
  // dynamics with that friction, and differ from the frictionless model's.
  const Model m = make_model(RobotParams{}, kSand, {std::make_shared<CoulombFriction>(Vec3(6.0, 3.0, 0.5))});
  const Model plain = make_model(RobotParams{}, kSand);
  DynamicsData dyn_truth(m), dyn_ekf(m), dyn_plain(plain);
  Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
  EkfConfig cfg;
  Ekf ekf, ekf_plain;
  ekf_reset(cfg, ekf, eta);
  ekf_reset(cfg, ekf_plain, eta);
  for (int k = 0; k < 300; ++k) {
    const Vec4 omega = k < 200 ? Vec4(-15, -10, 15, 10) : Vec4::Zero();  // drive, then coast
    dynamics_step(m, dyn_truth, eta, zeta, omega, 0.01, 1);
    ekf_predict(m, cfg, ekf, dyn_ekf, omega, 0.01);
    ekf_predict(plain, cfg, ekf_plain, dyn_plain, omega, 0.01);
  }
  INFO("truth " << eta.transpose() << ", EKF " << ekf.x.head<3>().transpose() << ", EKF without friction "
                << ekf_plain.x.head<3>().transpose());
  CHECK((ekf.x.head<2>() - eta.head<2>()).norm() < 2e-3);
  CHECK((ekf_plain.x.head<2>() - eta.head<2>()).norm() > 0.02);
  CHECK(ekf.x.tail<3>().norm() < 1e-9);  // stopped by the friction after coasting, as the truth
}

TEST_CASE("EKF measurement Jacobians match finite differences (with a sensor effect)") {
  const Model m = make_model(RobotParams{}, kSand, {std::make_shared<ImuHeadingBias>(0.05)});
  Vec6 x;
  x << 0.4, -0.3, 1.1, 0.05, -0.01, 0.2;
  Eigen::Matrix<double, 1, 6> Hpsi, Hr;
  Eigen::Matrix<double, 3, 6> Hpose;
  ekf_h_imu_psi(m, x, &Hpsi);
  ekf_h_imu_r(m, x, &Hr);
  ekf_h_pose(m, x, &Hpose);
  auto hpsi = [&](const Vec6& xx) { return Eigen::Matrix<double, 1, 1>(ekf_h_imu_psi(m, xx, nullptr)); };
  auto hr = [&](const Vec6& xx) { return Eigen::Matrix<double, 1, 1>(ekf_h_imu_r(m, xx, nullptr)); };
  auto hpose = [&](const Vec6& xx) { return ekf_h_pose(m, xx, nullptr); };
  CHECK((Hpsi - numeric_jacobian<1>(hpsi, x)).cwiseAbs().maxCoeff() < 1e-8);
  CHECK((Hr - numeric_jacobian<1>(hr, x)).cwiseAbs().maxCoeff() < 1e-8);
  CHECK((Hpose - numeric_jacobian<3>(hpose, x, true)).cwiseAbs().maxCoeff() < 1e-8);
}

TEST_CASE("EKF: an IMU bias that jumped at a time of the fitted log takes its newest value; a replay takes it by time") {
  // Fitted on a log: -0.2 rad until t = 50 s of that log, 0.1 rad after. augerd's filter runs now,
  // long after that jump (its own clock starts at 0: the log's times mean nothing to it).
  const Model m = make_model(RobotParams{}, kSand, {std::make_shared<ImuHeadingBias>(0.1, 50.0, -0.2)});
  Vec6 x;
  x << 0.4, -0.3, 1.1, 0.05, -0.01, 0.2;
  CHECK(ekf_h_imu_psi(m, x, nullptr) == Approx(1.1 + 0.1));
  SensorValues replay;
  replay.t_s = 10.0;
  predict_sensors(m, x.head<3>(), x.tail<3>(), replay);
  CHECK(replay.imu_psi_rad == Approx(1.1 - 0.2));
  replay.t_s = 60.0;
  predict_sensors(m, x.head<3>(), x.tail<3>(), replay);
  CHECK(replay.imu_psi_rad == Approx(1.1 + 0.1));
}

TEST_CASE("EKF with camera and IMU tracks a robot whose traction differs from the model") {
  // Truth: 30 % less longitudinal traction than the model believes, an IMU heading bias the
  // model knows about (effect), noisy measurements.
  TerrainParams slippy = kSand;
  slippy.sigma_long *= 0.7;
  const Model truth = make_model(RobotParams{}, slippy);
  const Model model = make_model(RobotParams{}, kSand, {std::make_shared<ImuHeadingBias>(0.1)});
  DynamicsData dyn_truth(truth), dyn_model(model);
  Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
  EkfConfig cfg;
  Ekf ekf;
  ekf_reset(cfg, ekf, eta);
  DeadReckoning dr(model);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0, 1);
  const Mat3 pose_cov = Vec3(0.01 * 0.01, 0.01 * 0.01, 0.02 * 0.02).asDiagonal();
  double worst = 0;
  for (int k = 1; k <= 2000; ++k) {
    const Vec4 omega = k < 1000 ? Vec4(-15, -12, 15, 18) : Vec4(-10, 10, 12, -8);
    dynamics_step(truth, dyn_truth, eta, zeta, omega, 0.01);
    dead_reckoning_step(model, dr, omega, 0.01);
    ekf_predict(model, cfg, ekf, dyn_model, omega, 0.01);
    ekf_update_imu_psi(model, cfg, ekf, wrap_angle(eta.z() + 0.1 + 0.02 * noise(rng)));
    ekf_update_imu_r(model, cfg, ekf, zeta.z() + 0.01 * noise(rng));
    if (k % 10 == 0)  // camera at 10 Hz
      ekf_update_pose(model, ekf, eta + Vec3(0.01 * noise(rng), 0.01 * noise(rng), 0.02 * noise(rng)), pose_cov);
    if (k > 200) worst = std::max(worst, (ekf.x.head<2>() - eta.head<2>()).norm());
  }
  CHECK(worst < 0.03);
  CHECK(std::fabs(wrap_angle(ekf.x[2] - eta.z())) < 0.03);
  CHECK((dr.eta.head<2>() - eta.head<2>()).norm() > 0.1);  // the model alone drifts
  CHECK(ekf.P.isApprox(ekf.P.transpose()));
}

TEST_CASE("EKF: a camera pose compared with the prediction for its capture time removes the latency lag") {
  // Truth drives 30 % faster along x than the model predicts, so the estimate leans on the
  // camera; the camera delivers each frame 0.1 s after capturing it. Fed as current, a frame
  // drags the estimate back by the distance covered during the latency.
  TerrainParams fast = kSand;
  fast.sigma_long *= 1.3;
  const Model truth = make_model(RobotParams{}, fast);
  const Model model = make_model(RobotParams{}, kSand);
  const Vec4 omega(-15, -15, 15, 15);  // straight ahead
  auto run = [&](bool timestamped) {
    DynamicsData dyn_truth(truth), dyn_model(model);
    Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
    EkfConfig cfg;
    Ekf ekf;
    ekf_reset(cfg, ekf, eta);
    PoseHistory history;
    struct Frame {
      double t_capture_s;
      Vec3 pose;
    };
    std::vector<Frame> in_flight;
    const Mat3 pose_cov = Vec3(0.003 * 0.003, 0.003 * 0.003, 0.005 * 0.005).asDiagonal();
    double err_sum = 0;
    int n = 0;
    for (int k = 1; k <= 1000; ++k) {
      const double t = 0.01 * k;
      dynamics_step(truth, dyn_truth, eta, zeta, omega, 0.01);
      ekf_predict(model, cfg, ekf, dyn_model, omega, 0.01);
      if (k % 5 == 0) in_flight.push_back({t, eta});  // 20 Hz capture
      while (!in_flight.empty() && in_flight.front().t_capture_s + 0.1 <= t + 1e-9) {
        const Frame f = in_flight.front();
        in_flight.erase(in_flight.begin());
        if (timestamped)
          REQUIRE(ekf_update_pose_delayed(model, ekf, history, f.pose, pose_cov, f.t_capture_s) == PoseUpdate::applied);
        else
          ekf_update_pose(model, ekf, f.pose, pose_cov);
      }
      history.push(t, ekf_h_pose(model, ekf.x, nullptr));
      if (t > 5.0) {
        err_sum += std::fabs(ekf.x[0] - eta.x());
        ++n;
      }
    }
    return err_sum / n;
  };
  const double lag_m = run(false), compensated_m = run(true);
  INFO("mean |x error| over the last 5 s: as current " << lag_m << " m, timestamped " << compensated_m << " m");
  CHECK(lag_m > 0.005);  // the truth covers ~10 mm in 0.1 s
  CHECK(compensated_m < 0.25 * lag_m);
}

TEST_CASE("PoseHistory interpolates the prediction, unwraps headings, and refuses times it does not keep") {
  PoseHistory h;
  Vec3 out;
  CHECK_FALSE(h.at(0.0, out));
  h.push(1.00, Vec3(0.0, 0.0, 3.10));
  h.push(1.01, Vec3(0.1, -0.2, -3.12));  // crossed +-pi
  CHECK(h.at(1.005, out));
  CHECK(out.x() == Approx(0.05));
  CHECK(out.y() == Approx(-0.1));
  CHECK(std::fabs(wrap_angle(out.z() - 3.13159)) < 1e-4);  // (3.10 + (2 pi - 3.12)) / 2: across pi, not through 0
  CHECK_FALSE(h.at(0.99, out));   // older than kept
  CHECK_FALSE(h.at(1.02, out));   // newer than the newest
  for (int k = 0; k < PoseHistory::kSize; ++k) h.push(2.0 + 0.01 * k, Vec3(double(k), 0, 0));
  CHECK_FALSE(h.at(1.005, out));  // pushed out of the ring
  CHECK(h.at(2.0, out));
  CHECK(out.x() == Approx(0.0));
  h.shift(Vec3(0.5, 0, 0));
  CHECK(h.at(2.0 + 0.01 * (PoseHistory::kSize - 1), out));
  CHECK(out.x() == Approx(PoseHistory::kSize - 1 + 0.5));
}
