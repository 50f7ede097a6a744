// Simulated IMU and camera: see sensors.hpp.
#include "sensors.hpp"

#include <cmath>

namespace auger::sim {

ImuReading Imu::read(double t_s, double psi_true_rad, double r_true_radps, const Eigen::Vector2d& f_true_mps2) {
  ImuReading o;
  o.t_s = t_s;
  o.psi_rad = wrap_angle(psi_true_rad + p_.psi_bias_rad + p_.psi_noise_rad * n01_(rng_));
  o.r_radps = r_true_radps + p_.r_bias_radps + p_.r_noise_radps * n01_(rng_);
  if (std::isfinite(last_t_s_) && t_s > last_t_s_) {
    const double walk = p_.acc_bias_walk_mps2_per_sqrt_s * std::sqrt(t_s - last_t_s_);
    for (int k = 0; k < 2; ++k) bias_acc_[k] += walk * n01_(rng_acc_);
  }
  last_t_s_ = t_s;
  o.ax_mps2 = f_true_mps2.x() + bias_acc_.x() + p_.acc_noise_mps2 * n01_(rng_acc_);
  o.ay_mps2 = f_true_mps2.y() + bias_acc_.y() + p_.acc_noise_mps2 * n01_(rng_acc_);
  return o;
}

SensorInput sensor_input(const ImuReading& imu, const PoseReading* pose) {
  SensorInput in;
  in.has_imu_psi = in.has_imu_r = in.has_imu_acc = true;
  in.imu_psi_rad = imu.psi_rad;
  in.imu_r_radps = imu.r_radps;
  in.imu_ax_mps2 = imu.ax_mps2;
  in.imu_ay_mps2 = imu.ay_mps2;
  if (pose) {
    in.has_pose = true;
    in.pose = pose->pose;
    in.pose_cov = pose->std_dev.cwiseProduct(pose->std_dev).asDiagonal();
    in.pose_t_s = pose->t_capture_s;  // the camera's latency: compared with the prediction then
  }
  return in;
}

void Camera::observe(double t_s, const Vec3& eta_true) {
  const double period = 1.0 / p_.rate_hz;
  while (next_capture_s_ <= t_s + 1e-12) {
    const double tc = next_capture_s_;
    next_capture_s_ += period;
    // First-order Gauss-Markov noise, exact discretisation over one frame:
    // n_k = a n_{k-1} + sqrt(1 - a^2) sigma w_k, a = exp(-T / tau): stationary std sigma.
    const double a = std::exp(-period / p_.noise_corr_s);
    for (int k = 0; k < 3; ++k) {
      const double w = n01_(rng_);
      colour_[k] = colour_init_ ? a * colour_[k] + std::sqrt(1 - a * a) * p_.noise_std[k] * w : p_.noise_std[k] * w;
    }
    colour_init_ = true;
    // Gilbert model: bursts of lost frames (occlusion), drawn every frame for reproducibility.
    const double x = u01_(rng_);
    dropping_ = dropping_ ? !(x < p_.p_drop_end) : (x < p_.p_drop_start);
    if (dropping_) continue;
    PoseReading r;
    r.t_capture_s = tc;
    r.t_deliver_s = tc + p_.latency_s;
    // The true pose is sampled at the call time; callers call at least every 10 ms, so the
    // capture instant is off by less than that (documented).
    r.pose = eta_true + colour_;
    r.pose[2] = wrap_angle(r.pose[2]);
    r.std_dev = p_.noise_std;
    queue_.push_back(r);
  }
  last_t_s_ = t_s;
}

bool Camera::deliver(double t_s, PoseReading& out) {
  if (queue_.empty() || queue_.front().t_deliver_s > t_s + 1e-12) return false;
  out = queue_.front();
  queue_.pop_front();
  return true;
}

}  // namespace auger::sim
