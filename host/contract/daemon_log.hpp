// augerd's log schema beyond docs/log-format.md (docs/daemon.md "The log"): the mode codes, the
// ctrl_events bits, the replay columns as one row struct (LogRow) whose columns are named in one
// table, and the rule of what each mode sends to the screws. augerd writes the rows
// (host/augerd/daemon.cpp, data_log.cpp) and applies the rule; `auger replay`
// (host/operator/replay.cpp) reads the rows back, reruns the controller and applies the same rule;
// the workbench reads the pose's capture time.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "auger/model.hpp"

namespace auger {
class CsvLogReader;
}

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

// What a mode sends to the screws (docs/daemon.md "The loop"), for augerd and `auger replay`:
// the controller's speeds in goto, follow and hold; in vel the body velocity through eq. (4),
// scaled as a whole to omega_max_rpm (the direction kept when saturated: the core's controller
// tracks poses only); in spin one module at spin_rpm, clamped; else 0. augerd applies the
// dead-man (vel and spin expire into idle) and `enable` before.
struct MotionInput {
  Mode mode = Mode::stopped;
  Vec3 vel = Vec3::Zero();  // vel: u_mps, v_mps, r_radps
  int spin_module = -1;     // spin: the module 0..3
  double spin_rpm = 0;
};
std::array<double, 4> mode_setpoints(const MotionInput& in, const std::array<double, 4>& ctrl_rpm,
                                     const Model& model, double omega_max_rpm);

// When the pose of a row was captured, on the log's t_s clock (empty: at t_s); augerd logs each
// camera pose on the row it arrived. The workbench compares the pose with the model then, and a
// fitted pose_time_offset is what remains late beyond it, as augerd's estimator subtracts it.
inline const char* pose_capture_column() { return "pose_capture_t_s"; }

// The columns augerd writes after docs/log-format.md's: what `auger replay` needs to run the
// core's estimator and controller again on the log and compare. NaN: an empty cell.
struct LogRow {
  double mode = 0;            // mode_code
  double ctrl_events = 0;     // CtrlEvent bits
  double ctrl_enabled = 0;    // 1: the core's controller is enabled after the events
  double alloc_nullspace = 0; // 1: the null-space allocator (the `allocator` command)
  double goal_x_m = NAN, goal_y_m = NAN, goal_psi_rad = NAN;  // a goto's goal, on its row
  double traj_n = NAN;        // a follow file's number (…-follow-N.waypoints), on its row
  double tm_fresh_0 = 0, tm_fresh_1 = 0, tm_fresh_2 = 0, tm_fresh_3 = 0;  // 1: new telemetry
  double pose_sx_m = NAN, pose_sy_m = NAN, pose_spsi_rad = NAN;  // the pose's standard deviations
  double pose_capture_t_s = NAN;                                 // pose_capture_column()
  double vel_u_mps = NAN, vel_v_mps = NAN, vel_r_radps = NAN;    // in mode vel
  double spin_module = NAN, spin_rpm = NAN;                      // in mode spin
  double xe_m = NAN, ye_m = NAN, psie_rad = NAN;                 // the estimate after the step
};

// Each column's name and member, in the order written.
struct LogColumn {
  const char* name;
  double LogRow::*value;
};
const std::vector<LogColumn>& log_row_columns();
// The names alone (the writers' header).
const std::vector<std::string>& replay_columns();
// With [online] enabled, after the replay columns (docs/daemon.md "Online identification"): the
// estimated terrain parameters and their standard deviations, the change detector's statistic,
// 1 in the cycle of a detected change, 1 while the fallback to the configured terrain is latched,
// and the parameters the controller uses.
const std::vector<std::string>& online_columns();
// With [control] effect_feedforward, last: the force the controller fed forward this cycle
// (docs/daemon.md "Effect feedforward"), body frame, after the clamp; 0 outside goto/follow/hold.
const std::vector<std::string>& feedforward_columns();
// The row's values in that order (values resized to the columns).
void log_row_values(const LogRow& row, std::vector<double>& values);

// Reads a row of an augerd log whose columns were found with find (require_columns first).
class LogRowReader {
 public:
  // Throws LogError naming the file and the first missing column.
  explicit LogRowReader(CsvLogReader& reader);
  LogRow row() const;  // of the reader's current line

 private:
  CsvLogReader& reader_;
  std::vector<int> index_;
};

}  // namespace auger::daemon
