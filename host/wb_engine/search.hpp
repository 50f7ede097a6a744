// The workbench engine's effect search (docs/workbench.md "How effects are fitted"): diagnose,
// fit and explain, the residual tests, the effect library, and the model file a fit writes.
// Their machinery (parts, problems, Levenberg-Marquardt) is internal: fitting.hpp.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "auger/effect.hpp"
#include "auger/model_file.hpp"
#include "dataset.hpp"
#include "simulation.hpp"

namespace auger::wb {

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
  bool held = false;                // its values held, not fitted (the paper's, where explain held them)
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
  int whitened_order = 0;  // > 0: tested after the camera noise's AR filter of that order
};
struct ResidualTests {
  int max_lag = 10;
  std::vector<ChannelResidualTest> channels;
  bool white = true, independent = true;
};
// With a whitening filter (NoiseColour::whiten) the camera's channels and the inputs are both
// filtered by it first (Box and Jenkins' prewhitening): coloured camera noise is then no finding.
ResidualTests residual_tests(const Model& model, const Dataset& data, const ChannelValues& noise,
                             const WhiteningFilter& whiten = {}, int max_lag = 10);
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
  bool paper_held = false;            // the paper's parameters held at its values, not refitted
  // The split heldout_ratio is of: 1, the search's (every third segment held out, from the
  // third on); 2 or 3 (the first or second of every three) on a branch taken on the other
  // splits' second opinion (docs/workbench.md "explain").
  int split = 1;
  // Taken on that second opinion: refused by split 1's held-out segments (refused_heldout
  // against refused_from for the structure before), it passed on splits 2 and 3 (split_heldout
  // against split_from, split_delta_bic; index 0 is split 2).
  bool second_opinion = false;
  double refused_heldout = kNaN, refused_from = kNaN;
  std::vector<double> split_heldout, split_from, split_delta_bic;
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

// The model file (docs/model.md) of a model and its fitted effects, as `fit` and `explain` write
// it (auger::write_model_file): the gantry's mass or the robot, the terrain set re-identified,
// the effects with their descriptions as comments.
ModelFile fitted_model_file(const Model& model, const Dataset& data, const std::vector<FittedEffect>& effects);

}  // namespace auger::wb
