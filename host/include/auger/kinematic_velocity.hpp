// A body velocity that owes nothing to the terrain model, for the online estimator
// (docs/daemon.md "Online identification"): the controller's EKF predicts with eqs. (6)-(7) of
// the configured terrain, so its velocity leans to that terrain and an estimator fed with it
// finds the configured terrain again. This filter knows only kinematics: per world axis a
// constant-acceleration Kalman filter (position, velocity, acceleration; white jerk) on the
// camera's positions, and for the heading a constant-rate filter (heading, rate; white angular
// acceleration) on the IMU's rate and heading and the camera's heading. The body velocity is the
// world velocity turned by the heading (eq. (1)).
//
// With an accelerometer (SensorInput::has_imu_acc) a second filter carries the velocity: per
// cycle the measured specific force, less an estimated body-frame bias and turned into the world
// frame by the heading, is integrated into the world velocity and position (the accelerometer as
// the process model's input, as an inertial navigator does), and the camera's positions correct
// the position, the velocity, the two biases and gravity's pull (below). Chosen over the accelerometer as a measurement
// of the constant-acceleration filter's acceleration: that keeps the white-jerk model, whose
// bandwidth must be wide for the acceleration to follow the screws' steps and then lets the
// camera's coloured noise through again; as the input, the velocity between camera fixes is the
// integral of the measured acceleration, whose error grows only as the accelerometer's noise
// (1.5e-3 m/s^2 per sqrt(Hz): 0.5 mm/s over 0.1 s) and its bias, which the camera pins down
// over seconds: the camera carries the slow drift, the accelerometer the 0.05-1 s band. Gravity's
// pull along a sloping ground is a state of its own, constant in the world frame (the bias is
// the body's). Without an accelerometer sample for more than 0.05 s the constant-acceleration
// filter's velocity is returned, and the inertial filter restarts from it when samples come
// again; a filter never fed an accelerometer returns bit for bit what it did before it had one.
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
  // The accelerometer (docs/daemon.md "A velocity without the model"): used when the IMU gives
  // it and `use_accelerometer`. Its white noise density, the random walk of its bias, and the
  // SD of the bias before any camera fix.
  bool use_accelerometer = true;
  double acc_noise_mps2_per_sqrt_hz = 1.5e-3;
  double acc_bias_walk_mps2_per_sqrt_s = 5e-4;
  double acc_bias_sd_mps2 = 0.1;
  // Gravity's part along the ground (world frame; 0.98 m/s^2 on a 0.1 rad slope): its SD before
  // the camera has seen it and its random walk (a plane's slope: 1e-4; ground whose slope varies
  // along the course needs more, at a cost on flat ground: on the firmware-in-the-loop logs
  // 5e-4 and 2e-3 raised the velocity's error from 2.7 to 2.9 and 3.9 mm/s). Told from the
  // bias only when the robot turns.
  double acc_gravity_sd_mps2 = 1.0;
  double acc_gravity_walk_mps2_per_sqrt_s = 0.0001;
  // With the accelerometer the velocity stays known this long without a camera pose (its error
  // grows as the bias's error times the time, not as an extrapolated acceleration's).
  double max_pose_age_acc_s = 0.5;
  // The camera's noise as first-order Gauss-Markov with this correlation time (0: white, as
  // before), of the variance each pose reports: the accelerometer's filter then takes a run of
  // frames that err alike as one error, not as many independent fixes (0.3 s for the simulated
  // camera, docs/robot-sim.md "Sensors").
  double pose_noise_corr_s = 0;
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
  // Whether the last step's velocity came from the accelerometer's filter.
  bool inertial() const { return ins_on_; }
  // The accelerometer's estimated bias in the body frame (m/s^2; x, y).
  Eigen::Vector2d accelerometer_bias() const { return si_.segment<2>(4); }
  // Gravity's estimated acceleration along the ground in the world frame (m/s^2; x, y).
  Eigen::Vector2d gravity_along_ground() const { return si_.segment<2>(8); }
  // SD of the body velocity (from the filter's covariance; u and v share the larger world SD).
  Vec3 body_velocity_sd() const;

 private:
  using Vec3k = Eigen::Matrix<double, 3, 1>;
  using Mat3k = Eigen::Matrix<double, 3, 3>;
  using VecNk = Eigen::Matrix<double, 10, 1>;
  using MatNk = Eigen::Matrix<double, 10, 10>;
  void predict_axis(Vec3k& s, Mat3k& P, double dt_s) const;
  // The accelerometer's filter: start from the constant-acceleration filters' state, one cycle.
  void start_inertial();
  void step_inertial(const SensorInput& sensors, bool pose_ok, double dt_s);
  bool coloured() const { return cfg_.pose_noise_corr_s > 0; }
  KinematicVelocityConfig cfg_;
  Vec3k sx_, sy_;            // position, velocity, acceleration along world x and y
  Mat3k Px_, Py_;
  Eigen::Vector2d sp_;       // heading, rate
  Eigen::Matrix2d Pp_;
  // The accelerometer's filter: world position x, velocity x, position y, velocity y, the
  // body-frame bias x, y, the camera's coloured error x, y (zero and unused while
  // pose_noise_corr_s is 0), gravity's acceleration along the ground in the world frame x, y.
  VecNk si_ = VecNk::Zero();
  MatNk Pi_ = MatNk::Zero();
  Eigen::Vector2d pose_var_ = Eigen::Vector2d::Zero();  // the last pose's variances x, y (m^2)
  bool ins_on_ = false;
  double acc_age_s_ = 0;
  Eigen::Vector2d last_acc_ = Eigen::Vector2d::Zero();  // the last specific force measured (body)
  bool have_pose_ = false;
  double pose_age_s_ = 0;
  Vec3 zeta_;
};

}  // namespace auger
