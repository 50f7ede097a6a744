// augerd: the I/O shell around auger_core's controller (DESIGN.md): the 100 Hz loop on
// CLOCK_MONOTONIC over the module bus (module_bus.hpp), the command and sensor sockets
// (line_server.hpp, docs/daemon-protocol.md), the logs (data_log.hpp) and the safety rules
// (docs/daemon.md). The loop is daemon.cpp; what a command or sensor line does, commands.cpp.
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
#include "config.hpp"
#include "data_log.hpp"
#include "line_server.hpp"
#include "mode.hpp"
#include "module_bus.hpp"
#include "waypoint_loader.hpp"

namespace augerd {

class Daemon {
 public:
  Daemon(const DaemonConfig& cfg, auger::Model model);
  ~Daemon();

  // Start-up, in this order; each throws std::runtime_error naming the port, file or socket.
  void open_modules() { bus_.open(); }
  void open_sockets();
  void open_log();
  // Runs until *stop becomes non-zero (SIGINT/SIGTERM), then leaves the modules stopped.
  void run(volatile const std::sig_atomic_t* stop);

 private:
  // commands.cpp
  std::optional<std::string> command(const std::string& line);
  std::string sensor(const std::string& line);
  std::string status_line() const;
  std::string sensors_status() const;
  void check_arrival();
  void follow_loaded();  // a `follow` file's contents arrived from the loader
  void enter(Mode m) { mode_ = m; }

  // daemon.cpp
  void fault(int module, const std::string& reason_token, const std::string& detail);
  void event(int module, const std::string& what, const std::string& action);
  void disable_controller() {
    controller_->set_enabled(false);
    ctrl_events_ |= kEvDisabled;
  }
  std::array<double, 4> setpoints(const std::array<double, 4>& ctrl_rpm);
  void write_log(const std::array<double, 4>& cmd_rpm);
  std::string port_of(int module) const { return module >= 0 ? bus_.module(module).port : "-"; }

  static constexpr double kArrivedM = 0.02, kArrivedRad = 0.05;  // docs/daemon.md, "arrived"

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
  std::uint64_t follow_client_ = 0;  // the client waiting for its `follow` answer
  int follow_traj_n_ = -1;           // the copy's number for that request
  // Counts commands that change the motion, and faults: a `follow` whose file arrives after
  // another such event is refused (the later command wins).
  std::uint64_t motion_epoch_ = 0, follow_epoch_ = 0;

  auger::SensorInput sensors_in_;
  auger::Vec3 pose_sd_ = auger::Vec3::Constant(NAN);  // standard deviations of this cycle's pose
  // Latest sensor values whenever they came (status all: calib and teleop checks).
  double last_imu_t_s_ = NAN, last_imu_r_radps_ = NAN, last_imu_psi_rad_ = NAN;
  double last_pose_t_s_ = NAN;
  auger::Vec3 last_pose_ = auger::Vec3::Constant(NAN);

  // What changed the core controller's state this cycle, before its step (log column
  // ctrl_events, so that auger replay applies the same changes in the same cycle).
  static constexpr int kEvDisabled = 1, kEvWaypoints = 2, kEvRebuilt = 4;
  int ctrl_events_ = 0;
  auger::Vec3 goal_ = auger::Vec3::Constant(NAN);  // goto of this cycle
  int traj_n_ = 0;          // follow files copied beside the log (…-follow-N.waypoints)
  int traj_logged_ = -1;    // the follow file of this cycle, -1 none
  std::string run_name_;    // augerd-<UTC start>: names the log files of this run
};

}  // namespace augerd
