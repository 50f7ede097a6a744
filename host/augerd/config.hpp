// augerd's configuration file (TOML, docs/daemon.md): serial ports, model, controller settings,
// sockets, log. Unknown keys and bad values are errors naming the file and line (ConfigError).
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "auger/controller.hpp"
#include "auger/model.hpp"
#include "ros2.hpp"

namespace augerd {

struct DaemonConfig {
  std::string path;  // the file read (errors and relative paths refer to it)

  // [serial]
  std::array<std::string, 4> ports;   // any order: modules are mapped by their identity id
  unsigned baud = 250000;
  double identity_timeout_s = 2.0;    // DESIGN.md: a DTR reset keeps the bootloader ~1 s
  double telemetry_timeout_s = 0.1;   // no valid telemetry this long: the module is lost

  // [model]
  std::string model_file;  // resolved against the configuration file's directory
  std::string terrain = "sand";

  // [control]: applied over the model file's [control] and Table 5 defaults
  auger::ControllerConfig controller;
  double period_s = 0.01;         // the loop period (100 Hz)
  double vel_timeout_s = 0.5;     // dead-man of `vel` commands
  int realtime_priority = 0;      // > 0: SCHED_FIFO at this priority and locked memory

  // [sockets]
  std::string commands_socket;
  std::string sensors_socket;

  // [log]
  std::string log_dir;
  std::uint64_t log_rotate_bytes = 64ull << 20;
  double log_flush_interval_s = 1.0;

  // [ros2]: the ROS 2 interface on DDS, off unless enabled (docs/ros2.md)
  auger::ros2::Settings ros2;
};

// Reads and checks the file, including the model file (so that a bad model is a start-up error
// too). Throws auger::ConfigError ("file:line:column: message").
DaemonConfig load_daemon_config(const std::string& path);

}  // namespace augerd
