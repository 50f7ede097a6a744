// augerd's answer to `status` and `status all` (docs/daemon-protocol.md) as one struct: augerd
// fills it and writes it with format_status; the field tools (auger monitor, teleop, step,
// calib) read it back with parse_status instead of looking keys up by string.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace auger::daemon {

// One module's fields of `status all` (m<i>_...): its telemetry and link counters.
struct ModuleStatus {
  std::string port;
  bool lost = true;              // no valid telemetry within the timeout, or no port open
  double tm_age_s = -1;          // since the last valid telemetry (-1: none or lost)
  std::uint32_t time_ms = 0;     // the module's clock
  double omega_rpm = 0, cmd_rpm = 0, omega_cmd_rpm = 0;
  std::int32_t position_counts = 0;
  double current_a = 0, voltage_v = 0, pwm = 0;
  std::uint16_t status = 0;      // the status word (latched faults in the high byte)
  std::string faults = "none";   // the latched faults by name (auger::io::fault_bits_text)
  unsigned rx_errors = 0, encoder_errors = 0;                                // the module's
  unsigned host_crc_errors = 0, host_header_errors = 0, host_bytes_skipped = 0;  // augerd's parser's
};

struct Status {
  // `status`
  double t_s = 0;
  bool enabled = false;
  std::string mode = "stopped";      // mode_name (daemon_log.hpp)
  double x_m = 0, y_m = 0, psi_rad = 0;     // the estimate
  double xd_m = 0, yd_m = 0, psid_rad = 0;  // the reference
  std::string fault = "none";        // "none", "<module>:<reason>" or the estimator's reason
  double loop_dt_s = 0, loop_jitter_max_s = 0;
  bool arrived = false, log_ok = true;
  long poses_rejected = 0;  // camera poses the estimator's gate rejected (docs/daemon.md "Safety")
  // `status all` adds the modules, the latest sensor values and, with ROS 2, its counters.
  bool all = false;
  std::array<ModuleStatus, 4> modules;
  double imu_age_s = 0, imu_psi_rad = 0, imu_r_radps = 0;  // NaN: none received
  double imu_ax_mps2 = 0, imu_ay_mps2 = 0;  // the last imu's acceleration; NaN: it had none
  double pose_age_s = 0, cam_x_m = 0, cam_y_m = 0, cam_psi_rad = 0;
  long poses_dropped = 0;  // camera poses dropped from a full queue (docs/daemon.md "Who may command the robot")
  bool ros2 = false;
  long ros2_applied = 0, ros2_refused = 0;
  double ros2_hook_max_us = 0;
  // With [online] (docs/daemon.md "Online identification"): the believed terrain (a model-file
  // row, or "unknown"), the estimate and its SDs (sigma N/rpm, D_x D_y N/(m/s), D_psi N m/(rad/s)),
  // the change detector's statistic, the changes detected, the fallback latched. With the drag
  // held (on_drag_held) the terrain is named by sigma / D (auger::believed_terrain).
  bool online = false;
  std::string online_terrain;
  bool on_drag_held = false;
  double on_sigma_long = 0, on_sigma_lat = 0, on_D_x = 0, on_D_y = 0, on_D_psi = 0;
  double on_sd_sigma_long = 0, on_sd_sigma_lat = 0, on_sd_D_x = 0, on_sd_D_y = 0, on_sd_D_psi = 0;
  double on_cusum = 0;
  long on_changes = 0;
  bool on_fallback = false;
  // The effects' parameters the model file marks online: on_eff_<effect>.<param>=value
  // on_sd_eff_<effect>.<param>=SD, in the parameter's unit (docs/daemon-protocol.md); parsed
  // back in the order of the names.
  struct OnlineEffect {
    std::string name;  // "terrain_slope.incline_x_rad"
    double value = 0, sd = 0;
  };
  std::vector<OnlineEffect> on_effects;
  // With [control] effect_feedforward: the force fed forward in the last cycle (body frame,
  // N, N, N m; feedforward_columns() in the log).
  bool feedforward = false;
  double ff_force_x_n = 0, ff_force_y_n = 0, ff_torque_psi_nm = 0;
};

// The answer line, "status t_s=... ..." (without newline).
std::string format_status(const Status& s);
// Reads an answer line back; returns "" or what is wrong with it (a missing key, a value that is
// not a number, not a status line). `status all`'s fields are read when the line has them.
std::string parse_status(const std::string& line, Status& out);

}  // namespace auger::daemon
