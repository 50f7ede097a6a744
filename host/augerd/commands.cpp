// What a line on augerd's sockets does (docs/daemon-protocol.md), `status`, and arrival.
#include <cinttypes>
#include <cmath>
#include <cstdio>

#include "daemon.hpp"

namespace augerd {

std::optional<std::string> Daemon::command(const std::string& line) {
  Command c;
  const std::string err = parse_command(line, c);
  if (!err.empty()) return "error: " + err;
  return command(c, line);
}

std::optional<std::string> Daemon::command(const Command& c, const std::string& line) {
  const std::string not_enabled = "error: not enabled (send enable first): " + quote_line(line);
  switch (c.kind) {
    case CommandKind::status:
      return auger::daemon::format_status(status(c.text == "all"));
    case CommandKind::enable: {
      const int bad = bus_.first_not_answering();
      if (bad >= 0)
        return "error: module " + std::to_string(bad) + " (" + port_of(bad) + ") is not answering; cannot enable";
      bus_.clear_faults();
      if (fault_reason_ != "none") {
        const std::string what = fault_module_ >= 0 ? fault_reason_ : "estimator (" + controller_->fault() + ")";
        std::fprintf(stderr, "augerd: t=%.3f s: enable: clearing fault %s\n", t_s_, what.c_str());
        event(fault_module_, "re-enabled", "fault " + fault_reason_ + " cleared by enable from " + commands_->current_peer());
      } else if (!enabled_) {
        event(-1, "enable", "enabled by " + commands_->current_peer());
      }
      controller_->clear_fault();
      // The operator's go-ahead: a network cmd_vel may drive at once (docs/ros2.md "Arbitration").
      local_active_s_ = -1e9;
      estimator_fault_reported_ = false;
      fault_module_ = -1;
      fault_reason_ = "none";
      enabled_ = true;
      ++motion_epoch_;
      enter(Mode::idle);
      disable_controller();
      return "ok";
    }
    case CommandKind::stop:
      take_source(Source::local, "local stop by " + commands_->current_peer());
      if (enabled_)
        event(-1, "stop", std::string("all screws stopped (was ") + mode_name(mode_) + ") by " + commands_->current_peer());
      enabled_ = false;
      ++motion_epoch_;
      enter(Mode::stopped);
      disable_controller();
      return "ok";
    case CommandKind::spin:
      if (!enabled_) return not_enabled;
      if (tracking(mode_))
        return std::string("error: cannot spin one module during ") + mode_name(mode_) + " (stop first): " + quote_line(line);
      // One module alone (step responses, calibration): the robot is not tracking, and the
      // command expires like `vel` (the dead-man).
      if (mode_ != Mode::spin) event(int(c.a), "spin", "one module driven alone by " + commands_->current_peer());
      take_source(Source::local, "local spin by " + commands_->current_peer());
      disable_controller();
      spin_module_ = int(c.a);
      spin_rpm_ = c.b;
      vel_until_s_ = t_s_ + cfg_.vel_timeout_s;
      ++motion_epoch_;
      enter(Mode::spin);
      return "ok";
    case CommandKind::vel:
      if (!enabled_) return not_enabled;
      if (from_network_) take_source(Source::network, "network cmd_vel (ROS 2)");
      else take_source(Source::local, "local vel by " + commands_->current_peer());
      disable_controller();
      vel_cmd_ = auger::Vec3(c.a, c.b, c.c);
      vel_until_s_ = t_s_ + cfg_.vel_timeout_s;
      ++motion_epoch_;
      enter(Mode::vel);
      return "ok";
    case CommandKind::go_to: {
      if (!enabled_) return not_enabled;
      take_source(Source::local, "local goto by " + commands_->current_peer());
      final_waypoint_ = auger::Waypoint{0.0, auger::Vec3(c.a, c.b, c.c)};
      controller_->set_waypoints({final_waypoint_});
      controller_->set_enabled(true);
      ctrl_events_ |= kEvWaypoints;
      goal_ = final_waypoint_.eta_p;
      traj_logged_ = -1;
      motion_t0_s_ = t_s_;
      arrived_ = false;
      ++motion_epoch_;
      enter(Mode::go_to);
      return "ok";
    }
    case CommandKind::follow: {
      if (!enabled_) return not_enabled;
      if (loader_.busy()) return "error: another follow file is still being read: " + quote_line(line);
      // Read off the loop (waypoint_loader.hpp); the answer comes when the file has been read.
      follow_traj_n_ = traj_n_++;
      const std::string copy =
          cfg_.log_dir + "/" + run_name_ + "-follow-" + std::to_string(follow_traj_n_) + ".waypoints";
      loader_.start(c.text, copy, follow_traj_n_, t_s_);
      follow_client_ = commands_->current_client();
      follow_peer_ = commands_->current_peer();
      follow_epoch_ = motion_epoch_;
      return std::nullopt;
    }
    case CommandKind::allocator: {
      // The core's controller takes its configuration at construction: a new one, started
      // from the current estimate. Only between motions, so no trajectory restarts.
      if (tracking(mode_))
        return std::string("error: cannot switch the allocator during ") + mode_name(mode_) +
               " (stop or wait): " + quote_line(line);
      ctrl_cfg_.allocator.kind =
          c.text == "pinv" ? auger::AllocatorKind::pseudo_inverse : auger::AllocatorKind::null_space;
      const auger::Vec3 eta = controller_->eta_estimate();
      controller_ = std::make_unique<auger::Controller>(model_, ctrl_cfg_);
      controller_->reset(eta);
      ctrl_events_ |= kEvRebuilt;
      return "ok";
    }
  }
  return "error: internal";
}

void Daemon::follow_loaded() {
  std::optional<WaypointLoader::Result> r = loader_.poll(t_s_);
  if (!r) return;
  if (!r->error.empty()) return commands_->reply(follow_client_, "error: " + r->error);
  // Another command (or a fault) came while the file was read: it wins.
  if (!enabled_ || motion_epoch_ != follow_epoch_)
    return commands_->reply(follow_client_, "error: a later command or a fault came while the follow file was read");
  final_waypoint_ = r->waypoints.back();
  try {
    controller_->set_waypoints(std::move(r->waypoints));
  } catch (const std::exception& e) {
    return commands_->reply(follow_client_, std::string("error: ") + e.what());
  }
  take_source(Source::local, "local follow by " + follow_peer_);
  controller_->set_enabled(true);
  ctrl_events_ |= kEvWaypoints;
  traj_logged_ = r->copy_n;
  if (!r->copy_skipped.empty() && !follow_copy_said_) {
    follow_copy_said_ = true;  // once per run: a client repeating follow must not flood the event log
    std::fprintf(stderr, "augerd: t=%.3f s: %s\n", t_s_, r->copy_skipped.c_str());
    event(-1, "follow-not-copied", r->copy_skipped);
  }
  motion_t0_s_ = t_s_;
  arrived_ = false;
  enter(Mode::follow);
  commands_->reply(follow_client_, "ok");
}

std::string Daemon::sensor(const std::string& line) {
  SensorMessage m;
  const std::string err = parse_sensor(line, m);
  if (!err.empty()) return "error: " + err;
  return sensor(m, line);
}

std::string Daemon::sensor(const SensorMessage& m, const std::string& line) {
  // Wall-clock stamp to the loop's clock (CLOCK_MONOTONIC since start).
  const double t_loop_s = m.t_unix_s - mono_to_unix_s_ - t0_mono_s_;
  const double age_s = t_s_ - t_loop_s;
  if (age_s < -0.5)
    return "error: timestamp " + std::to_string(m.t_unix_s) + " is in the future by " + std::to_string(-age_s) +
           " s (clocks in sync?): " + quote_line(line);
  if (age_s > 2.0)
    return "error: timestamp " + std::to_string(m.t_unix_s) + " is " + std::to_string(age_s) + " s old: " + quote_line(line);
  if (m.kind == SensorKind::pose) {
    auger::SensorInput p;
    auger::daemon::to_sensor_input(m, t_loop_s, p);
    queue_pose(p, auger::Vec3(m.sx_m, m.sy_m, m.spsi_rad));
    last_pose_ = p.pose;
    last_pose_t_s_ = t_loop_s;
  } else {
    auger::daemon::to_sensor_input(m, t_loop_s, sensors_in_);
    last_imu_t_s_ = t_loop_s;
    last_imu_psi_rad_ = m.imu_psi_rad;
    last_imu_r_radps_ = m.imu_r_radps;
    last_imu_ax_mps2_ = m.has_acc ? m.ax_mps2 : NAN;
    last_imu_ay_mps2_ = m.has_acc ? m.ay_mps2 : NAN;
  }
  return "";
}

void Daemon::queue_pose(const auger::SensorInput& in, const auger::Vec3& sd) {
  if (pose_queue_n_ == kPoseQueue) {
    pose_queue_head_ = (pose_queue_head_ + 1) % kPoseQueue, --pose_queue_n_;
    ++poses_dropped_;
    if (!poses_dropped_said_) {
      poses_dropped_said_ = true;
      event(-1, "poses-dropped",
            "camera poses arrive faster than the 100 Hz loop takes them: the oldest of " + std::to_string(kPoseQueue) +
                " waiting is dropped (said once per run of drops)");
    }
  }
  pose_queue_[std::size_t((pose_queue_head_ + pose_queue_n_) % kPoseQueue)] = {in, sd};
  ++pose_queue_n_;
}

void Daemon::take_queued_pose() {
  if (pose_queue_n_ == 0) {
    poses_dropped_said_ = false;
    return;
  }
  const QueuedPose& q = pose_queue_[std::size_t(pose_queue_head_)];
  sensors_in_.has_pose = true;
  sensors_in_.pose = q.in.pose;
  sensors_in_.pose_cov = q.in.pose_cov;
  sensors_in_.pose_t_s = q.in.pose_t_s;
  pose_sd_ = q.sd;
  pose_queue_head_ = (pose_queue_head_ + 1) % kPoseQueue, --pose_queue_n_;
}

// A goto or follow has arrived once its waypoint clock is past the last waypoint and the
// estimate is within tolerance of the final pose; the controller keeps tracking that pose
// (mode hold) until the next command. Before, follow stayed "follow" for ever.
void Daemon::check_arrival() {
  if (!enabled_ || (mode_ != Mode::go_to && mode_ != Mode::follow)) return;
  if (t_s_ - motion_t0_s_ < final_waypoint_.t_s) return;
  const auger::Vec3 e = final_waypoint_.eta_p - controller_->eta_estimate();
  if (!(std::hypot(e[0], e[1]) <= kArrivedM) || !(std::fabs(auger::wrap_angle(e[2])) <= kArrivedRad)) return;
  arrived_ = true;
  char what[160];
  std::snprintf(what, sizeof what, "%s arrived at x=%.3f y=%.3f psi=%.3f; holding the final pose", mode_name(mode_),
                final_waypoint_.eta_p[0], final_waypoint_.eta_p[1], final_waypoint_.eta_p[2]);
  event(-1, "arrived", what);
  std::fprintf(stderr, "augerd: t=%.3f s: %s\n", t_s_, what);
  enter(Mode::hold);
}

auger::daemon::Status Daemon::status(bool all) const {
  auger::daemon::Status s;
  const auto& eta = controller_->eta_estimate();
  const auto& eta_d = controller_->reference().eta_d;
  s.t_s = t_s_;
  s.enabled = enabled_;
  s.mode = mode_name(mode_);
  s.x_m = eta[0], s.y_m = eta[1], s.psi_rad = eta[2];
  s.xd_m = eta_d[0], s.yd_m = eta_d[1], s.psid_rad = eta_d[2];
  s.fault = fault_module_ >= 0 ? std::to_string(fault_module_) + ":" + fault_reason_ : fault_reason_;
  s.loop_dt_s = loop_dt_s_;
  s.loop_jitter_max_s = jitter_max_s_;
  s.arrived = arrived_;
  s.log_ok = log_ ? log_->stats().ok : DataLog::Stats{}.ok;
  s.poses_rejected = poses_rejected_;
  s.all = all;
  if (!all) return s;
  bus_.status_fields(t_s_, s.modules);
  s.imu_age_s = t_s_ - last_imu_t_s_;
  s.imu_psi_rad = last_imu_psi_rad_;
  s.imu_r_radps = last_imu_r_radps_;
  s.imu_ax_mps2 = last_imu_ax_mps2_;
  s.imu_ay_mps2 = last_imu_ay_mps2_;
  s.pose_age_s = t_s_ - last_pose_t_s_;
  s.cam_x_m = last_pose_[0], s.cam_y_m = last_pose_[1], s.cam_psi_rad = last_pose_[2];
  s.poses_dropped = poses_dropped_;
  ros2_status(s);
  online_status(s);
  if (cfg_.controller.effect_feedforward) {
    const auger::Vec3& ff_n = controller_->effect_feedforward_n();
    s.feedforward = true;
    s.ff_force_x_n = ff_n[0], s.ff_force_y_n = ff_n[1], s.ff_torque_psi_nm = ff_n[2];
  }
  return s;
}

}  // namespace augerd
