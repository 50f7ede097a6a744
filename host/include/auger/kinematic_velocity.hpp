// A body velocity that owes nothing to the terrain model, for the online estimator
// (docs/daemon.md "Online identification"): the controller's EKF predicts with eqs. (6)-(7) of
// the configured terrain, so its velocity leans to that terrain and an estimator fed with it
// finds the configured terrain again. This filter knows only kinematics: per world axis a
// constant-acceleration Kalman filter (position, velocity, acceleration; white jerk) on the
// camera's positions, and for the heading a constant-rate filter (heading, rate; white angular
// acceleration) on the IMU's rate and heading and the camera's heading. The body velocity is the
// world velocity turned by the heading (eq. (1)).
//
// Fixed-size Eigen types only: no allocation after construction.
#pragma once

#include <Eigen/Core>

#include "auger/controller.hpp"

namespace auger {

struct KinematicVelocityConfig {
  double jerk_sd = 0.03;       // white jerk, m/s^3 per sqrt(Hz): how fast the acceleration may change
  double yaw_accel_sd = 2.0;   // white angular acceleration, rad/s^2 per sqrt(Hz)
  double imu_r_sd = 0.005;     // the IMU's rate noise, rad/s
  double imu_psi_sd = 0.005;   // the IMU's heading noise, rad
  // Without a camera pose for longer than this the velocity is unknown (NaN): the filter would
  // extrapolate its acceleration, and on the firmware-in-the-loop chain a 0.9 s camera dropout
  // ran u 0.034 m/s off (docs/daemon.md "A velocity without the model").
  double max_pose_age_s = 0.12;
};

class KinematicVelocity {
 public:
  explicit KinematicVelocity(const KinematicVelocityConfig& config = {});
  // At rest at eta (x, y, psi).
  void reset(const Vec3& eta);
  // One cycle of dt_s with this cycle's sensors (SensorInput as the controller gets them: the
  // camera's pose and its covariance, the IMU's heading and rate). Returns the body velocity
  // (u, v in m/s, r in rad/s); NaN until the first camera pose and while the last one is older
  // than max_pose_age_s.
  const Vec3& step(const SensorInput& sensors, double dt_s);
  const Vec3& body_velocity() const { return zeta_; }
  // SD of the body velocity (from the filter's covariance; u and v share the larger world SD).
  Vec3 body_velocity_sd() const;

 private:
  using Vec3k = Eigen::Matrix<double, 3, 1>;
  using Mat3k = Eigen::Matrix<double, 3, 3>;
  void predict_axis(Vec3k& s, Mat3k& P, double dt_s) const;
  KinematicVelocityConfig cfg_;
  Vec3k sx_, sy_;            // position, velocity, acceleration along world x and y
  Mat3k Px_, Py_;
  Eigen::Vector2d sp_;       // heading, rate
  Eigen::Matrix2d Pp_;
  bool have_pose_ = false;
  double pose_age_s_ = 0;
  Vec3 zeta_;
};

}  // namespace auger
