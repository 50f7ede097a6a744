// augerd's side of the ROS 2 interface (docs/ros2.md): the bridge (host/ros2) does every DDS
// call on its own threads; the loop only takes the newest inputs and hands over its state, and
// measures the time that costs it.
#include <algorithm>
#include <cstdio>
#include <ctime>

#include <Eigen/Core>

#include "clock.hpp"
#include "daemon.hpp"

namespace augerd {

void Daemon::open_ros2() {
  if (cfg_.ros2.enabled) ros2_ = auger::ros2::make_bridge(cfg_.ros2);
  if (ros2_) std::fprintf(stderr, "augerd: ROS 2 on DDS, %s\n", ros2_->describe().c_str());
}

// Inputs go through the sockets' own entry points, `vel` and the sensors socket's `pose` and
// `imu` lines (%.17g reproduces every double exactly): every bound and check of those
// (parse_command, parse_sensor: auger/input_limits.hpp) applies to ROS 2 messages unchanged,
// and the 0.5 s dead-man of `vel` to Twist.
void Daemon::ros2_inputs() {
  // When the local command stopped running (a vel's dead-man, a goto's arrival): the network
  // waits local_priority_s from there.
  if (local_motion_running()) local_active_s_ = t_s_;
  auger::ros2::Inputs in;
  const double t0 = clock_s(CLOCK_MONOTONIC), c0 = clock_s(CLOCK_THREAD_CPUTIME_ID);
  const bool got = ros2_->poll(in);
  ros2_cycle_us_ = 1e6 * (clock_s(CLOCK_MONOTONIC) - t0);
  ros2_cycle_cpu_us_ = 1e6 * (clock_s(CLOCK_THREAD_CPUTIME_ID) - c0);
  if (!got) return;
  if (in.refused > 0) {
    ros2_refused_ += in.refused - 1;  // ros2_refused() counts the last one
    ros2_refused(in.refusal.data());
  }
  char line[320];
  auto apply = [&](const std::string& answer, const char* what) {
    if (answer.empty() || answer == "ok") {
      ++ros2_applied_;
      return;
    }
    ros2_refused(std::string(what) + ": " + (answer.rfind("error: ", 0) == 0 ? answer.substr(7) : answer));
  };
  if (in.has_vel) {
    std::snprintf(line, sizeof line, "vel %.17g %.17g %.17g", in.u_mps, in.v_mps, in.r_radps);
    if (const std::string why = network_vel_refusal(); !why.empty()) {
      ros2_refused("cmd_vel: " + why);
    } else {
      // `vel` always answers at once (only `follow` answers later).
      from_network_ = true;
      apply(command(line).value_or("ok"), "cmd_vel");
      from_network_ = false;
    }
  }
  if (in.has_pose) {
    std::snprintf(line, sizeof line, "pose %.17g %.17g %.17g %.17g %.17g %.17g %.17g", in.pose_t_unix_s, in.x_m, in.y_m,
                  in.psi_rad, in.sx_m, in.sy_m, in.spsi_rad);
    apply(sensor(line), "pose");
  }
  if (in.has_imu) {
    std::snprintf(line, sizeof line, "imu %.17g %.17g %.17g", in.imu_t_unix_s, in.imu_psi_rad, in.imu_r_radps);
    apply(sensor(line), "imu");
  }
}

// Motion commands arbitrated as twist_mux does it, by priority (docs/ros2.md "Arbitration"):
// a local `stop` (and any fault) first, then the local motion commands (goto, follow, vel,
// spin), then a network cmd_vel, which drives only while no local motion runs and not before
// local_priority_s after the last one ended (or arrived), so a teleoperation's pauses and a
// goto's arrival are not taken over at once. A `stop` needs a local `enable` anyway.
void Daemon::take_source(Source s, const std::string& who) {
  if (s == Source::local) local_active_s_ = t_s_;
  // Only with ROS 2 are there two sources to tell apart.
  if (ros2_ && s != source_) {
    event(-1, "source", "motion commands from " + who + " (was " + source_who_ + ")");
    std::fprintf(stderr, "augerd: t=%.3f s: motion commands from %s (was %s)\n", t_s_, who.c_str(),
                 source_who_.c_str());
  }
  network_refusal_said_ = false;  // a new command: a new run of refusals gets its event
  source_ = s;
  source_who_ = who;
}

std::string Daemon::network_vel_refusal() {
  if (source_ != Source::local || !enabled_) return "";  // not enabled: command() says so
  const bool running = local_motion_running();
  char why[200] = "";
  if (running)
    std::snprintf(why, sizeof why, "a %s is running (%s); local commands have priority", mode_name(mode_),
                  source_who_.c_str());
  else if (t_s_ - local_active_s_ < cfg_.ros2.local_priority_s)
    std::snprintf(why, sizeof why,
                  "the last local command (%s) ended %.2f s ago; network cmd_vel may drive %.2f s after it",
                  source_who_.c_str(), t_s_ - local_active_s_, cfg_.ros2.local_priority_s);
  if (why[0] && !network_refusal_said_) {
    event(-1, "network-refused", std::string("cmd_vel (ROS 2) not obeyed: ") + why);
    network_refusal_said_ = true;
  }
  return why;
}

void Daemon::ros2_refused(const std::string& why) {
  ++ros2_refused_;
  ros2_last_refusal_ = why;
  if (t_s_ - ros2_said_at_s_ < 5.0) {
    ++ros2_unsaid_;
    return;
  }
  std::fprintf(stderr, "augerd: t=%.3f s: ROS 2 input refused: %s", t_s_, why.c_str());
  if (ros2_unsaid_ > 0) std::fprintf(stderr, " (and %ld more refused since the last message)", ros2_unsaid_);
  std::fputc('\n', stderr);
  ros2_said_at_s_ = t_s_;
  ros2_unsaid_ = 0;
}

void Daemon::ros2_publish() {
  auger::ros2::Snapshot& o = ros2_out_;
  o.t_unix_s = t0_mono_s_ + t_s_ + mono_to_unix_s_;
  const auger::Vec3& eta = controller_->eta_estimate();
  const auger::Vec3& zeta = controller_->zeta_estimate();
  for (int i = 0; i < 3; ++i) o.eta[i] = eta[i], o.zeta[i] = zeta[i];
  const auger::Mat6* P = controller_->estimate_covariance();
  o.has_cov = P != nullptr;
  if (P) Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(o.cov) = *P;
  for (int i = 0; i < 4; ++i) {
    const Module& m = bus_.module(i);
    auger::ros2::ModuleSnapshot& x = o.module[i];
    x.answering = m.tm.received && m.answering();
    x.omega_rpm = m.tm.omega_rpm();
    x.cmd_rpm = m.cmd_rpm;
    x.current_a = m.tm.current_a();
    x.voltage_v = m.tm.voltage_v();
    x.pwm = m.tm.pwm();
    x.status = m.tm.frame.status;
    x.rx_errors = m.tm.frame.rx_errors;
    x.encoder_errors = m.tm.frame.encoder_errors;
    x.crc_errors = m.link ? m.link->parser_stats().crc_errors : 0;
    x.header_errors = m.link ? m.link->parser_stats().header_errors : 0;
    x.bytes_skipped = m.link ? m.link->parser_stats().bytes_discarded : 0;
    x.fw[0] = m.identity.fw_major, x.fw[1] = m.identity.fw_minor, x.fw[2] = m.identity.fw_patch;
    std::snprintf(x.port.data(), x.port.size(), "%s", m.port.c_str());
  }
  o.enabled = enabled_;
  std::snprintf(o.mode.data(), o.mode.size(), "%s", mode_name(mode_));
  o.fault_module = fault_module_;
  std::snprintf(o.fault_reason.data(), o.fault_reason.size(), "%s", fault_reason_.c_str());
  o.loop_dt_s = loop_dt_s_;
  o.loop_jitter_max_s = jitter_max_s_;
  o.hook_max_us = ros2_hook_us_max_;
  o.inputs_applied = ros2_applied_;
  o.inputs_refused = ros2_refused_;
  std::snprintf(o.last_refusal.data(), o.last_refusal.size(), "%s", ros2_last_refusal_.c_str());
  const double t0 = clock_s(CLOCK_MONOTONIC), c0 = clock_s(CLOCK_THREAD_CPUTIME_ID);
  ros2_->publish(o);
  ros2_cycle_us_ += 1e6 * (clock_s(CLOCK_MONOTONIC) - t0);
  ros2_cycle_cpu_us_ += 1e6 * (clock_s(CLOCK_THREAD_CPUTIME_ID) - c0);
  ros2_sum_cpu_us_ += ros2_cycle_cpu_us_;
  ros2_max_cpu_us_ = std::max(ros2_max_cpu_us_, ros2_cycle_cpu_us_);
  ros2_window_max_us_ = std::max(ros2_window_max_us_, ros2_cycle_us_);
  if (t_s_ - ros2_window_start_s_ >= 1.0) {
    ros2_hook_us_max_ = ros2_window_max_us_;
    ros2_window_max_us_ = 0;
    ros2_window_start_s_ = t_s_;
  }
  ros2_sum_us_ += ros2_cycle_us_;
  ros2_max_all_us_ = std::max(ros2_max_all_us_, ros2_cycle_us_);
  ++ros2_cycles_;
  ros2_cycle_us_ = 0;
}

std::string Daemon::ros2_status() const {
  if (!ros2_) return "";
  char buf[160];
  std::snprintf(buf, sizeof buf, " ros2_applied=%ld ros2_refused=%ld ros2_hook_max_us=%.1f", ros2_applied_,
                ros2_refused_, ros2_hook_us_max_);
  return buf;
}

void Daemon::ros2_report() const {
  if (!ros2_ || ros2_cycles_ == 0) return;
  std::fprintf(stderr,
               "augerd: ROS 2: %ld inputs applied, %ld refused; the loop spent %.1f us mean, %.1f us max per cycle "
               "in the bridge's poll and publish (its own CPU time %.1f us mean, %.1f us max)\n",
               ros2_applied_, ros2_refused_, ros2_sum_us_ / double(ros2_cycles_), ros2_max_all_us_,
               ros2_sum_cpu_us_ / double(ros2_cycles_), ros2_max_cpu_us_);
}

}  // namespace augerd
