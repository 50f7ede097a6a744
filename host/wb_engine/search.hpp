// The workbench engine's effect search (docs/workbench.md "diagnose" and "fit"): diagnose, fit,
// the effect library, and the model file a fit writes. Their machinery (parts, problems,
// Levenberg-Marquardt) is internal: fitting.hpp; explain is explain.hpp.
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
  std::vector<std::pair<std::string, std::string>> texts;  // a discovered term's dof and form
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
  bool implausible = false;     // ... outside or at the end of its physical range (kImplausibleHeldout)
  std::vector<FittedEffect> refitted;  // diagnose --model: the model's effects, refitted with it
};

// A candidate lowers the held-out error when it predicts the held-out segments at least this
// share better than the model without it: the gain explain asks of a step, so that diagnose's
// first candidate is one explain could take (docs/workbench.md "diagnose", 3). One rule for the
// ranking, its groups in the text, JSON and report.
constexpr double kHeldOutGain = 0.02;
inline bool lowers_heldout(const Candidate& c, double nominal_heldout_ratio) {
  return c.heldout_ratio < (1.0 - kHeldOutGain) * nominal_heldout_ratio;
}
// An implausible fit (a value at or beyond its physical range) ranks as if its held-out error
// were this many times higher, in explain's steps and diagnose's ranking alike: a part of the
// answer often fits with the paper's parameters stretched (explain's next step takes them back),
// so it must not be ruled out, but a plausible fit of nearly the same error goes first. (Ranked
// after every plausible one, diagnose put a terrain change at 4.9 times the noise floor above
// quadratic drag at 0.96, whose coefficient sat at its range end, on a log of the independent
// generator where explain named the drag.)
constexpr double kImplausibleHeldout = 1.15;
inline double ranking_heldout(double heldout_ratio, bool implausible) {
  return heldout_ratio * (implausible ? kImplausibleHeldout : 1.0);
}

// diagnose's `significant` (docs/workbench.md "Calibration of `significant`"): the nominal model
// misses by more than 1.3 times the noise floor over every segment, or the best candidate gains
// more than 20 in BIC and removes 5 % of the held-out error. Logs without a missing effect stay
// within 1.0-1.1 times and no candidate removes more than 0.2 % of theirs, so the 5 % alone tells
// them apart; a guard that the nominal miss by 1.1 times besides had called an IMU heading drift
// (random walk, held-out 1.116 -> 1.030, delta BIC -686) not significant at a miss of 1.093 while
// explain, whose steps ask 2 %, named it.
constexpr double kNominalMissRatio = 1.3;
constexpr double kSignificantHeldout = 0.05;
inline bool diagnose_significant(double nominal_all_ratio, double nominal_heldout_ratio, double best_heldout_ratio,
                                 double best_delta_bic) {
  return nominal_all_ratio > kNominalMissRatio ||
         (best_delta_bic < -20 && best_heldout_ratio < nominal_heldout_ratio * (1.0 - kSignificantHeldout));
}

struct DiagnoseOptions {
  std::vector<std::string> only;  // restrict to these effect ids (empty = the whole library)
  int threads = 2;
  bool progress = false;          // progress lines on stderr
};

struct DiagnoseResult {
  ModelChoice model;
  ChannelValues noise_floor{};
  ChannelValues segment_floor{};  // the ratios' reference (segment_floor(), dataset.hpp)
  ErrorStats nominal;          // segments, whole log
  double nominal_heldout_ratio = 0;
  double nominal_all_ratio = 0;  // over every segment of the search (the nominal fits nothing)
  double n_eff = 0, n = 0;
  std::vector<Candidate> candidates;  // ranked, best first
  bool significant = false;
  std::string verdict;                // plain words
  std::vector<Window> where;          // worst windows of what remains after the best candidate
  bool refits_model = false;          // the model had effects: refitted jointly with each candidate
};
// diagnose's ranking (docs/workbench.md "diagnose", 3): the indices of c, best first.
std::vector<std::size_t> ranking_order(const std::vector<Candidate>& c, double nominal_heldout_ratio);
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
  ChannelValues segment_floor{};  // the ratios' reference (segment_floor(), dataset.hpp)
  ErrorStats err_before, err_after;   // segments, whole log
  std::vector<FittedEffect> effects;  // includes "paper_params" (the terrain set) first
  std::string model_toml;             // the model file text
};
// terms: discovered terms to fit as well, each (dof, form) of auger/term_form.hpp (`fit --add-term`).
// hold: parameters of paper_params kept at the model's values (`fit --hold`, e.g. D_x, D_y, D_psi
// as augerd's online estimate holds them); an unknown name throws std::invalid_argument.
// threads: the fit's simulations share them (the same answer on any number).
FitResult fit(const Dataset& data, ModelChoice model, const std::vector<std::string>& effect_ids,
              bool progress = false, const std::vector<std::pair<std::string, std::string>>& terms = {},
              const std::vector<std::string>& hold = {}, int threads = 2);

// The effect library as the workbench knows it: registry entries plus paper_params, with the
// fitting metadata (documented in docs/workbench.md "Adding an effect").
struct LibraryEffect {
  std::string id;
  std::string summary;
  std::vector<ParamSpec> params;  // as in the registry
  std::vector<std::string> units;
  bool needs_imu = false;
  bool yaw_only = false;  // shows only with the robot's yaw and several screws (not on a gantry rail)
  // A robot log without pose (only the IMU heading compared): the effect cannot be seen at all,
  // or these of its parameters (along x and y only) are held at their defaults.
  bool needs_pose = false;
  std::vector<std::string> held_without_pose;
};
std::vector<LibraryEffect> effect_library();

// The model file (docs/model.md) of a model and its fitted effects, as `fit` and `explain` write
// it (auger::write_model_file): the gantry's mass or the robot, the terrain set re-identified,
// the effects with their descriptions as comments, and `online = true` on the parameters
// `online` (aligned with model.effects, ModelChoice::online) names.
ModelFile fitted_model_file(const Model& model, const Dataset& data, const std::vector<FittedEffect>& effects,
                            const std::vector<std::vector<std::string>>& online = {});

}  // namespace auger::wb
