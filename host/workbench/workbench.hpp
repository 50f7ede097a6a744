// The model workbench's engine (issue 5, docs/workbench.md): a log as a dataset, the model
// simulated from the measured screw speeds, errors against the noise floor estimated from the
// data, where the model fails, and the effect search of `diagnose` / `fit`. The subcommands
// (compare.cpp, diagnose.cpp, fit.cpp, report.cpp) are thin shells around these functions.
//
// Channels ("DOF" in the JSON): x, y, psi of the external pose, and imu_psi (the IMU heading,
// which the model predicts as psi plus the sensor effects). A gantry log (docs/log-format.md) is
// the robot model with yaw locked, screws 0 and 1 driven, and one active channel: x for the
// longitudinal axis, y for the lateral one (docs/model-notes.md eqs. (11)-(17)).
#pragma once

#include <array>
#include <cstddef>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "auger/dynamics.hpp"
#include "auger/effect.hpp"
#include "auger/log.hpp"
#include "auger/model.hpp"
#include "auger/model_file.hpp"

namespace auger::wb {

constexpr int kChannels = 4;  // x, y, psi, imu_psi
enum Channel { kX = 0, kY = 1, kPsi = 2, kImuPsi = 3 };
const char* channel_name(int channel);  // "x", "y", "psi", "imu_psi"
const char* channel_unit(int channel);  // "m" or "rad"
using ChannelValues = std::array<double, kChannels>;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A log in memory, in the columns the workbench uses.
struct Dataset {
  std::string path;
  bool gantry = false;
  std::string axis;      // gantry: "longitudinal" or "lateral"
  std::string terrain;   // metadata `terrain`, "" if absent
  double gantry_mass_kg = 16.0;
  std::vector<double> t_s;
  std::vector<Vec4> omega_rpm;        // a gap is filled with the last measured value
  std::vector<ChannelValues> meas;    // x_m, y_m, psi_rad, imu_psi_rad; NaN = not measured
  std::array<bool, kChannels> active{};  // channels with at least a few measurements
  std::vector<double> force_n;        // gantry: the measured traction force along the rail (else empty)
  std::vector<double> imu_r_radps;    // robot: the IMU's yaw rate (NaN = not measured)
  std::size_t size() const { return t_s.size(); }
  double duration_s() const { return t_s.empty() ? 0 : t_s.back() - t_s.front(); }
};

// Reads a robot or gantry log (by its `# format:`; a log without one is read as a robot log).
// Throws auger::LogError naming file, line and column.
Dataset load_dataset(const std::string& path);

// The model to compare with: model_path (a model file) or, if empty, the shipped models
// (models/robot.toml, models/gantry.toml, found via AUGER_MODELS_DIR or next to the binary)
// or else the paper's tables compiled in. Terrain from the log's metadata (sand by default).
// A gantry model locks yaw (I_z huge) and takes the mass from `mass_kg` (default 16).
struct ModelChoice {
  Model model;
  std::string source;   // what was loaded, for reports
  std::string terrain;  // the terrain set used
};
ModelChoice choose_model(const Dataset& data, const std::string& model_path = "");

// Coloured camera noise (docs/workbench.md "Noise floor"): the camera heading against the IMU
// heading while the robot does not turn gives the camera's whole heading noise; factor is its
// ratio to the sample-to-sample estimate, applied to x, y and psi when above 1.25.
struct NoiseColour {
  double factor = 1.0;
  std::size_t samples = 0;  // camera/IMU pairs compared (fewer than 200: not estimated)
  bool applied = false;
};
NoiseColour camera_noise_colour(const Dataset& data, const ChannelValues& white);
// Measurement noise per channel, from the data itself: the robust spread (MAD) of each
// measured sample's deviation from the cubic through its measured neighbours, scaled for the
// neighbours' weights, times the camera's colour factor. NaN for a channel without data.
ChannelValues estimate_noise_floor(const Dataset& data, NoiseColour* colour = nullptr);
// The same estimator on one series (NaN = not measured); angles wrapped when is_angle.
double estimate_noise(const std::vector<double>& t_s, const std::vector<double>& values, bool is_angle = false);

// How the model is run against the log.
struct SimOptions {
  double segment_s = 25.0;    // re-initialise from the measured pose every segment (<= 0: open loop)
  bool imu_heading = false;   // the paper's Fig. 9 variant: heading taken from the IMU
  int n_sub = 1;              // dynamics sub-steps per sample (the linear part is exact per step)
  double pose_delay_s = 0.0;  // pose rows show the state pose_delay_s earlier (effect pose_time_offset)
  // Each segment's start pose is refined to the mean offset of its first anchor_s of measurements
  // (a rigid shift of the segment), so one noisy pose sample does not bias a whole segment.
  double anchor_s = 2.0;
  double warm_s = 2.0;  // the model runs this long (> 5 x I_z / D_psi) before a segment start to set its velocity
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
// Per-sample labels (exposed for tests): motion, speed band, phase, direction, heading.
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
  Prediction open_loop, segments, imu_heading;  // imu_heading empty without IMU heading data
  ErrorStats open_loop_err, segments_err, imu_heading_err, one_step_err;
  std::vector<Window> windows;  // 5 s windows
  std::vector<Window> worst;
  std::vector<RegimeRow> regimes;
};
CompareResult compare(const Dataset& data, ModelChoice model);

// ---- the effect search (diagnose, fit) ----

// A candidate the search can fit: a registry effect (or the pseudo-effect "paper_params",
// which re-identifies sigma_long, sigma_lat, D_x, D_y, D_psi of eqs. (15)-(17)).
struct FitParam {
  std::string name;
  double value = 0;
  double sigma = kNaN;  // 1-sigma uncertainty (Gauss-Newton, scaled by n_eff)
  std::string unit;
  // Why the value is not to be trusted ("" if plausible): outside the parameter's physical
  // range, at a search bound, or an uncertainty larger than the value.
  std::string flag;
};
struct FittedEffect {
  std::string effect;               // identifier, docs/workbench.md
  std::vector<FitParam> params;     // as written to a model file
  std::string description;          // plain words, e.g. "a constant force of 15 N opposing ..."
};

struct Candidate {
  FittedEffect fitted;
  double train_cost = 0;        // sum of squared noise-normalised residuals, training part
  double delta_bic = 0;         // vs the nominal model, with n_eff
  ChannelValues heldout_rms{kNaN, kNaN, kNaN, kNaN};
  double heldout_ratio = 0;     // RMS over channels of heldout_rms / noise
  bool near_tie = false;
  std::string tell_apart;       // the experiment that separates it from its near tie
  bool flagged = false;         // a parameter (its own or a refitted one) is flagged
  bool implausible = false;     // ... outside or at the end of its physical range (ranks after plausible fits)
  std::vector<FittedEffect> refitted;  // diagnose --model: the model's effects, refitted with it
};

struct DiagnoseOptions {
  std::vector<std::string> only;  // restrict to these effect ids (empty = the whole library)
  int threads = 2;
  bool progress = false;          // progress lines on stderr
};

struct DiagnoseResult {
  ModelChoice model;
  ChannelValues noise_floor{};
  ErrorStats nominal;          // segments, whole log
  double nominal_heldout_ratio = 0;
  double n_eff = 0, n = 0;
  std::vector<Candidate> candidates;  // ranked, best first
  bool significant = false;
  std::string verdict;                // plain words
  std::vector<Window> where;          // worst windows of what remains after the best candidate
  bool refits_model = false;          // the model had effects: refitted jointly with each candidate
};
// Marks neighbours in a ranking that cannot be told apart, with the experiment that would.
void mark_near_ties(std::vector<Candidate>& ranked);
DiagnoseResult diagnose(const Dataset& data, ModelChoice model, const DiagnoseOptions& options = {});

// The log as the search simulates it: rows with a pose plus enough others for steps of at most
// max_dt_s, omega averaged over each merged interval (5x fewer steps for a 20 Hz camera).
Dataset decimate_for_search(const Dataset& data, double max_dt_s = 0.05);

// `fit`: re-identify the paper's parameters together with the given effects.
struct FitResult {
  ModelChoice before, after;
  ChannelValues noise_floor{};
  ErrorStats err_before, err_after;   // segments, whole log
  std::vector<FittedEffect> effects;  // includes "paper_params" (the terrain set) first
  std::string model_toml;             // the model file text
};
FitResult fit(const Dataset& data, ModelChoice model, const std::vector<std::string>& effect_ids,
              bool progress = false);

// The effect library as the workbench knows it: registry entries plus paper_params, with the
// fitting metadata (documented in docs/workbench.md "Adding an effect").
struct LibraryEffect {
  std::string id;
  std::string summary;
  std::vector<ParamSpec> params;  // as in the registry
  std::vector<std::string> units;
  bool needs_imu = false;
  bool yaw_only = false;  // shows only with the robot's yaw and several screws (not on a gantry rail)
};
std::vector<LibraryEffect> effect_library();

// ---- residual tests (residual_tests.cpp): what a model leaves, white and independent of the
// inputs? (MATLAB's `resid` for an output-error model: the simulation error over segments of
// 25 s, each segment's mean removed.)
struct ChannelResidualTest {
  int channel = 0;
  std::size_t n = 0;            // residuals tested (fewer than 50: not tested)
  std::vector<double> acf;      // lags 1..max_lag
  double whiteness_q = 0, whiteness_limit = 0;  // Ljung-Box Q and its 1 % limit
  bool white = true;
  double independence_z = 0, independence_limit = 0;  // largest |correlation| sqrt(n) with an input
  int worst_input = 0, worst_lag = 0;  // input: drive force x, y, yaw torque (eq. (7)); lag in samples
  bool independent = true;
};
struct ResidualTests {
  int max_lag = 10;
  std::vector<ChannelResidualTest> channels;
  bool white = true, independent = true;
};
ResidualTests residual_tests(const Model& model, const Dataset& data, const ChannelValues& noise, int max_lag = 10);
std::string describe_residual_tests(const ResidualTests& t);  // plain words, "" never

// ---- explain (explain.cpp): the loop compare -> diagnose -> fit -> diagnose ... in one command.
struct ExplainOptions {
  int max_effects = 4;   // effects added at most
  int beam = 2;          // model structures carried per step (near ties are not settled greedily)
  int threads = 2;
  bool progress = false;          // a line per step on stderr
  bool progress_detail = false;   // and a line per candidate fitted
  std::vector<std::string> only;  // restrict the candidates (empty: the whole library)
};
struct ExplainStep {
  int index = 0;
  std::string added;                  // effect added at this step ("" for step 0: the model as given)
  std::vector<std::string> dropped;   // effects the backward check removed at this step
  std::vector<std::string> effects;   // the model's effects after the step, in the order added
  std::vector<FittedEffect> fitted;   // every part after the step (paper_params first), jointly fitted
  ChannelValues heldout_ratio{kNaN, kNaN, kNaN, kNaN};  // per channel, times the noise floor
  double heldout_combined = kNaN;     // RMS over channels
  double delta_bic = 0;               // against the step before
  bool flagged = false;               // an implausible or unidentified parameter
  bool implausible = false;           // a value outside or at the end of its physical range
  std::vector<Candidate> alternatives;  // candidates this step nearly chose instead (near ties)
};
struct ExplainResult {
  std::vector<std::string> logs;
  std::vector<ChannelValues> noise_floor;  // per log
  std::array<bool, kChannels> active{};    // channels any log measures
  std::vector<ExplainStep> steps;          // the path of the final model, step 0 first
  std::vector<std::string> effects;        // ids in the order added
  ChannelValues final_ratio{kNaN, kNaN, kNaN, kNaN};    // as compare --model computes it, all logs
  ChannelValues final_heldout{kNaN, kNaN, kNaN, kNaN};  // the last step's held-out ratio
  std::vector<FittedEffect> final_fitted;  // refitted on every segment, polished on the full logs
  std::vector<ResidualTests> tests;        // per log, of the final model
  std::string verdict_kind;  // "noise", "near_noise", "unexplained", "max_effects"
  std::string verdict;
  std::vector<Window> where;       // worst windows left (first log)
  std::vector<RegimeRow> regimes;  // the regimes with the largest error left (first log)
  int structures_tried = 0;        // joint fits run
  std::vector<ModelChoice> final_models;  // per log
  std::string model_toml;
};
// logs and models: one model choice per log (its terrain); effects are shared, the paper's
// parameters are shared per terrain.
ExplainResult explain(const std::vector<Dataset>& logs, const std::vector<ModelChoice>& models,
                      const ExplainOptions& options = {});

// Writes a model file (TOML, docs/model.md) for a model and its fitted effects.
std::string model_to_toml(const Model& model, const Dataset& data, const std::vector<FittedEffect>& effects);

// ---- JSON output (every command's --json prints one object) ----
class Json {
 public:
  Json& begin_object(const char* key = nullptr);
  Json& end_object();
  Json& begin_array(const char* key = nullptr);
  Json& end_array();
  Json& num(const char* key, double v);    // NaN/inf -> null
  Json& str(const char* key, const std::string& v);
  Json& boolean(const char* key, bool v);
  Json& channels(const char* key, const ChannelValues& v, const std::array<bool, kChannels>& active);
  const std::string& text() const { return out_; }

 private:
  void sep(const char* key);
  std::string out_;
  std::vector<bool> first_;
};
void json_windows(Json& j, const char* key, const std::vector<Window>& windows);

}  // namespace auger::wb
