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

// Inputs go through the sockets' own entry points as typed messages, `vel` and the sensors
// socket's `pose` and `imu`: every bound and check of those (check_command, check_sensor:
// auger/input_limits.hpp) applies to ROS 2 messages unchanged, and the 0.5 s dead-man of `vel` to
// Twist. The lines below are only how an error answer quotes the input (%.17g: every double
// exactly), as if it had come as a line.
void Daemon::ros2_inputs() {
  // When the local command stopped running (a vel's dead-man, a goto's arrival): the network
  // waits local_priority_s from there.
  if (local_motion_running()) local_active_s_ = t_s_;
  auger::ros2::Inputs in;
  const double t0 = clock_s(CLOCK_MONOTONIC), c0 = clock_s(CLOCK_THREAD_CPUTIME_ID);
  const bool got = ros2_->poll(in);
  ros2_time_.cycle_us = 1e6 * (clock_s(CLOCK_MONOTONIC) - t0);
  ros2_time_.cycle_cpu_us = 1e6 * (clock_s(CLOCK_THREAD_CPUTIME_ID) - c0);
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
    Command c;
    c.kind = CommandKind::vel;
    c.a = in.u_mps, c.b = in.v_mps, c.c = in.r_radps;
    std::snprintf(line, sizeof line, "vel %.17g %.17g %.17g", c.a, c.b, c.c);
    if (const std::string why = network_vel_refusal(); !why.empty()) {
      ros2_refused("cmd_vel: " + why);
    } else if (const std::string bad = auger::daemon::check_command(c); !bad.empty()) {
      apply("error: " + bad, "cmd_vel");
    } else {
      // `vel` always answers at once (only `follow` answers later).
      from_network_ = true;
      apply(command(c, line).value_or("ok"), "cmd_vel");
      from_network_ = false;
    }
  }
  auto sense = [&](const SensorMessage& m, const char* what) {
    if (const std::string bad = auger::daemon::check_sensor(m); !bad.empty()) return apply("error: " + bad, what);
    apply(sensor(m, auger::daemon::sensor_line(m)), what);
  };
  for (int i = 0; i < in.n_poses; ++i) sense(in.poses[std::size_t(i)], "pose");
  if (in.has_imu) sense(in.imu, "imu");
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
  o.hook_max_us = ros2_time_.hook_us_max;
  o.inputs_applied = ros2_applied_;
  o.inputs_refused = ros2_refused_;
  std::snprintf(o.last_refusal.data(), o.last_refusal.size(), "%s", ros2_last_refusal_.c_str());
  online_snapshot(o.online);
  const double t0 = clock_s(CLOCK_MONOTONIC), c0 = clock_s(CLOCK_THREAD_CPUTIME_ID);
  ros2_->publish(o);
  Ros2Timing& rt = ros2_time_;
  rt.cycle_us += 1e6 * (clock_s(CLOCK_MONOTONIC) - t0);
  rt.cycle_cpu_us += 1e6 * (clock_s(CLOCK_THREAD_CPUTIME_ID) - c0);
  rt.sum_cpu_us += rt.cycle_cpu_us;
  rt.max_cpu_us = std::max(rt.max_cpu_us, rt.cycle_cpu_us);
  rt.window_max_us = std::max(rt.window_max_us, rt.cycle_us);
  if (t_s_ - rt.window_start_s >= 1.0) {
    rt.hook_us_max = rt.window_max_us;
    rt.window_max_us = 0;
    rt.window_start_s = t_s_;
  }
  rt.sum_us += rt.cycle_us;
  rt.max_all_us = std::max(rt.max_all_us, rt.cycle_us);
  ++rt.cycles;
  rt.cycle_us = 0;
}

void Daemon::ros2_status(auger::daemon::Status& s) const {
  s.ros2 = ros2_ != nullptr;
  if (!s.ros2) return;
  s.ros2_applied = ros2_applied_;
  s.ros2_refused = ros2_refused_;
  s.ros2_hook_max_us = ros2_time_.hook_us_max;
}

void Daemon::ros2_report() const {
  const Ros2Timing& rt = ros2_time_;
  if (!ros2_ || rt.cycles == 0) return;
  std::fprintf(stderr,
               "augerd: ROS 2: %ld inputs applied, %ld refused; the loop spent %.1f us mean, %.1f us max per cycle "
               "in the bridge's poll and publish (its own CPU time %.1f us mean, %.1f us max)\n",
               ros2_applied_, ros2_refused_, rt.sum_us / double(rt.cycles), rt.max_all_us,
               rt.sum_cpu_us / double(rt.cycles), rt.max_cpu_us);
}

}  // namespace augerd
