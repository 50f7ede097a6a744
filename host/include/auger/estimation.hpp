// Pose estimation from measured screw speeds:
// - dead reckoning with the dynamic model, eqs. (5)-(7) (the paper's model-only estimate);
// - the paper's variant that replaces the model heading by the IMU heading (Fig. 9, bottom);
// - an extended Kalman filter on [x, y, psi, u, v, r] fusing IMU heading, IMU yaw rate and any
//   external pose (the paper's proposed future work).
#pragma once

#include <array>

#include <Eigen/Core>

#include "auger/dynamics.hpp"
#include "auger/measured.hpp"
#include "auger/model.hpp"

namespace auger {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

// ---- dead reckoning ----
struct DeadReckoning {
  explicit DeadReckoning(const Model& model) : dyn(model) {}
  Vec3 eta = Vec3::Zero();
  Vec3 zeta = Vec3::Zero();
  DynamicsData dyn;
};

// Advances the estimate over dt_s with the measured speeds (eqs. (5)-(7)). If imu_psi_rad is
// measured (not NaN) it replaces the model heading, before and after the step (paper's variant).
void dead_reckoning_step(const Model& model, DeadReckoning& dr, const Vec4& omega_rpm, double dt_s,
                         double imu_psi_rad = kNotMeasured, int n_sub = 4);

// ---- EKF ----
struct EkfConfig {
  Vec3 accel_noise = Vec3(0.5, 0.5, 0.5);       // std of unmodelled body acceleration (m/s^2, rad/s^2)
  Vec3 pose_noise = Vec3(0.002, 0.002, 0.002);  // std per sqrt(s) of pose random walk (slip)
  double imu_psi_std_rad = 0.02;
  double imu_r_std_radps = 0.01;
  Vec6 initial_std = (Vec6() << 0.05, 0.05, 0.05, 0.05, 0.05, 0.05).finished();
  // The gate on a pose's innovation nu (docs/daemon.md "Safety"): a pose whose squared
  // Mahalanobis distance nu' S^-1 nu (S = H P H' + R) exceeds this is rejected, not applied.
  // 30.66 is the chi-square quantile with 3 degrees of freedom whose tail is 1e-6: a pose that
  // agrees with the estimate is refused about once in a million. 0: no gate.
  double pose_gate_d2 = 30.66;
  // A fault only on sustained disagreement: every pose for this long rejected, and at least
  // this many of them (the controller's fault, docs/daemon.md "Safety").
  double pose_reject_fault_s = 1.0;
  int pose_reject_fault_n = 3;
};

struct Ekf {
  Vec6 x = Vec6::Zero();  // x_m, y_m, psi_rad, u, v, r
  Mat6 P = Mat6::Identity();
  // workspace
  Mat6 F;
  Vec3 tau_n;
};

void ekf_reset(const EkfConfig& cfg, Ekf& ekf, const Vec3& eta);

// Discrete process model: exact linear step of eq. (6) for the velocities (drive effects
// included, held over dt) and eq. (5) with the exact body displacement rotated by the mid-step
// heading. Returns x_next; F (if given) receives d x_next / d x.
Vec6 ekf_process(const Model& model, const Vec6& x, const Vec3& tau_n, double dt_s, Mat6* F);

void ekf_predict(const Model& model, const EkfConfig& cfg, Ekf& ekf, DynamicsData& dyn,
                 const Vec4& omega_rpm, double dt_s);

// Measurement models h(x) (with the model's sensor effects) and their Jacobians.
double ekf_h_imu_psi(const Model& model, const Vec6& x, Eigen::Matrix<double, 1, 6>* H);
double ekf_h_imu_r(const Model& model, const Vec6& x, Eigen::Matrix<double, 1, 6>* H);
Vec3 ekf_h_pose(const Model& model, const Vec6& x, Eigen::Matrix<double, 3, 6>* H);

void ekf_update_imu_psi(const Model& model, const EkfConfig& cfg, Ekf& ekf, double imu_psi_rad);
void ekf_update_imu_r(const Model& model, const EkfConfig& cfg, Ekf& ekf, double imu_r_radps);
void ekf_update_pose(const Model& model, Ekf& ekf, const Vec3& pose, const Mat3& covariance);

// What the filter predicted the pose sensor would read over the last kSize steps (2.56 s at
// 100 Hz: augerd accepts sensor messages up to 2 s old). A camera delivers a frame tens of ms
// after it captured it; comparing that frame with the prediction for *now* reads the robot's
// motion during the latency as an error and drags the estimate back (at 0.1 m/s and 30 ms:
// 3 mm, as large as the camera's noise). Fixed size: no allocation in the 100 Hz step.
struct PoseHistory {
  static constexpr int kSize = 256;
  std::array<double, kSize> t_s{};
  std::array<Vec3, kSize> h{};
  int next = 0, count = 0;

  void clear() { next = count = 0; }
  void push(double t, const Vec3& h_pose);
  // The prediction at time t, interpolated (headings unwrapped); false when t lies outside
  // what is kept (older than the oldest entry, or newer than the newest by more than 1 ms).
  bool at(double t, Vec3& h_pose) const;
  // A correction of the estimate applies to the kept past too, so that the next delayed frame
  // does not count it a second time.
  void shift(const Vec3& delta);
};

// A pose captured at t_capture_s: the innovation against the prediction for its capture time,
// applied to the current state with the current gain (the usual latency compensation when the
// latency is short against the dynamics' error growth). stale (nothing changed) when the
// capture time lies outside the history; rejected (nothing changed) when gate_d2 > 0 and the
// innovation's squared Mahalanobis distance, written to *d2, exceeds it.
enum class PoseUpdate { applied, stale, rejected };
PoseUpdate ekf_update_pose_delayed(const Model& model, Ekf& ekf, PoseHistory& history, const Vec3& pose,
                                   const Mat3& covariance, double t_capture_s, double gate_d2 = 0,
                                   double* d2 = nullptr);

}  // namespace auger
