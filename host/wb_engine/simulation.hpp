// The workbench engine's simulation (docs/workbench.md): the model chosen for a log, run from
// its measured screw speeds, its errors against the noise floor, where it fails (windows,
// regimes) and everything `compare` reports.
#pragma once

#include <array>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "auger/dynamics.hpp"
#include "auger/model.hpp"
#include "dataset.hpp"

namespace auger::wb {

// The model to compare with: model_path (a model file) or, if empty, the paper's tables compiled
// in. Terrain `terrain`, else the log's metadata (sand if neither names one; the subcommands say
// so: host/workbench/terrain.hpp). A gantry model locks yaw (I_z huge) and takes the mass from
// `mass_kg` (default 16).
struct ModelChoice {
  Model model;
  std::string source;   // what was loaded, for reports
  std::string terrain;  // the terrain set used
  // Per model.effects: the parameters its model file marks `online = true` (augerd estimates
  // them, docs/model.md), so that a file written from this model keeps the marks.
  std::vector<std::vector<std::string>> online;
};
ModelChoice choose_model(const Dataset& data, const std::string& model_path = "", const std::string& terrain = "");
// The terrains of the paper's tables: robot (Table 3) sand, frozen_grass; gantry (Table 2) sand, gravel.
std::vector<std::string> table_terrains(bool gantry);

// How the model is run against the log.
// The longest warm-up sim_options_for gives a model with a slow time constant.
constexpr double kMaxWarm_s = 15.0;

struct SimOptions {
  double segment_s = 25.0;    // re-initialise from the measured pose every segment (<= 0: open loop)
  bool imu_heading = false;   // the paper's Fig. 9 variant: heading taken from the IMU
  int n_sub = 1;              // dynamics sub-steps per sample (the linear part is exact per step)
  double pose_delay_s = 0.0;  // pose rows show the state pose_delay_s earlier (effect pose_time_offset)
  // Each segment's start pose is refined to the mean offset of its first anchor_s of measurements
  // (a rigid shift of the segment), so one noisy pose sample does not bias a whole segment.
  double anchor_s = 2.0;
  // ... the heading from the IMU heading where the log has one (the camera's noise may wander).
  bool heading_from_imu = true;
  double warm_s = 2.0;  // the model runs this long (> 5 x I_z / D_psi) before a segment start to set its velocity
                        // (sim_options_for: at least settle_s)
  double settle_s = 0;  // five of the model's slowest time constants M / D, up to kMaxWarm_s (sim_options_for)
};

// The options a model's effects imply (pose_time_offset sets pose_delay_s).
SimOptions sim_options_for(const Model& model);

// Predicted sensor channels per sample (NaN before the first measured pose).
struct Prediction {
  std::vector<ChannelValues> pred;
  std::vector<double> force_n;  // gantry: the model's drive force along the rail (eq. (7) with effects)
  std::vector<std::size_t> segment_start;  // sample indices where segments begin
};
void simulate(const Model& model, const Dataset& data, const SimOptions& options, Prediction& out,
              std::size_t begin = 0, std::size_t end = std::numeric_limits<std::size_t>::max());
// The same into an existing prediction (out.pred sized data.size()), touching only [begin, end):
// the search simulates its training segments this way.
void simulate_range(const Model& model, const Dataset& data, const SimOptions& options, Prediction& out,
                    std::size_t begin, std::size_t end);

// Prediction error (pred - meas, headings wrapped) per channel.
struct ErrorStats {
  ChannelValues rms{kNaN, kNaN, kNaN, kNaN};
  ChannelValues ratio_to_noise{kNaN, kNaN, kNaN, kNaN};
  std::array<std::size_t, kChannels> n{};
};
ErrorStats error_stats(const Dataset& data, const Prediction& p, const ChannelValues& noise,
                       std::size_t begin = 0, std::size_t end = std::numeric_limits<std::size_t>::max());

// One-step-ahead error: from each measured pose, the model's pose one sample later.
ErrorStats one_step_error(const Model& model, const Dataset& data, const ChannelValues& noise);

// A time window and channel with its error.
struct Window {
  double t_start_s = 0, t_end_s = 0;
  int dof = 0;
  double rms = 0, ratio_to_noise = 0;
};
// Error per window of window_s, each window simulated from its own measured start pose (so a
// window shows what acts inside it, not what accumulated before). Sorted by time.
std::vector<Window> window_errors(const Model& model, const Dataset& data, const ChannelValues& noise,
                                  double window_s = 5.0, const SimOptions& options = {});
// The simulation window_errors runs (segments of window_s, shorter anchor and warm-up), so a
// report can plot the error curve its windows measure.
SimOptions window_sim_options(const SimOptions& options, double window_s = 5.0);
// The n worst (window, channel) pairs by ratio_to_noise.
std::vector<Window> worst_windows(const std::vector<Window>& windows, std::size_t n = 5);

// Error by regime: each sample is labelled from the screw speeds (motion along x, y, yaw or
// combined; speed band; accelerating / steady / coasting; direction; heading quadrant).
struct RegimeRow {
  std::string kind;   // "motion", "speed", "phase", "direction", "heading"
  std::string label;  // e.g. "x", "5-12 rpm", "accelerating", "forward", "heading -45..45 deg"
  double seconds = 0;
  ChannelValues rms{kNaN, kNaN, kNaN, kNaN};
  ChannelValues ratio_to_noise{kNaN, kNaN, kNaN, kNaN};
};
// Per-sample labels (exposed for tests): motion, speed band, phase, direction, heading (the
// nearest measured camera heading within 1 s, in a log without one the IMU's; "" if none).
struct RegimeLabels {
  std::string motion, speed, phase, direction, heading;
};
RegimeLabels classify_sample(const Model& model, const Dataset& data, std::size_t k);
std::vector<RegimeRow> error_by_regime(const Model& model, const Dataset& data, const Prediction& p,
                                       const ChannelValues& noise);

// Everything `compare` reports.
struct CompareResult {
  ModelChoice model;
  ChannelValues noise_floor{};
  NoiseColour noise_colour;  // the camera noise's colour, found against the IMU heading
  ChannelValues segment_floor{};  // the reference of the ratios (segment_floor(): the noise the anchor keeps)
  Prediction open_loop, segments, imu_heading;  // imu_heading empty without IMU heading or pose
  ErrorStats open_loop_err, segments_err, imu_heading_err, one_step_err;
  std::vector<Window> windows;  // 5 s windows
  std::vector<Window> worst;
  std::vector<RegimeRow> regimes;
};
CompareResult compare(const Dataset& data, ModelChoice model);

}  // namespace auger::wb
