// augerd's ROS 2 interface on the wire (DDS, Eclipse Cyclone DDS; docs/ros2.md): its settings
// (augerd's [ros2] section), ROS 2's name rules, and the bridge. augerd's 100 Hz loop sees only
// Bridge::poll and Bridge::publish, which never block: every DDS call happens on the bridge's
// own thread or in Cyclone's receive thread. This header has no DDS type in it, so augerd and
// its configuration reader compile the same with or without Cyclone DDS (AUGER_WITH_ROS2). The
// settings and ROS 2's name rules are augerd's contract's (host/contract/ros2_settings.hpp): the
// configuration reader there checks them without DDS; the inputs arrive as the sensors socket's
// typed messages (host/contract/daemon_lines.hpp).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "daemon_lines.hpp"
#include "ros2_settings.hpp"

namespace auger::ros2 {

// ---- the 100 Hz loop's side ----

// One module's state for JointState and the diagnostics.
struct ModuleSnapshot {
  bool answering = false;       // telemetry within augerd's timeout
  double omega_rpm = 0, cmd_rpm = 0, current_a = 0, voltage_v = 0, pwm = 0;
  uint16_t status = 0;          // the telemetry's status word (latched faults in the high byte)
  uint16_t rx_errors = 0, encoder_errors = 0;                     // the module's counters
  uint16_t crc_errors = 0, header_errors = 0, bytes_skipped = 0;  // augerd's parser's
  uint8_t fw[3] = {0, 0, 0};
  std::array<char, 96> port{};
};

// augerd's [online] estimator (docs/daemon.md "Online identification"): the estimate in the
// order sigma_long, sigma_lat (N/rpm), D_x, D_y (N/(m/s)), D_psi (N m/(rad/s)), and the detector.
struct OnlineSnapshot {
  bool enabled = false;
  double value[5] = {}, sd[5] = {};
  bool held[5] = {};                 // held at the configured value (auger::OnlineEstimate::held)
  double cusum = 0, cusum_threshold = 0;
  long changes = 0;
  std::array<char, 64> fallback{};   // the latched fallback's reason, "" none
  std::array<char, 200> believed{};  // the believed terrain, auger::believed_terrain (looked at once a second)
  std::array<char, 24> basis{};      // what it compared, auger::believed_basis
  // The effects' parameters the model file marks online (auger::kMaxOnlineEffects at most), in
  // their units: the /diagnostics entry's values (the estimate topic keeps its five rows).
  static constexpr int kMaxEffects = 3;
  int effects = 0;
  double effect_value[kMaxEffects] = {}, effect_sd[kMaxEffects] = {};
  std::array<char, 64> effect_name[kMaxEffects] = {};  // "terrain_slope.incline_x_rad"
  std::array<char, 24> effect_unit[kMaxEffects] = {};
};

// What augerd knows at the end of a cycle; plain data, copied as a whole (no allocation).
struct Snapshot {
  double t_unix_s = 0;              // the cycle's wall-clock time (header stamps)
  double eta[3] = {0, 0, 0};        // x_m, y_m, psi_rad in the world (odom) frame
  double zeta[3] = {0, 0, 0};       // u_mps, v_mps, r_radps in the body (base_link) frame
  bool has_cov = false;             // the EKF's covariance below (other estimators have none)
  double cov[36] = {};              // 6x6 row-major over [x, y, psi, u, v, r]
  ModuleSnapshot module[4];
  bool enabled = false;
  std::array<char, 16> mode{};
  int fault_module = -1;            // the module whose fault stopped the robot, -1 none
  std::array<char, 48> fault_reason{};
  double loop_dt_s = 0, loop_jitter_max_s = 0;
  double hook_max_us = 0;           // augerd's poll + publish, the longest over the last second
  long inputs_applied = 0, inputs_refused = 0;  // ROS 2 inputs since start
  std::array<char, 200> last_refusal{};         // why the last one was refused
  OnlineSnapshot online;
};

// Inputs since the last poll, converted to `vel`'s quantities and the sensors socket's messages
// (whose values augerd checks as a line's: daemon_lines.hpp check_command, check_sensor): the
// newest command and IMU sample (the loop uses one per cycle), but every pose, oldest first, up
// to kMaxPoses (augerd's estimator takes each, one per cycle; beyond that the oldest go).
struct Inputs {
  static constexpr int kMaxPoses = 8;
  bool has_vel = false;
  double u_mps = 0, v_mps = 0, r_radps = 0;
  int n_poses = 0;
  std::array<auger::daemon::SensorMessage, kMaxPoses> poses;  // PoseWithCovarianceStamped: with its variances
  bool has_imu = false;
  auger::daemon::SensorMessage imu;
  long received = 0;   // messages taken, the superseded ones included
  long refused = 0;    // of which the bridge refused (a malformed message; the reason below)
  std::array<char, 200> refusal{};
};

class Bridge {
 public:
  virtual ~Bridge() = default;
  // Moves the inputs received since the last call into `in`; false when there were none, or
  // when the receive thread holds them this instant (they come the next cycle). Never blocks.
  virtual bool poll(Inputs& in) = 0;
  // Hands the cycle's state to the bridge's thread when an output is due; never blocks (a
  // cycle whose copy would have to wait is skipped and counted).
  virtual void publish(const Snapshot& s) = 0;
  // One line for augerd's start-up message: domain, topics in and out.
  virtual std::string describe() const = 0;
};

// Whether this build has the bridge (built with Cyclone DDS).
bool available();
// When enabled with a dds_config: the file as Cyclone DDS will read it (a non-empty regular file,
// well-formed, <CycloneDDS> with a <Domain> for the domain id, no <Security>: that is [ros2]
// keystore's, and Cyclone accepts every element). One line per problem, naming the file; empty
// when fine. For `augerd --check` and every start (startup_check.cpp).
std::vector<std::string> check_dds_config(const Settings& s);
// Creates the participant, readers and writers. Throws std::runtime_error (no DDS, a bad
// configuration file). Built without Cyclone DDS: throws, saying how to build with it.
std::unique_ptr<Bridge> make_bridge(const Settings& s);

}  // namespace auger::ros2
