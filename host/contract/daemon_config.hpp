// augerd's configuration file (TOML, docs/daemon.md): serial ports, model, controller settings,
// sockets, log, ROS 2. Unknown keys and bad values are errors naming the file and line
// (ConfigError). Read by augerd and by `auger replay`, which rebuilds augerd's controller from it.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "auger/controller.hpp"
#include "auger/model.hpp"
#include "auger/model_file.hpp"
#include "auger/kinematic_velocity.hpp"
#include "auger/online_estimator.hpp"
#include "ros2_settings.hpp"

namespace auger {

struct DaemonConfig {
  std::string path;  // the file read (errors and relative paths refer to it)

  // [serial]
  std::array<std::string, 4> ports;   // any order: modules are mapped by their identity id
  unsigned baud = 250000;
  double identity_timeout_s = 2.0;    // docs/design.md: a DTR reset keeps the bootloader ~1 s
  double telemetry_timeout_s = 0.1;   // no valid telemetry this long: the module is lost

  // [model]
  std::string model_file;  // resolved against the configuration file's directory
  // Its contents, read once here: augerd builds its model, online parameters and terrain rows
  // from this, so they cannot come from two versions of a file edited meanwhile.
  auger::ModelFile model;
  std::string terrain = "sand";

  // [control]: applied over the model file's [control] and Table 5 defaults
  ControllerConfig controller;
  double period_s = 0.01;         // the loop period (100 Hz)
  double vel_timeout_s = 0.5;     // dead-man of `vel` commands
  int realtime_priority = 0;      // > 0: SCHED_FIFO at this priority and locked memory

  // [sockets]
  std::string commands_socket;
  std::string sensors_socket;
  // Who may connect: the files' modes and groups, set explicitly (docs/daemon.md "Who may
  // command the robot"). A group is a name resolved at start-up (the system's, not the file's
  // business: check_startup); empty: augerd's own group.
  unsigned commands_mode = 0660, sensors_mode = 0660;
  std::string commands_group, sensors_group;
  double idle_timeout_s = 30.0;               // a client that sends no line this long is closed

  // [log]
  std::string log_dir;
  std::uint64_t log_rotate_bytes = 64ull << 20;
  double log_flush_interval_s = 1.0;
  double log_fsync_interval_s = 10.0;
  bool log_mcap = false;  // an MCAP file beside each CSV file (docs/formats.md)

  // Lines of keys whose values are checked against each other after the model file's defaults
  // (0: not in this file).
  int line_omega_min = 0, line_omega_max = 0, line_period = 0, line_telemetry_timeout = 0;
  int line_commands_group = 0, line_sensors_group = 0;

  // [ros2]: the ROS 2 interface on DDS, off unless enabled (docs/ros2.md)
  auger::ros2::Settings ros2;

  // [online]: identification of the terrain while driving, off unless enabled (docs/daemon.md
  // "Online identification"); apply: the controller uses what it identified (off by default: fed
  // with the EKF's velocity the estimate follows the controller's own model, docs/benchmarks.md).
  auger::OnlineConfig online;
  bool online_apply = false;
  // velocity = "kinematic": the estimator is fed auger::KinematicVelocity's body velocity (the
  // camera and IMU alone, no terrain model) instead of the EKF's.
  bool online_kinematic = false;
  // That filter's settings: the accelerometer's use and noise (accelerometer, acc_noise, ...).
  auger::KinematicVelocityConfig online_kin;
};

// Reads and checks the file, including the model file (so that a bad model is a start-up error
// too) and the order of related values (omega_min_rpm <= omega_max_rpm, ...). Throws
// ConfigError ("file:line:column: message"). ros2_available: whether the reader's program has
// the ROS 2 bridge (augerd built with Cyclone DDS); if not, `[ros2] enabled = true` is an error.
// ros2_security_stated: whether `[ros2] enabled = true` must come with `keystore` or `insecure =
// true` (false only for `auger ros2-keys`, which makes the keystore the file will name).
DaemonConfig read_daemon_config(const std::string& path, bool ros2_available, bool ros2_security_stated = true);

}  // namespace auger
