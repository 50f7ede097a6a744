// augerd's log schema beyond docs/log-format.md (docs/daemon.md "The log"): the mode codes, the
// ctrl_events bits and the replay columns. augerd writes them (host/augerd/data_log.cpp,
// daemon.cpp); `auger replay` (host/operator/replay.cpp) reads them back and reruns the controller.
#pragma once

#include <string>
#include <vector>

namespace auger::daemon {

// augerd's mode (docs/daemon.md "The loop"): its name in `status`, its code in the `mode` column.
enum class Mode { stopped = 0, idle = 1, vel = 2, go_to = 3, follow = 4, hold = 5, spin = 6 };

inline const char* mode_name(Mode m) {
  switch (m) {
    case Mode::stopped: return "stopped";
    case Mode::idle: return "idle";
    case Mode::vel: return "vel";
    case Mode::go_to: return "goto";
    case Mode::follow: return "follow";
    case Mode::hold: return "hold";
    case Mode::spin: return "spin";
  }
  return "?";
}

// The log's `mode` column.
inline int mode_code(Mode m) { return static_cast<int>(m); }

// The controller tracks poses in these (allocator and spin are refused then).
inline bool tracking(Mode m) { return m == Mode::go_to || m == Mode::follow || m == Mode::hold; }

// Bits of the `ctrl_events` column: what changed the core controller's state this cycle, before
// its step, so that a replay applies the same changes in the same cycle.
enum CtrlEvent : int { kEvDisabled = 1, kEvWaypoints = 2, kEvRebuilt = 4 };

// When the pose of a row was captured, on the log's t_s clock (empty: at t_s); augerd logs each
// camera pose on the row it arrived. The workbench compares the pose with the model then, and a
// fitted pose_time_offset is what remains late beyond it, as augerd's estimator subtracts it.
inline const char* pose_capture_column() { return "pose_capture_t_s"; }

// The columns augerd writes after docs/log-format.md's: what `auger replay` needs to run the
// core's estimator and controller again on the log and compare.
inline const std::vector<std::string>& replay_columns() {
  static const std::vector<std::string> cols = {
      "mode",      "ctrl_events", "ctrl_enabled", "alloc_nullspace", "goal_x_m",  "goal_y_m",
      "goal_psi_rad", "traj_n",   "tm_fresh_0",  "tm_fresh_1",      "tm_fresh_2", "tm_fresh_3",
      "pose_sx_m", "pose_sy_m",   "pose_spsi_rad", pose_capture_column(), "vel_u_mps",     "vel_v_mps", "vel_r_radps",
      "spin_module", "spin_rpm",  "xe_m",        "ye_m",            "psie_rad"};
  return cols;
}

// With [online] enabled, after the replay columns (docs/daemon.md "Online identification"): the
// estimated terrain parameters and their standard deviations, the change detector's statistic,
// 1 in the cycle of a detected change, 1 while the fallback to the configured terrain is latched,
// and the parameters the controller uses.
inline const std::vector<std::string>& online_columns() {
  static const std::vector<std::string> cols = {
      "on_sigma_long",    "on_sigma_lat",    "on_D_x",    "on_D_y",    "on_D_psi",
      "on_sd_sigma_long", "on_sd_sigma_lat", "on_sd_D_x", "on_sd_D_y", "on_sd_D_psi",
      "on_cusum",         "on_change",       "on_fallback",
      "ctl_sigma_long",   "ctl_sigma_lat",   "ctl_D_x",   "ctl_D_y",   "ctl_D_psi"};
  return cols;
}

}  // namespace auger::daemon
