// The workbench engine's datasets (docs/workbench.md): a robot or gantry log in memory, in the
// channels the workbench compares, and the measurement noise floor estimated from the data.
//
// Channels ("DOF" in the JSON): x, y, psi of the external pose, and imu_psi (the IMU heading,
// which the model predicts as psi plus the sensor effects). A gantry log (docs/log-format.md) is
// the robot model with yaw locked, screws 0 and 1 driven, and one active channel: x for the
// longitudinal axis, y for the lateral one (docs/model-notes.md eqs. (11)-(17)).
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "auger/log.hpp"
#include "auger/model.hpp"

namespace auger::wb {

constexpr int kChannels = 4;  // x, y, psi, imu_psi
enum Channel { kX = 0, kY = 1, kPsi = 2, kImuPsi = 3 };
const char* channel_name(int channel);  // "x", "y", "psi", "imu_psi"
const char* channel_unit(int channel);  // "m" or "rad"
using ChannelValues = std::array<double, kChannels>;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// The largest finite channel; NaN when none is.
inline double largest_finite(const ChannelValues& v) {
  double m = kNaN;
  for (double x : v)
    if (std::isfinite(x) && !(x <= m)) m = x;
  return m;
}

// A log in memory, in the columns the workbench uses.
struct Dataset {
  std::string path;
  bool gantry = false;
  std::string axis;      // gantry: "longitudinal" or "lateral"
  std::string terrain;   // metadata `terrain`, "" if absent
  double gantry_mass_kg = 16.0;
  std::vector<double> t_s;
  // Between two measured speeds of a screw less than kOmegaInterpolateS apart (a module that
  // reports at 5 Hz), linear; across a longer gap, held from the last measured value.
  std::vector<Vec4> omega_rpm;
  std::vector<ChannelValues> meas;    // x_m, y_m, psi_rad, imu_psi_rad; NaN = not measured
  std::array<bool, kChannels> active{};  // channels with at least a few measurements
  std::vector<double> force_n;        // gantry: the measured traction force along the rail (else empty)
  std::vector<double> imu_r_radps;    // robot: the IMU's yaw rate (NaN = not measured)
  // When each row's pose was captured (augerd's pose_capture_t_s; NaN: at t_s). Empty if the log
  // has no such column.
  std::vector<double> pose_t_s;
  // augerd's [online] estimate per row (its on_* columns, docs/daemon.md "Online identification"):
  // sigma_long, sigma_lat (N/rpm), D_x, D_y (N/(m/s)), D_psi (N m/(rad/s)) and their SDs. Empty if
  // the log has no such columns.
  std::vector<std::array<double, 5>> online_value, online_sd;
  std::size_t size() const { return t_s.size(); }
  double duration_s() const { return t_s.empty() ? 0 : t_s.back() - t_s.front(); }
  // A pose from external tracking (x, y); a robot log without one is compared in its IMU heading
  // alone (docs/workbench.md "A log without pose").
  bool has_pose() const { return active[kX] || active[kY]; }
};

constexpr double kOmegaInterpolateS = 1.0;

// A row a simulation can start from: a measured pose (x, y, psi); in a log without pose, a
// measured IMU heading (x and y start at 0 and are not compared).
bool is_start_row(const Dataset& data, std::size_t k);
// The pose a simulation starts from at such a row.
Vec3 start_pose(const Dataset& data, std::size_t k);


// Reads a robot or gantry log (by its `# format:`; a log without one is read as a robot log).
// Throws auger::LogError naming file, line and column.
Dataset load_dataset(const std::string& path);

// Coloured noise as an autoregressive filter over camera frames: w_k = e_k - sum_j ar[j-1]
// e_{k-j} is white (empty ar: the noise is white already). The residual tests whiten by it.
struct WhiteningFilter {
  std::vector<double> ar;
  double frame_s = 0;  // the camera's frame period the lags count
};
// Coloured camera noise (docs/workbench.md "Noise floor"): the camera heading against the IMU
// heading while the robot does not turn gives the camera's whole heading noise; factor is its
// ratio to the sample-to-sample estimate, applied to x, y and psi when above 1.25.
struct NoiseColour {
  double factor = 1.0;
  std::size_t samples = 0;  // camera/IMU pairs compared (fewer than 200: not estimated)
  bool applied = false;
  WhiteningFilter whiten;   // of the camera's noise, when applied
  // The variance of the camera noise's mean over a segment's 2 s anchor (SimOptions::anchor_s),
  // as a share of its whole variance: what the rigid shift of each segment keeps of a noise that
  // wanders (measured, not modelled: 2 s means of camera minus IMU heading). 0: not applied.
  double anchor_share = 0;
  std::size_t anchor_windows = 0;  // 2 s windows it is the variance of
};
NoiseColour camera_noise_colour(const Dataset& data, const ChannelValues& white);
// The best single jump in a series d(t) (camera minus IMU heading: an IMU bias re-initialised),
// by least squares over every split with at least margin_s and min_rows on either side (prefix
// sums, one pass). What each explanation takes of the sum of squares about the mean tells a jump
// from a drift (a line) and from noise.
struct JumpSplit {
  double total_ss = 0;      // about the mean
  double line_ss = 0;       // what a line in t takes of it
  double levels_ss = -1;    // what the best split into two constant levels takes (-1: no split)
  double levels_t_s = 0;    // that split's time, midway between its rows
  double line_jump_ss = -1; // what a line plus a jump, at the best split for both, takes (-1: none)
  std::size_t line_jump_at = 0;  // the first row after that jump
  double t0_s = 0;          // line_jump's time origin
  Eigen::Vector3d line_jump = Eigen::Vector3d::Zero();  // its offset at t0_s, slope, jump
};
JumpSplit split_jump(const std::vector<double>& t_s, const std::vector<double>& d, double margin_s,
                     std::size_t min_rows);
// The error a perfect model leaves on segments anchored on 2 s of poses, per channel: the noise
// floor, and where the camera's noise wanders, for x and y the part of it the anchor keeps,
// sqrt(1 + anchor_share) times the floor (the heading is anchored on the IMU, whose noise is
// white). The reference of every error ratio: 1.0 = only noise left.
ChannelValues segment_floor(const ChannelValues& noise_floor, const NoiseColour& colour);

// Measurement noise per channel, from the data itself: the robust spread (MAD) of each
// measured sample's deviation from the cubic through its measured neighbours, scaled for the
// neighbours' weights, times the camera's colour factor. NaN for a channel without data.
ChannelValues estimate_noise_floor(const Dataset& data, NoiseColour* colour = nullptr);
// The same estimator on one series (NaN = not measured); angles wrapped when is_angle.
double estimate_noise(const std::vector<double>& t_s, const std::vector<double>& values, bool is_angle = false);

}  // namespace auger::wb
