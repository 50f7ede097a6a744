// The controller as one step function with an injected clock (docs/design.md "Time"):
// step(t_s, telemetry[4], sensors) -> setpoints[4] (rpm). augerd calls it from its 100 Hz loop,
// the simulator's scheduler in lock-step simulated time. The Model is const and shared; all
// working memory is allocated at construction, so a step never touches the heap.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "auger/allocation.hpp"
#include "auger/dynamics.hpp"
#include "auger/estimation.hpp"
#include "auger/tracking_pid.hpp"
#include "auger/trajectory.hpp"

namespace auger {

enum class EstimatorKind { dead_reckoning, dead_reckoning_imu, ekf };

struct ControllerConfig {
  PidGains gains = table5_gains("sand");
  Vec3 gamma_per_s = default_gamma_per_s();
  AllocatorConfig allocator;
  EstimatorKind estimator = EstimatorKind::ekf;
  EkfConfig ekf;
  int dynamics_substeps = 4;
  double max_dt_s = 0.1;  // a longer gap (a stalled loop) is integrated as this much
  // Feedforward of the model's effect forces: eq. (6) is M zeta_dot + D zeta = S B omega +
  // tau_effects, so for the PID's force (eq. (21)) to act the screws are asked for tau_PID minus
  // the force the model's effects make (Effect::feedforward_force: slope, quadratic drag, the
  // rigid body's coupling; not dry friction), at the estimated pose and the reference's body
  // velocity, each DOF within the drive's reach, before eq. (22). Off: the PID's force alone.
  bool effect_feedforward = false;
};

// One module's telemetry for this cycle.
struct ScrewTelemetry {
  double omega_rpm = 0;
  bool valid = false;  // false: no fresh frame, the last setpoint stands in for the speed
};

// Sensor messages that arrived since the last step (absent = not measured).
struct SensorInput {
  bool has_pose = false;
  Vec3 pose = Vec3::Zero();  // external tracking (camera), world frame
  Mat3 pose_cov = Mat3::Identity() * 1e-4;
  // When the pose was captured, on the step's clock (NaN: treat it as current). The EKF
  // compares it with its prediction for that time (PoseHistory).
  double pose_t_s = kNotMeasured;
  bool has_imu_psi = false;
  double imu_psi_rad = 0;
  bool has_imu_r = false;
  double imu_r_radps = 0;
  // The IMU's specific force in the body frame (x forward, y left; m/s^2): the body's
  // acceleration minus gravity's, a_x = u' - r v, a_y = v' + r u by eq. (1) (docs/model-notes.md).
  // Only KinematicVelocity reads it (the controller's EKF does not).
  bool has_imu_acc = false;
  double imu_ax_mps2 = 0, imu_ay_mps2 = 0;
};

class Controller {
 public:
  // The model is referenced, not copied: it must outlive the controller.
  Controller(const Model& model, const ControllerConfig& config);

  // Not for the 100 Hz path (these may allocate): load a trajectory, (re)start.
  void set_waypoints(std::vector<Waypoint> waypoints);  // times relative to the first enabled step
  void reset(const Vec3& eta);                          // estimate at eta, at rest, disabled
  void set_enabled(bool enabled);                       // disabled: setpoints 0, reference holds

  // One control cycle at time t_s (seconds, any epoch, increasing).
  const std::array<double, 4>& step(double t_s, const std::array<ScrewTelemetry, 4>& telemetry,
                                    const SensorInput& sensors);

  const Vec3& eta_estimate() const { return eta_; }
  const Vec3& zeta_estimate() const { return zeta_; }
  // The EKF's covariance over [x, y, psi, u, v, r] (augerd's ROS 2 Odometry); null with the
  // dead-reckoning estimators, which keep none.
  const Mat6* estimate_covariance() const { return config_.estimator == EstimatorKind::ekf ? &ekf_.P : nullptr; }
  const ReferenceState& reference() const { return ref_; }
  const AllocationResult& allocation() const { return alloc_; }
  // This step's PID terms (eqs. (19)-(21)) and the effects' force fed forward (zero when off).
  const PidTerms& pid_terms() const { return pid_terms_; }
  const Vec3& effect_feedforward_n() const { return feedforward_n_; }
  const ControllerConfig& config() const { return config_; }
  // Timestamped poses the EKF could not use: captured before the kept history (2.56 s) or
  // after the step they arrived in.
  long stale_poses() const { return stale_poses_; }
  // Poses the EKF's gate refused (EkfConfig::pose_gate_d2), since construction, and whether
  // this step's pose was one of them (augerd's status and log).
  long rejected_poses() const { return rejected_poses_; }
  bool pose_rejected() const { return pose_rejected_; }
  // This step's pose: its innovation's Mahalanobis distance (NaN without a pose, or before the
  // estimator's first pose, which is taken as it is).
  double pose_distance() const { return pose_distance_; }
  bool enabled() const { return enabled_; }

  // A step whose estimate is not finite or leaves the bounds of input_limits.hpp (the EKF has
  // diverged), or whose setpoints are not finite, latches a fault: the estimator restarts at the
  // last good estimate (at rest, with its initial uncertainty, so the next camera pose corrects
  // it), the controller disables itself and commands 0 until clear_fault(). "" when none.
  const std::string& fault() const { return fault_; }
  void clear_fault() { fault_.clear(); }

 private:
  void restart_estimator(const Vec3& eta);
  void latch_fault(const std::string& what);
  void pose_update(double t_s, const SensorInput& sensors);
  bool feed_forward();  // tau_command_n_ -= the effects' force; false: a fault latched

  const Model& model_;
  ControllerConfig config_;
  DeadReckoning dr_;
  Ekf ekf_;
  PoseHistory pose_history_;
  long stale_poses_ = 0;
  long rejected_poses_ = 0;
  bool pose_rejected_ = false;
  double pose_distance_ = 0;
  // The gate applies once the estimator has taken a pose since its (re)start: until then its
  // position is a guess, and the first pose is how it learns where the robot is.
  bool pose_taken_ = false;
  int reject_run_n_ = 0;        // poses rejected in a row
  double reject_run_t0_s_ = 0;  // when that run began
  double pose_delay_s_ = 0;  // the model's pose_time_offset effect: poses show the robot this much earlier
  ReferenceState ref_;
  PidState pid_;
  PidTerms pid_terms_{};
  Vec3 feedforward_n_ = Vec3::Zero();
  Vec3 tau_command_n_ = Vec3::Zero();  // what the allocation is asked for
  AllocationResult alloc_;
  std::vector<Waypoint> waypoints_;
  int waypoint_ = -1;
  double t_prev_s_ = 0;
  double t_start_s_ = 0;
  bool started_ = false;  // a first step has set the clock
  bool trajectory_running_ = false;
  bool enabled_ = false;
  Vec3 eta_ = Vec3::Zero(), zeta_ = Vec3::Zero();
  Vec3 last_good_eta_ = Vec3::Zero();
  std::string fault_;
  Vec4 omega_meas_rpm_ = Vec4::Zero();
  std::array<double, 4> setpoints_rpm_{};
};

}  // namespace auger
