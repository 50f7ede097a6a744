// Aligning a pose log recorded on another computer (a camera's) with a robot log: coarse by the
// logs' `t0_unix_s`, refined by cross-correlating the IMU yaw rate with the camera's heading
// rate, then the camera pose interpolated onto the robot's samples. Called by `auger merge`
// (merge.cpp) and the tests.
#pragma once

#include <string>
#include <vector>

#include "auger/log.hpp"

namespace auger::wb {

// A camera's pose track in its own clock; psi_rad is unwrapped (continuous) so that it can be
// interpolated and differentiated across +-pi.
struct PoseTrack {
  std::vector<double> t_s, x_m, y_m, psi_rad;
};

// Reads the camera log: a robot-log-format CSV with at least t_s, x_m, y_m, psi_rad (rows with
// an empty pose are skipped). Throws auger::LogError naming file, line and column.
PoseTrack read_pose_track(const std::string& path, double* t0_unix_s = nullptr, bool* has_t0 = nullptr);

struct MergeOptions {
  double max_shift_s = 30;   // search +- this around the t0_unix_s offset
  double smooth_s = 0.1;     // half-width of the rate window: camera heading differences over 2 x this
  double max_gap_s = 0.5;    // camera samples farther apart than this are not interpolated across
  std::size_t max_grid = 4000000;  // samples of the alignment grid (11 h at 10 ms); beyond: refused
};
// --max-shift is at most this (an hour: clocks further apart are not one run).
constexpr double kMaxShiftS = 3600;

// t_robot = t_camera + offset_s.
struct Alignment {
  double coarse_offset_s = 0;  // from t0_unix_s (0 if a log has none)
  bool t0_used = false;
  bool refined = false;        // false: no IMU yaw rate or no turning, coarse offset kept
  double offset_s = 0;
  double correlation = 0;      // Pearson r of the two rates at the chosen offset
  double second_peak = 0;      // best r more than 1 s away from it (ambiguity)
  double overlap_s = 0;        // time both rates are available at the chosen offset
  double grid_dt_s = 0;        // resolution of the search before sub-sample interpolation
  std::string quality;         // "good", "ambiguous", "poor", "t0 only"
  std::string note;            // why, in words
};

// A log's `t0_unix_s` metadata: a number within the bounds of a clock. Throws LogError.
double parse_t0_unix_s(const std::string& path, const MetadataEntry& m);

// robot_t_s / imu_r_radps: the robot log's times and IMU yaw rates (NaN = not measured).
// Throws std::invalid_argument when a log is too long for the alignment grid.
Alignment align_camera(const std::vector<double>& robot_t_s, const std::vector<double>& imu_r_radps,
                       const PoseTrack& camera, double coarse_offset_s, bool t0_used,
                       const MergeOptions& options = {});

// The camera pose at robot time t_s (linear in the unwrapped heading); false outside the
// camera's time or inside a gap longer than max_gap_s. psi is wrapped to (-pi, pi].
bool camera_pose_at(const PoseTrack& camera, double t_robot_s, double offset_s, double max_gap_s,
                    double& x_m, double& y_m, double& psi_rad);

}  // namespace auger::wb
