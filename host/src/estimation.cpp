// Pose estimation: dead reckoning (eqs. (5)-(7)), IMU heading variant, EKF.
#include "auger/estimation.hpp"

#include <cmath>

#include <Eigen/LU>

#include "auger/effect.hpp"

namespace auger {

void dead_reckoning_step(const Model& model, DeadReckoning& dr, const Vec4& omega_rpm, double dt_s,
                         double imu_psi_rad, int n_sub) {
  const bool imu = measured(imu_psi_rad);
  dynamics_step(model, dr.dyn, dr.eta, dr.zeta, omega_rpm, dt_s, n_sub);
  // Paper's variant (Fig. 9): the IMU orientation replaces the model's.
  if (imu) dr.eta.z() = wrap_angle(imu_psi_rad);
}

void ekf_reset(const EkfConfig& cfg, Ekf& ekf, const Vec3& eta) {
  ekf.x.setZero();
  ekf.x.head<3>() = eta;
  ekf.P = cfg.initial_std.cwiseAbs2().asDiagonal();
}

namespace {
// Exact displacement of eq. (6) per DOF: disp = a v0 + b f (both closed form).
void displacement_coeffs(double m, double d, double dt, double& a, double& b) {
  if (d <= 0) {
    a = dt;
    b = 0.5 * dt * dt / m;
    return;
  }
  const double T = m / d;
  const double q = T * (1.0 - std::exp(-dt / T));
  a = q;
  b = (dt - q) / d;
}
}  // namespace

Vec6 ekf_process(const Model& model, const Vec6& x, const Vec3& tau, double dt, Mat6* F) {
  Vec6 xn;
  Vec3 disp, a;
  for (int k = 0; k < 3; ++k) {
    double gain = 0, b = 0;
    xn[3 + k] = first_order_step(model.M_diag[k], model.D_diag[k], x[3 + k], tau[k], dt, &gain);  // eq. (6)
    displacement_coeffs(model.M_diag[k], model.D_diag[k], dt, a[k], b);
    disp[k] = a[k] * x[3 + k] + b * tau[k];
  }
  // eq. (5): body displacement rotated by the heading at mid-step.
  const double psi_m = x[2] + 0.5 * disp[2];
  const double c = std::cos(psi_m), s = std::sin(psi_m);
  xn[0] = x[0] + c * disp[0] - s * disp[1];
  xn[1] = x[1] + s * disp[0] + c * disp[1];
  xn[2] = x[2] + disp[2];
  if (F) {
    Mat6& J = *F;
    J.setZero();
    const double dx_dpsi = -s * disp[0] - c * disp[1];
    const double dy_dpsi = c * disp[0] - s * disp[1];
    J(0, 0) = 1;
    J(0, 2) = dx_dpsi;
    J(0, 3) = c * a[0];
    J(0, 4) = -s * a[1];
    J(0, 5) = dx_dpsi * 0.5 * a[2];
    J(1, 1) = 1;
    J(1, 2) = dy_dpsi;
    J(1, 3) = s * a[0];
    J(1, 4) = c * a[1];
    J(1, 5) = dy_dpsi * 0.5 * a[2];
    J(2, 2) = 1;
    J(2, 5) = a[2];
    for (int k = 0; k < 3; ++k) {
      double gain;
      J(3 + k, 3 + k) = first_order_step(model.M_diag[k], model.D_diag[k], 1.0, 0.0, dt, &gain);
    }
  }
  return xn;
}

void ekf_predict(const Model& model, const EkfConfig& cfg, Ekf& ekf, DynamicsData& dyn,
                 const Vec4& omega_rpm, double dt) {
  if (!(dt > 0)) return;
  drive_force(model, dyn, omega_rpm, dt, ekf.tau_n);  // eq. (7) with the drive effects
  // eq. (6)'s body forces of the model's effects (dry friction, a slope, ...) for the estimated
  // state, held over the step. F treats them as constant: their derivative is a Coulomb
  // friction's jump at rest, which the process noise covers.
  dyn.tau_drive_n = ekf.tau_n;
  effect_body_force(model, dyn, dyn.t_s, ekf.x.head<3>(), ekf.x.tail<3>(), omega_rpm, dt);
  dyn.t_s += dt;  // time-dependent effects (a change of terrain) count from the filter's start
  ekf.tau_n += dyn.tau_effect_n;
  ekf.x = ekf_process(model, ekf.x, ekf.tau_n, dt, &ekf.F);
  ekf.x[2] = wrap_angle(ekf.x[2]);
  Vec6 q;
  q.head<3>() = cfg.pose_noise.cwiseAbs2() * dt;
  q.tail<3>() = cfg.accel_noise.cwiseAbs2() * dt;
  ekf.P = ekf.F * ekf.P * ekf.F.transpose();
  ekf.P.diagonal() += q;
}

namespace {
// What the sensors read for state x, now (SensorValues::live: a jump a model was fitted with, at a
// time of its log, is past).
SensorValues predicted_now(const Model& model, const Vec6& x) {
  SensorValues v;
  v.live = true;
  predict_sensors(model, x.head<3>(), x.tail<3>(), v);
  return v;
}
}  // namespace

double ekf_h_imu_psi(const Model& model, const Vec6& x, Eigen::Matrix<double, 1, 6>* H) {
  const SensorValues v = predicted_now(model, x);
  if (H) H->setZero(), (*H)(0, 2) = 1;
  return v.imu_psi_rad;
}

double ekf_h_imu_r(const Model& model, const Vec6& x, Eigen::Matrix<double, 1, 6>* H) {
  const SensorValues v = predicted_now(model, x);
  if (H) H->setZero(), (*H)(0, 5) = 1;
  return v.imu_r_radps;
}

Vec3 ekf_h_pose(const Model& model, const Vec6& x, Eigen::Matrix<double, 3, 6>* H) {
  const SensorValues v = predicted_now(model, x);
  if (H) H->setZero(), H->leftCols<3>().setIdentity();
  return v.pose;
}

namespace {
// Joseph-form update (keeps P symmetric positive semi-definite); fixed sizes, no heap.
template <int N>
void ekf_update(Ekf& ekf, const Eigen::Matrix<double, N, 1>& innovation,
                const Eigen::Matrix<double, N, 6>& H, const Eigen::Matrix<double, N, N>& R) {
  const Eigen::Matrix<double, N, N> S = H * ekf.P * H.transpose() + R;
  const Eigen::Matrix<double, 6, N> K = ekf.P * H.transpose() * S.inverse();
  ekf.x += K * innovation;
  ekf.x[2] = wrap_angle(ekf.x[2]);
  const Mat6 IKH = Mat6::Identity() - K * H;
  ekf.P = IKH * ekf.P * IKH.transpose() + K * R * K.transpose();
}
}  // namespace

void ekf_update_imu_psi(const Model& model, const EkfConfig& cfg, Ekf& ekf, double z) {
  Eigen::Matrix<double, 1, 6> H;
  const double h = ekf_h_imu_psi(model, ekf.x, &H);
  Eigen::Matrix<double, 1, 1> nu(wrap_angle(z - h)), R(cfg.imu_psi_std_rad * cfg.imu_psi_std_rad);
  ekf_update<1>(ekf, nu, H, R);
}

void ekf_update_imu_r(const Model& model, const EkfConfig& cfg, Ekf& ekf, double z) {
  Eigen::Matrix<double, 1, 6> H;
  const double h = ekf_h_imu_r(model, ekf.x, &H);
  Eigen::Matrix<double, 1, 1> nu(z - h), R(cfg.imu_r_std_radps * cfg.imu_r_std_radps);
  ekf_update<1>(ekf, nu, H, R);
}

void ekf_update_pose(const Model& model, Ekf& ekf, const Vec3& pose, const Mat3& covariance) {
  Eigen::Matrix<double, 3, 6> H;
  Vec3 nu = pose - ekf_h_pose(model, ekf.x, &H);
  nu.z() = wrap_angle(nu.z());
  ekf_update<3>(ekf, nu, H, covariance);
}

void PoseHistory::push(double t, const Vec3& h_pose) {
  t_s[std::size_t(next)] = t;
  h[std::size_t(next)] = h_pose;
  next = (next + 1) % kSize;
  count = std::min(count + 1, kSize);
}

bool PoseHistory::at(double t, Vec3& h_pose) const {
  if (count == 0) return false;
  auto idx = [&](int age) { return std::size_t((next - 1 - age + 2 * kSize) % kSize); };  // age 0: newest
  const double newest_s = t_s[idx(0)], oldest_s = t_s[idx(count - 1)];
  if (t < oldest_s || t > newest_s + 1e-3) return false;
  if (t >= newest_s) {
    h_pose = h[idx(0)];
    return true;
  }
  // Newest to oldest: the first entry at or before t and the one after it.
  for (int age = 1; age < count; ++age) {
    const std::size_t a = idx(age), b = idx(age - 1);
    if (t_s[a] > t) continue;
    const double span_s = t_s[b] - t_s[a];
    const double w = span_s > 0 ? (t - t_s[a]) / span_s : 0.0;
    h_pose.head<2>() = h[a].head<2>() + w * (h[b].head<2>() - h[a].head<2>());
    h_pose.z() = wrap_angle(h[a].z() + w * wrap_angle(h[b].z() - h[a].z()));
    return true;
  }
  h_pose = h[idx(count - 1)];
  return true;
}

void PoseHistory::shift(const Vec3& delta) {
  for (int i = 0; i < count; ++i) {
    h[std::size_t(i)] += delta;
    h[std::size_t(i)].z() = wrap_angle(h[std::size_t(i)].z());
  }
}

PoseUpdate ekf_update_pose_delayed(const Model& model, Ekf& ekf, PoseHistory& history, const Vec3& pose,
                                   const Mat3& covariance, double t_capture_s, double gate_d2, double* d2) {
  Vec3 h_then;
  if (!history.at(t_capture_s, h_then)) return PoseUpdate::stale;
  Eigen::Matrix<double, 3, 6> H;
  ekf_h_pose(model, ekf.x, &H);
  Vec3 nu = pose - h_then;
  nu.z() = wrap_angle(nu.z());
  // The innovation's squared Mahalanobis distance (NaN with a non-finite covariance: applied,
  // and the controller's state check catches what follows).
  const Mat3 S = H * ekf.P * H.transpose() + covariance;
  const double m2 = nu.dot(S.inverse() * nu);
  if (d2) *d2 = m2;
  if (gate_d2 > 0 && m2 > gate_d2) return PoseUpdate::rejected;
  const Vec3 before = ekf.x.head<3>();
  ekf_update<3>(ekf, nu, H, covariance);
  Vec3 delta = ekf.x.head<3>() - before;
  delta.z() = wrap_angle(delta.z());
  history.shift(delta);
  return PoseUpdate::applied;
}

}  // namespace auger
