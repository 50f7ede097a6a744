// augerd: the I/O shell around auger_core's controller (docs/design.md): the 100 Hz loop on
// CLOCK_MONOTONIC over the module bus (module_bus.hpp), the command and sensor sockets
// (line_server.hpp, docs/daemon-protocol.md), the logs (data_log.hpp), the safety rules
// (docs/daemon.md) and the ROS 2 interface (docs/ros2.md). The loop is daemon.cpp; what a
// command or sensor line does, commands.cpp; what ROS 2 messages do and see, ros2_link.cpp.
#pragma once

#include <array>
#include <csignal>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "auger/controller.hpp"
#include "auger/model.hpp"
#include "auger/kinematic_velocity.hpp"
#include "auger/online_estimator.hpp"
#include "config.hpp"
#include "daemon_lines.hpp"
#include "daemon_log.hpp"
#include "data_log.hpp"
#include "line_server.hpp"
#include "module_bus.hpp"
#include "ros2.hpp"
#include "status.hpp"
#include "waypoint_loader.hpp"

namespace augerd {

// The log schema, the socket line protocols and the status answer are shared with `auger`
// (auger_contract, host/contract).
using auger::daemon::Command;
using auger::daemon::CommandKind;
using auger::daemon::Mode;
using auger::daemon::SensorKind;
using auger::daemon::SensorMessage;
using auger::daemon::kEvDisabled;
using auger::daemon::kEvRebuilt;
using auger::daemon::kEvWaypoints;
using auger::daemon::mode_name;
using auger::daemon::parse_command;
using auger::daemon::parse_sensor;
using auger::daemon::quote_line;
using auger::daemon::tracking;

// The loop's time inside Bridge::poll and Bridge::publish (docs/benchmarks.md): this cycle's, the
// longest over the last whole second (status all, diagnostics), and over the run; wall time, and
// the loop thread's CPU time (wall minus CPU: the thread was preempted, not waiting: nothing in
// there waits).
struct Ros2Timing {
  double cycle_us = 0, window_max_us = 0, window_start_s = 0, hook_us_max = 0;
  double sum_us = 0, max_all_us = 0;
  double cycle_cpu_us = 0, sum_cpu_us = 0, max_cpu_us = 0;
  long cycles = 0;
};

class Daemon {
 public:
  Daemon(const DaemonConfig& cfg, auger::Model model);
  ~Daemon();

  // Start-up, in this order; each throws std::runtime_error naming the port, file or socket.
  void open_modules() { bus_.open(); }
  void open_sockets();
  void open_log();
  // The ROS 2 interface when [ros2] enabled (docs/ros2.md); its threads, not the loop, do the DDS
  // I/O. Throws std::runtime_error.
  void open_ros2();
  // Runs until *stop becomes non-zero (SIGINT/SIGTERM), then leaves the modules stopped.
  void run(volatile const std::sig_atomic_t* stop);

 private:
  // commands.cpp
  std::optional<std::string> command(const std::string& line);
  // A parsed command; line: how an error answer quotes it (the socket's line, or for a ROS 2
  // input the command it stands for).
  std::optional<std::string> command(const Command& c, const std::string& line);
  std::string sensor(const std::string& line);
  // A parsed message (its values checked already: parse_sensor, check_sensor).
  std::string sensor(const SensorMessage& m, const std::string& line);
  auger::daemon::Status status(bool all) const;
  void check_arrival();
  void follow_loaded();  // a `follow` file's contents arrived from the loader
  void enter(Mode m) { mode_ = m; }

  // ros2_link.cpp: ROS 2 inputs as typed commands and sensor messages, the cycle's state out.
  void ros2_inputs();
  void ros2_publish();
  void ros2_refused(const std::string& why);
  // Arbitration of motion commands (docs/ros2.md "Arbitration"): local stop > local goto,
  // follow, vel, spin > network cmd_vel; every change of source an event.
  enum class Source { none, local, network };
  void take_source(Source s, const std::string& who);
  std::string network_vel_refusal();  // why a network cmd_vel may not drive now ("" if it may)
  bool local_motion_running() const {
    return source_ == Source::local && enabled_ &&
           (mode_ == Mode::vel || mode_ == Mode::spin || mode_ == Mode::go_to || mode_ == Mode::follow);
  }
  void ros2_status(auger::daemon::Status& s) const;  // status all's ros2_* fields (none without ROS 2)
  void ros2_report() const;         // the exit report's ROS 2 line

  // online_link.cpp: the online estimator, [online] enabled (docs/daemon.md "Online
  // identification"); with it off (online_ null) none of this runs and the log has no more columns.
  void online_step(const std::array<auger::ScrewTelemetry, 4>& tel);
  void online_values(double* out) const;  // this cycle's online_columns()
  void online_status(auger::daemon::Status& s) const;  // status all's online fields (none when off)
  void online_snapshot(auger::ros2::OnlineSnapshot& o) const;  // for ROS 2 (enabled false when off)
  // The event `what` with the online effects' estimates after `lead` (none: no event).
  void online_effects_event(const char* what, const char* lead);

  // daemon.cpp
  void fault(int module, const std::string& reason_token, const std::string& detail);
  void event(int module, const std::string& what, const std::string& action);
  void disable_controller() {
    controller_->set_enabled(false);
    ctrl_events_ |= auger::daemon::kEvDisabled;
  }
  std::array<double, 4> setpoints(const std::array<double, 4>& ctrl_rpm);
  void write_log(const std::array<double, 4>& cmd_rpm);
  std::string port_of(int module) const { return module >= 0 ? bus_.module(module).port : "-"; }

  static constexpr double kArrivedM = 0.02, kArrivedRad = 0.05;  // docs/daemon.md "The loop"

  const DaemonConfig& cfg_;
  auger::Model model_;
  auger::ControllerConfig ctrl_cfg_;
  std::unique_ptr<auger::Controller> controller_;
  ModuleBus bus_;
  std::unique_ptr<LineServer> commands_, sensors_;
  std::unique_ptr<DataLog> log_;
  WaypointLoader loader_;

  double t0_mono_s_ = 0, t0_unix_s_ = 0;
  double t_s_ = 0;            // loop time of this cycle (CLOCK_MONOTONIC since start)
  double mono_to_unix_s_ = 0; // CLOCK_REALTIME - CLOCK_MONOTONIC now, for sensor timestamps
  double loop_dt_s_ = 0;
  double jitter_max_s_ = 0;   // over the last second, for `status`

  bool enabled_ = false;
  Mode mode_ = Mode::stopped;
  auger::Vec3 vel_cmd_ = auger::Vec3::Zero();
  double vel_until_s_ = 0;
  auger::Waypoint final_waypoint_;  // goto/follow: the last waypoint (arrival)
  double motion_t0_s_ = 0;    // goto/follow: loop time the motion started (its waypoint clock)
  bool arrived_ = false;      // goto/follow: past the last waypoint and at the final pose
  int spin_module_ = -1;      // `spin`: one module at spin_rpm_, the others 0 (auger step, calib)
  double spin_rpm_ = 0;
  int fault_module_ = -1;     // -1 with fault_reason_ != "none": the estimator
  std::string fault_reason_ = "none";
  bool estimator_fault_reported_ = false;  // the controller's latched fault, until `enable`
  // A run of camera poses the estimator's gate rejected (docs/daemon.md "Safety"): its first in
  // the event log, and its end with the count.
  long poses_rejected_ = 0;  // over the run (status)
  long reject_run_n_ = 0;
  double reject_run_t0_s_ = 0;
  void pose_gate_events();
  std::uint64_t follow_client_ = 0;  // the client waiting for its `follow` answer
  int follow_traj_n_ = -1;           // the copy's number for that request
  bool follow_copy_said_ = false;    // a follow past the copies' budget is in the event log
  std::string follow_peer_;          // and who sent it (the source's event)
  // Counts commands that change the motion, and faults: a `follow` whose file arrives after
  // another such event is refused (the later command wins).
  std::uint64_t motion_epoch_ = 0, follow_epoch_ = 0;

  auger::SensorInput sensors_in_;
  auger::Vec3 pose_sd_ = auger::Vec3::Constant(NAN);  // standard deviations of this cycle's pose
  // Camera poses not yet given to the estimator. Several may arrive in one cycle (a burst after
  // a network stall, two sources): each reaches the estimator, one per cycle in arrival order,
  // compared with the prediction for its own capture time, so the log's row holds exactly the
  // pose the estimator took (auger replay reproduces augerd). Fixed size, no allocation: beyond
  // kPoseQueue waiting (a source faster than the loop) the oldest is dropped and counted.
  struct QueuedPose {
    auger::SensorInput in;  // its pose fields
    auger::Vec3 sd;
  };
  static constexpr int kPoseQueue = 8;
  std::array<QueuedPose, kPoseQueue> pose_queue_{};
  int pose_queue_head_ = 0, pose_queue_n_ = 0;
  long poses_dropped_ = 0;
  bool poses_dropped_said_ = false;
  void queue_pose(const auger::SensorInput& in, const auger::Vec3& sd);
  void take_queued_pose();  // the oldest into sensors_in_, before the controller's step
  // Latest sensor values whenever they came (status all: calib and teleop checks).
  double last_imu_t_s_ = NAN, last_imu_r_radps_ = NAN, last_imu_psi_rad_ = NAN;
  double last_imu_ax_mps2_ = NAN, last_imu_ay_mps2_ = NAN;
  double last_pose_t_s_ = NAN;
  auger::Vec3 last_pose_ = auger::Vec3::Constant(NAN);

  int ctrl_events_ = 0;  // log column ctrl_events: auger::daemon::CtrlEvent bits of this cycle
  auger::Vec3 goal_ = auger::Vec3::Constant(NAN);  // goto of this cycle
  int traj_n_ = 0;          // follow files copied beside the log (…-follow-N.waypoints)
  int traj_logged_ = -1;    // the follow file of this cycle, -1 none
  std::string run_name_;    // augerd-<UTC start>: names the log files of this run

  std::unique_ptr<auger::OnlineEstimator> online_;  // null: [online] off
  std::vector<auger::TerrainParams> terrains_;       // the model file's, to name the believed terrain
  bool online_change_ = false;                       // a change detected this cycle
  bool online_fallback_said_ = false;
  std::string applied_terrain_;                      // the believed terrain of what the controller uses
  auger::KinematicVelocity online_kin_;              // [online] velocity = "kinematic"
  std::string believed_said_;                        // the estimate's believed terrain last written as an event
  double believed_next_t_s_ = 0;                     // when it is looked at next (once a second)
  std::string believed_now_ = "unknown";             // what it was then, in full (ROS 2 diagnostics)
  auger::VecE effects_said_ = auger::VecE::Constant(NAN);  // the online effects' values last written as an event

  // ROS 2 (null unless enabled): what its inputs did, and the time the loop spends on it.
  std::unique_ptr<auger::ros2::Bridge> ros2_;
  Source source_ = Source::none;   // where the running (or last) motion command came from
  std::string source_who_ = "none";
  double local_active_s_ = -1e9;   // the last cycle a local motion command ran (or its stop)
  bool from_network_ = false;      // command() is running a network cmd_vel
  bool network_refusal_said_ = false;  // the event of this run of refusals is in the log
  auger::ros2::Snapshot ros2_out_;
  long ros2_applied_ = 0, ros2_refused_ = 0;
  std::string ros2_last_refusal_;
  double ros2_said_at_s_ = -1e9;  // refusals are printed at most every 5 s
  long ros2_unsaid_ = 0;
  Ros2Timing ros2_time_;
};

}  // namespace augerd
