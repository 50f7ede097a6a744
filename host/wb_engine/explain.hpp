// `auger explain`'s engine (docs/workbench.md "explain"): the loop compare -> diagnose -> fit ->
// diagnose ... as one search over model structures (explain.cpp and its concern files).
#pragma once

#include <string>
#include <vector>

#include "residual_tests.hpp"
#include "search.hpp"

namespace auger::wb {

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
// A library effect the final checks took out of the model (docs/workbench.md "Parsimony"), and why.
struct RemovedEffect {
  std::string effect;
  std::string why;             // plain words
  double contribution = kNaN;  // what it changed in the prediction, times the noise floor (largest channel)
  bool unconfirmed = false;    // taken out (or the paper's parameters held) by the cross-validation
  std::string reason{};        // why without what was done ("removed: ", ...): the verdict quotes it
};
// Of the effects the cross-validation took out (or the paper's parameters it held), the one that
// changed the prediction most, if by at least the noise floor: the candidate closest in size that
// the log does not confirm in form, which the verdict names (docs/workbench.md "The stop rule");
// nullptr if none.
const RemovedEffect* closest_unconfirmed(const std::vector<RemovedEffect>& removed);
// An effect the check of form took out of a model that does not fit the log (docs/workbench.md
// "Parsimony", confirmed in form): the error with and without it, and why it is no finding.
struct StandIn {
  std::string effect;
  std::string why;             // plain words: what disagrees
  double contribution = kNaN;  // as RemovedEffect::contribution
  ChannelValues ratio_with{kNaN, kNaN, kNaN, kNaN}, ratio_without{kNaN, kNaN, kNaN, kNaN};  // compare's error
};
// An effect of the final model that its step took in a near tie: the log cannot tell it from the
// alternatives, so the choice between them is no finding (docs/workbench.md "Near ties").
struct NearTie {
  std::string effect;
  std::vector<std::string> with;  // the alternatives, as their step listed them
  std::string tell_apart;         // the experiment that tells them apart
};
// A term as explain writes it out: where it acts, its form, the inputs it reads, its coefficient.
struct TermText {
  std::string dof, form;            // as the model file's [[effect]] id = "term" takes them
  std::vector<std::string> inputs;  // the vocabulary's names it reads (omega_rpm_2, u_mps, ...)
  double coefficient = kNaN;
  std::string unit;                 // of the coefficient
  std::string description;
};
// A term no library effect has, proposed from the residuals (docs/workbench.md "Discovered terms").
struct DiscoveredTerm : TermText {
  double uncertainty = kNaN;
  double contribution = kNaN;       // as RemovedEffect::contribution
  // Terms that predict as well in its place (within 2 %, refitted): the same steady speeds, which
  // the log does not tell apart (docs/workbench.md "Discovered terms", twins).
  struct Alternative : TermText {
    std::string tell_apart;
    double ratio = kNaN;  // the largest over the channels with it, as compare computes it
  };
  std::vector<Alternative> alternatives;
};
// The terms of one dof (`channel`: x, y, yaw, screw_0..3, screws) and the error compare reports
// with them and the groups listed before.
struct DiscoveredGroup {
  std::string channel;
  std::vector<DiscoveredTerm> terms;
  ChannelValues ratio_after{kNaN, kNaN, kNaN, kNaN};
};
struct ExplainResult {
  std::vector<std::string> logs;
  std::vector<ChannelValues> noise_floor;  // per log
  std::vector<ChannelValues> segment_floor;  // per log: the ratios' reference (segment_floor())
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
  std::vector<RemovedEffect> removed;       // effects of the search's structure the final checks took out
  std::vector<StandIn> stand_ins;           // possible stand-ins: not findings, out of the model
  std::vector<NearTie> near_ties;           // effects of the final model taken in a near tie
  // When no library effect fits in form: the library model's own error and the best library
  // candidate's name, and the terms proposed instead (empty: the dictionary has none either).
  bool outside_library = false;
  ChannelValues library_ratio{kNaN, kNaN, kNaN, kNaN};
  std::vector<DiscoveredGroup> discovered;
};
// logs and models: one model choice per log (its terrain); effects are shared, the paper's
// parameters are shared per terrain.
ExplainResult explain(const std::vector<Dataset>& logs, const std::vector<ModelChoice>& models,
                      const ExplainOptions& options = {});

}  // namespace auger::wb
