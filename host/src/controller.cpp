// Controller step: estimation, reference eq. (18), PID eqs. (19)-(21), the effects' feedforward
// (eq. (6), when configured), allocation eq. (22).
#include "auger/controller.hpp"

#include "auger/input_limits.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace auger {

Controller::Controller(const Model& model, const ControllerConfig& config)
    : model_(model), config_(config), dr_(model) {
  // A model fitted with pose_time_offset (auger fit) says by how much the poses lag the screw
  // speeds: the EKF then takes each pose as of that much earlier.
  pose_delay_s_ = pose_delay_s(model_);
  reset(Vec3::Zero());
}

void Controller::restart_estimator(const Vec3& eta) {
  dr_.eta = eta;
  dr_.zeta.setZero();
  dr_.dyn.reset(model_);
  ekf_reset(config_.ekf, ekf_, eta);
  pose_history_.clear();
  pose_taken_ = false;
  pose_distance_ = NAN;
  reject_run_n_ = 0;
  eta_ = eta;
  zeta_.setZero();
  last_good_eta_ = eta;
}

void Controller::latch_fault(const std::string& what) {
  if (fault_.empty()) fault_ = what;
  enabled_ = false;
  trajectory_running_ = false;
}

void Controller::reset(const Vec3& eta) {
  restart_estimator(eta);
  fault_.clear();
  reference_reset(ref_, eta);
  pid_ = PidState{};
  started_ = false;
  trajectory_running_ = false;
  enabled_ = false;
  waypoint_ = -1;
  setpoints_rpm_.fill(0.0);
  omega_meas_rpm_.setZero();
}

void Controller::set_waypoints(std::vector<Waypoint> waypoints) {
  check_waypoints(waypoints);
  waypoints_ = std::move(waypoints);
  waypoint_ = -1;
  trajectory_running_ = false;
}

void Controller::set_enabled(bool enabled) {
  if (enabled && !enabled_) {
    // Start tracking from where the robot is, at rest: no jump in the reference.
    reference_reset(ref_, eta_);
    pid_ = PidState{};
    trajectory_running_ = false;
  }
  enabled_ = enabled;
}

// A pose through the EKF's gate: one wild pose is rejected and counted; poses that all disagree
// for pose_reject_fault_s latch a fault (a camera that is wrong, or a robot carried away): the
// estimator then restarts at its estimate and takes the next pose as it comes.
void Controller::pose_update(double t_s, const SensorInput& sensors) {
  const EkfConfig& e = config_.ekf;
  double d2 = NAN;
  const double t_capture_s = (std::isnan(sensors.pose_t_s) ? t_s : sensors.pose_t_s) - pose_delay_s_;
  const PoseUpdate u = ekf_update_pose_delayed(model_, ekf_, pose_history_, sensors.pose, sensors.pose_cov,
                                               t_capture_s, pose_taken_ ? e.pose_gate_d2 : 0.0, &d2);
  pose_distance_ = pose_taken_ ? std::sqrt(d2) : NAN;
  switch (u) {
    case PoseUpdate::stale:
      ++stale_poses_;
      return;
    case PoseUpdate::applied:
      pose_taken_ = true;
      reject_run_n_ = 0;
      return;
    case PoseUpdate::rejected:
      break;
  }
  ++rejected_poses_;
  pose_rejected_ = true;
  if (reject_run_n_++ == 0) reject_run_t0_s_ = t_s;
  const double run_s = t_s - reject_run_t0_s_;
  if (reject_run_n_ < e.pose_reject_fault_n || run_s < e.pose_reject_fault_s) return;
  char what[200];
  std::snprintf(what, sizeof what,
                "camera poses disagree with the estimate: %d poses in %.2f s beyond the gate (the last at "
                "Mahalanobis distance %.3g, gate %.3g)",
                reject_run_n_, run_s, std::sqrt(d2), std::sqrt(e.pose_gate_d2));
  latch_fault(what);
  restart_estimator(ekf_.x.head<3>());
}

// eq. (6): the screws must give tau_PID - tau_effects for the PID's force to act. The effects'
// force is taken at the estimated pose (a slope's pull turns with the heading) and at the
// velocity the reference asks for, not the estimated one: a drag fed forward at the estimated
// velocity is a positive velocity feedback (negative damping 2 c |v|, more than D_x at the
// physical range's top) that also carries the estimate's noise. Each DOF is clamped to what the
// four screws can push at omega_max_rpm (more is not deliverable and would only crowd out the
// PID's share in the allocator's scaling); a non-finite force latches a fault.
bool Controller::feed_forward() {
  const Vec3 zeta_ref = rotation_J(eta_.z()).transpose() * ref_.eta_d_dot;
  const Effect* bad = effect_feedforward_force(model_, eta_, zeta_ref, feedforward_n_);
  if (bad || !feedforward_n_.allFinite()) {
    latch_fault("non-finite effect force for the feedforward (eq. (6))" +
                (bad ? ": effect " + bad->id() : std::string()));
    feedforward_n_.setZero();
    return false;
  }
  for (int k = 0; k < 3; ++k) {
    const double reach_n = config_.allocator.omega_max_rpm * model_.SB.row(k).cwiseAbs().sum();
    feedforward_n_[k] = std::clamp(feedforward_n_[k], -reach_n, reach_n);
  }
  tau_command_n_ -= feedforward_n_;
  return true;
}

const std::array<double, 4>& Controller::step(double t_s, const std::array<ScrewTelemetry, 4>& tel,
                                              const SensorInput& sensors) {
  double dt = started_ ? t_s - t_prev_s_ : 0.0;
  if (!(dt > 0)) dt = 0.0;  // a repeated or backward time step predicts nothing
  dt = std::min(dt, config_.max_dt_s);
  if (started_ && !(t_s > t_prev_s_)) t_s = t_prev_s_;
  t_prev_s_ = t_s;
  started_ = true;

  for (int i = 0; i < 4; ++i)
    omega_meas_rpm_[i] = tel[static_cast<std::size_t>(i)].valid ? tel[static_cast<std::size_t>(i)].omega_rpm
                                                                 : setpoints_rpm_[static_cast<std::size_t>(i)];

  // Estimation from the screw speeds measured over the past cycle.
  switch (config_.estimator) {
    case EstimatorKind::dead_reckoning:
    case EstimatorKind::dead_reckoning_imu: {
      const bool imu = config_.estimator == EstimatorKind::dead_reckoning_imu && sensors.has_imu_psi;
      dead_reckoning_step(model_, dr_, omega_meas_rpm_, dt, imu ? sensors.imu_psi_rad : kNotMeasured,
                          config_.dynamics_substeps);
      if (sensors.has_pose) dr_.eta = sensors.pose;  // an external fix resets the drift
      eta_ = dr_.eta;
      zeta_ = dr_.zeta;
      break;
    }
    case EstimatorKind::ekf:
      ekf_predict(model_, config_.ekf, ekf_, dr_.dyn, omega_meas_rpm_, dt);
      if (sensors.has_imu_psi) ekf_update_imu_psi(model_, config_.ekf, ekf_, sensors.imu_psi_rad);
      if (sensors.has_imu_r) ekf_update_imu_r(model_, config_.ekf, ekf_, sensors.imu_r_radps);
      // The prediction for now joins the history before a pose is taken: a pose captured during
      // the past cycle (a camera faster than the loop, or a loop running late) lies between the
      // last cycle's entry and this one, not beyond the history; the update's shift moves it too.
      pose_history_.push(t_s, ekf_h_pose(model_, ekf_.x, nullptr));
      // A pose without a capture time is taken as of now (the history's newest entry: the same
      // update as without a history).
      pose_rejected_ = false;
      pose_distance_ = NAN;
      if (sensors.has_pose) pose_update(t_s, sensors);
      eta_ = ekf_.x.head<3>();
      zeta_ = ekf_.x.tail<3>();
      break;
  }
  // One absurd measurement must not poison the estimate for good: a diverged state latches a
  // fault and the estimator starts again from the last estimate that made sense.
  if (!estimate_ok(eta_, zeta_)) {
    latch_fault("estimator diverged: " + check_estimate(eta_, zeta_));
    restart_estimator(last_good_eta_);
  } else {
    last_good_eta_ = eta_;
  }

  if (!enabled_ || !fault_.empty()) {
    enabled_ = false;
    reference_reset(ref_, eta_);
    setpoints_rpm_.fill(0.0);
    alloc_ = AllocationResult{};
    feedforward_n_.setZero();
    return setpoints_rpm_;
  }

  // Reference, eq. (18): the active waypoint is the set-point; before any, hold the start.
  if (!trajectory_running_) {
    t_start_s_ = t_s;
    trajectory_running_ = true;
    waypoint_ = -1;
  }
  waypoint_ = active_waypoint(waypoints_, t_s - t_start_s_, waypoint_);
  const Vec3 eta_p = waypoint_ >= 0 ? waypoints_[static_cast<std::size_t>(waypoint_)].eta_p : ref_.eta_d;
  reference_step(config_.gamma_per_s, ref_, eta_p, dt);

  tracking_pid(config_.gains, pid_, eta_, zeta_, ref_, pid_terms_);  // eqs. (19)-(21)
  tau_command_n_ = pid_terms_.tau_n;
  if (config_.effect_feedforward && !feed_forward()) {
    setpoints_rpm_.fill(0.0);
    alloc_ = AllocationResult{};
    return setpoints_rpm_;
  }
  allocate(model_, config_.allocator, tau_command_n_, alloc_);  // eq. (22)
  if (!alloc_.omega_rpm.allFinite()) {
    latch_fault("non-finite screw speeds from the allocation (eq. (22))");
    setpoints_rpm_.fill(0.0);
    return setpoints_rpm_;
  }
  for (int i = 0; i < 4; ++i) setpoints_rpm_[static_cast<std::size_t>(i)] = alloc_.omega_rpm[i];
  return setpoints_rpm_;
}

}  // namespace auger
