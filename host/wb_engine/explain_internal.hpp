// `auger explain`'s engine (workbench.hpp, docs/workbench.md "explain"): the loop a
// researcher runs by hand (compare, diagnose, fit --add the best, diagnose again, ...) as one
// search over model structures. At every step each candidate is fitted jointly with everything
// chosen so far and the paper's parameters (never on top of a frozen earlier fit); an effect
// that no longer pays for itself is dropped; near ties are carried as a small beam; the loop
// stops when what remains is noise (the error at the noise floor on the held-out segments and
// over the whole log, residuals white and independent of the inputs) or when no candidate is
// significant, and then says what is left.
// Internal to the workbench engine: the Explainer class that explain.cpp (the beam loop),
// explain_search.cpp (one step: candidates fitted, the significant ones, the backward check, the
// other splits' second opinion), explain_branches.cpp (a structure's state, the paper's
// parameters, change times), explain_final.cpp (the final fit and model), explain_parsimony.cpp
// and explain_standins.cpp (the final checks), explain_discover.cpp (discovered terms) and
// explain_stop.cpp (the stop rule and the verdict) define.
#pragma once

#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "discover.hpp"
#include "explain.hpp"
#include "fitting.hpp"

namespace auger::wb::explain_internal {

using search::FitOutcome;
using search::Part;
using search::Problem;
using search::Segments;

constexpr const char* kCoulomb = "coulomb_friction";
constexpr const char* kStickSlip = "stick_slip_friction";
using search::kTerrainChange;
// A channel whose held-out error is at most this multiple of the noise floor is at the noise:
// logs with no missing effect give 1.0-1.1 (docs/workbench.md "Calibration").
constexpr double kAtNoise = 1.15;
// The verdict's noise: every channel of the final model, as compare reports it, at most this
// multiple of the noise floor (docs/workbench.md "The stop rule").
constexpr double kVerdictNoise = 1.2;
// How many times the best structure's ranked held-out error a structure may leave and still be
// carried on in the beam (docs/workbench.md "explain", 5): 1.5, and 1.25 once the best is at the
// noise floor on the held-out segments (best_heldout <= kVerdictNoise), where a worse one has
// nothing left to gain on it.
inline double beam_gap(double best_heldout) { return best_heldout <= kVerdictNoise ? 1.25 : 1.5; }
// Adding an effect must gain this much in BIC (strong evidence, Kass and Raftery) and lower the
// held-out error by this share.
constexpr double kAddBic = -10.0;
constexpr double kAddHeldout = kHeldOutGain;
// Far from the noise (a structure's held-out error at least kFarFromNoise times the floor) the
// residuals are the model's error, smooth over whole segments: their lag-1 autocorrelation is
// near 1, n_eff falls to its floor of 10, and no gain reaches kAddBic once the paper's parameters
// are re-identified with it (a slope that halved the held-out error of a log at 63 times the
// floor scored +5.7). There a candidate that lowers the held-out error by kLargeHeldout, on
// segments its fit has not seen, counts as significant (docs/workbench.md "explain", point 3).
constexpr double kFarFromNoise = 3.0;
constexpr double kLargeHeldout = 0.25;
inline bool significant_gain(double delta_bic, double h_from, double h_to) {
  if (!(h_to < h_from * (1.0 - kAddHeldout))) return false;
  return delta_bic < kAddBic || (h_from >= kFarFromNoise && h_to <= h_from * (1.0 - kLargeHeldout));
}
// Discovered terms are proposed (docs/workbench.md "Discovered terms") where they predict the 25 s
// segments kAddHeldout better than the library's model, or as well (within kAddHeldout) with fewer
// fitted parameters and no more parts (terms and effects) than its effects: those are then the less
// parsimonious account of the same force (a quadratic drag whose x and y coefficients a log turning
// on the spot does not identify, for a traction that falls with the yaw rate: one term, the same
// torque r |r|). Terms found on the paper's model alone where the library's model is at the noise
// floor in size must be simpler: there a few per cent are the noise's (three terms, sign(omega)
// on every screw, a dead band in other words, and two that fitted noise, at 1.015 times the floor
// took the place of a true dead band and offset centre at 1.038).
inline bool terms_accepted(double err_terms, int params_terms, int parts_terms, double err_library,
                           int params_library, int parts_library, bool replacing_at_noise) {
  const bool simpler = err_terms <= (1.0 + kAddHeldout) * err_library && params_terms < params_library &&
                       parts_terms <= parts_library;
  return simpler || (!replacing_at_noise && err_terms <= (1.0 - kAddHeldout) * err_library);
}
constexpr int kFolds = 3;
using FoldValues = std::array<double, kFolds>;
// An effect (or a discovered term) stays in the final model only when it changes the prediction
// by at least this share of the noise floor (RMS over every segment, in its strongest channel):
// less could not move a channel across the verdict's 1.2 (sqrt(1 + 0.5^2) = 1.12).
constexpr double kMinContribution = 0.5;
// ... and when taking it out raises the cross-validated error by this share.
constexpr double kConfirm = 0.01;

// Error ratios to the noise floor pooled over logs: per channel the sample-weighted root mean
// square, and over the channels their root mean square (the held-out error's `h`).
struct ChannelPool {
  std::array<double, kChannels> sum{}, n{};
  void add(const ErrorStats& e) {
    for (int c = 0; c < kChannels; ++c) {
      const auto cc = static_cast<std::size_t>(c);
      if (!e.n[cc] || !std::isfinite(e.ratio_to_noise[cc])) continue;
      sum[cc] += e.ratio_to_noise[cc] * e.ratio_to_noise[cc] * static_cast<double>(e.n[cc]);
      n[cc] += static_cast<double>(e.n[cc]);
    }
  }
  double combined(ChannelValues& per_channel) const {
    double all = 0;
    int k = 0;
    for (int c = 0; c < kChannels; ++c) {
      const auto cc = static_cast<std::size_t>(c);
      per_channel[cc] = n[cc] > 0 ? std::sqrt(sum[cc] / n[cc]) : kNaN;
      if (n[cc] > 0) {
        all += sum[cc] / n[cc];
        ++k;
      }
    }
    return k ? std::sqrt(all / k) : kNaN;
  }
};

struct LogCtx {
  const Dataset* full = nullptr;
  Dataset data;  // decimated for the search
  ModelChoice choice;
  Model base;    // the given model without its effects
  ChannelValues noise_floor{};  // the measurement noise (estimate_noise_floor)
  ChannelValues noise{};        // the ratios' reference (segment_floor())
  WhiteningFilter whiten;  // the camera noise's colour, for the residual tests
  Segments all;
  // Per fold (Explainer::other_splits): the segments fitted on and those judged on; fold 0 is
  // the search's split (every third segment held out), folds 1 and 2 hold out the other thirds.
  std::array<Segments, kFolds> fit, judge;
};

struct State {
  std::vector<Part> parts;  // paper_params parts (if any) and effects, in the order added
  double cost = std::numeric_limits<double>::infinity();
  int n_params = 0;
  ChannelValues held{kNaN, kNaN, kNaN, kNaN};
  double h = kNaN;
  // Its error over every segment of the search (training and held-out) per channel, where the
  // held-out error is at the noise (NaN otherwise): the held-out third alone can miss what the
  // log shows (explain_stop.cpp, at_noise).
  ChannelValues all_ratio{kNaN, kNaN, kNaN, kNaN};
  // The split it is fitted and judged on: 0, the search's; 1 or 2 for a branch taken on the
  // other splits' second opinion (Explainer::other_splits).
  int fold = 0;
  bool flagged = false, implausible = false;
  std::vector<ExplainStep> history;
  FitOutcome fit;
};

// The structure with part i taken out: an effect removed, the paper's parameters held at the
// paper's values (their alternative is the paper's model, not none). explain_parsimony.cpp.
std::vector<Part> without_part(std::vector<Part> parts, std::size_t i);
// The paper's parameters re-identified (free): checked as an effect is (parsimony, and as a
// stand-in for a discovered term), their removal being to hold them at the paper's values.
inline bool paper_free(const Part& p) { return !p.entry && !p.free.empty(); }
// The simpler form effect p reduces to when a parameter of it is not identified or not confirmed:
// stick-slip friction to Coulomb friction at its sliding level, an IMU drift to a bias, a force
// lag with a dead time to the plain lag, a dead band to the symmetric dead zone. False: none.
// explain_parsimony.cpp.
bool simpler_form(const Part& p, const Dataset& d, Part& out);
// "force_lag without its dead time", "screw_dead_band as a symmetric dead zone", or to's id.
std::string simpler_form_name(const Part& from, const Part& to);
// The largest finite value over the channels (0 when none): a contribution's size.
double largest(const ChannelValues& v);

// An effect part's label: terrain_change of one of several logs carries the log's number.
std::string label(const Part& p, std::size_t n_logs);
std::vector<std::string> effect_labels(const std::vector<Part>& parts, std::size_t n_logs);
// A structure's key (its effects' labels sorted, and whether it has the paper's parameters): two
// branches with one key are one structure.
std::string key_of(const std::vector<Part>& parts, std::size_t n_logs);

class Explainer {
 public:
  Explainer(const std::vector<Dataset>& logs, const std::vector<ModelChoice>& models, const ExplainOptions& o);

  ExplainResult run();

 private:
  void prune_beam(std::vector<State>& next, const std::vector<State>& finished) const;
  void choose_final(std::vector<State>& finished, ExplainResult& res);
  template <typename... A>
  void detail(const char* fmt, A... a) {
    if (opt_.progress_detail) progress(fmt, a...);
  }
  template <typename... A>
  void progress(const char* fmt, A... a) {
    if (!opt_.progress) return;
    std::lock_guard<std::mutex> lock(print_);
    std::fprintf(stderr, fmt, a...);
    std::fprintf(stderr, "\n");
  }

  // Ranking of structures: the held-out error, an implausible fit counted kImplausibleHeldout
  // worse (the next step takes stretched paper parameters back: from_scratch).
  static double score(const State& s) { return ranking_heldout(s.h, s.implausible); }

  static bool paper_held(const std::vector<Part>& parts) {
    for (const Part& p : parts)
      if (!p.entry && p.free.empty()) return true;
    return false;
  }

  // Library effects and discovered terms (the parts with an entry; the paper's parameters have none).
  static int effects_in(const std::vector<Part>& parts) {
    int n = 0;
    for (const Part& p : parts) n += p.entry != nullptr;
    return n;
  }
  static int effects_in(const State& s) { return effects_in(s.parts); }

  bool at_noise(const State& s) const;

  bool tests_pass(const State& s);

  // The segments a structure is fitted on, and those it is judged on (its held-out error).
  const Problem& fit_on(int fold) const { return fit_[static_cast<std::size_t>(fold)]; }
  static const Segments& fitted_on(const LogCtx& c, int fold) { return c.fit[static_cast<std::size_t>(fold)]; }
  static const Segments& judged_on(const LogCtx& c, int fold) { return c.judge[static_cast<std::size_t>(fold)]; }

  // Held-out error of a structure, pooled over the logs per channel, and its error over every
  // segment (State::all_ratio) where the held-out one is at the noise.
  void heldout(State& s) const;

  // Cost on the training segments of a structure as it stands (no fit).
  void evaluate(State& s);

  std::vector<FittedEffect> fitted_of(const State& s, double s2_scale) const;

  const Model& base_for(const Part& p) const;

  // The paper's parameters of every terrain among the logs, free, before the effects (or held at
  // the paper's values, where the structure so far holds them).
  std::vector<Part> with_paper(const std::vector<Part>& parts) const;

  struct Task {
    const State* state = nullptr;
    std::string id;
    int log = -1;  // terrain_change of one log when there are several
    int wait_for = -1;  // stick-slip waits for the Coulomb task of the same state
    FitOutcome first;   // the candidate fitted on top of the state held
    FitOutcome out;     // then everything refitted jointly
    bool joint = false;
    std::string replaces;  // stick-slip in place of the state's Coulomb friction
  };

  std::vector<Task> tasks_for(const State& s) const;

  template <typename Fn>
  void run_parallel(std::vector<Task>& tasks, const std::vector<std::size_t>& which, Fn fn) {
    search::run_parallel(opt_.threads, which, [&](std::size_t i) { return tasks[i].wait_for; }, fn);
  }

  // Two passes: every candidate fitted on top of the state held (cheap: only its own
  // parameters), then the promising ones refitted jointly with everything (the expensive part).
  // Promising: the five best by training cost on the first step (three later) and any that gains
  // at least 10 % of what the best gains.
  void run_tasks(std::vector<Task>& tasks, const State& s, int step);

  // A fit whose paper parameters end at their physical range has taken up an effect it lacked
  // (every force scaled up shortens every time constant). The same structure is refitted from
  // the paper's values and each effect's own fit on the paper's model, where each effect can
  // take its share back; the better fit is kept.
  FitOutcome from_scratch(FitOutcome o, int fold);

  // The parts with the paper's parameters back at the paper's values (held, or free) and each
  // effect at its own fit on the paper's model (the first step's), where there is one.
  std::vector<Part> paper_start(std::vector<Part> start, bool hold);

  static bool paper_at_end(const FitOutcome& o);

  // The same structure with the paper's parameters held at the paper's values, where refitted
  // they end at their range even after from_scratch: on a short log the training segments cannot
  // tell a missing effect from stretched paper parameters, so the held-out segments judge. Held
  // is a restriction: it is taken only when it predicts them better outright (not merely because
  // the stretched fit counts 15 % worse for being implausible).
  FitOutcome paper_held_alternative(FitOutcome o, int fold);

  // A structure that held the paper's parameters because the training segments alone could not
  // place them: on every segment they may be identified. Freed there, they are a candidate when
  // they stay inside their range and gain strongly (10 in BIC, as an effect must); `final_fit`
  // keeps them only if, polished, they predict the 25 s segments 2 % better than held.
  bool free_paper_on_all(const FitOutcome& o, FitOutcome& freed_out);

  // Polish on the full logs (10 ms rows, 25 s segments), as fit does; the residuals stay those of
  // the search's segments (for the BIC and the uncertainties).
  void polish(FitOutcome& o) const;

  // The error `compare --model` reports, per channel pooled over the logs (multiples of the
  // noise floor), and their root mean square over the channels.
  double compare_error(const std::vector<Part>& parts, ChannelValues* per_channel = nullptr) const;

  // A change of terrain placed on top of other effects may settle where it imitates them; the
  // time its own fit on the paper's model found (the first step's) is tried as a start too.
  FitOutcome change_from_alone(FitOutcome o, int log, int fold);

  Part candidate_part(const Task& t) const;

  // The effective sample size of o's residuals over pr.
  static double n_eff_of(const FitOutcome& o, const Problem& pr) {
    return search::effective_n(static_cast<double>(o.r.size()), search::lag1_autocorrelation(pr, o.r));
  }

  // A change of terrain that falls in a held-out segment: the training segments say only that it
  // lies somewhere in that gap (the training cost is the same anywhere in it), and a place chosen
  // at random in the gap would charge the held-out segment with up to 25 s of the wrong terrain.
  // So its place inside the gap, and only that, is read from the held-out segment.
  void place_changes_in_gaps(std::vector<Part>& parts, int fold) const;

  State make_state(const State& parent, FitOutcome o) const;

  // The residual variance of s's fit, times n / n_eff over the segments it was fitted on
  // (fit_params' s2_scale).
  double s2_scale(const State& s) const;
  // The same for an outcome fitted on every segment (1 without residuals): its parameters'
  // uncertainties, as parsimony's identification and the check of form judge them.
  std::vector<FitParam> params_on_all(const FitOutcome& o) const {
    const double n = static_cast<double>(o.r.size());
    return search::fit_params(o, o.r.size() ? o.cost / std::max(1.0, n - o.n_params) * n / n_eff_of(o, all_) : 1.0);
  }

  static double bic_change(double cost_from, int k_from, double cost_to, int k_to, double n_eff) {
    return n_eff * std::log(std::max(cost_to, 1e-300) / std::max(cost_from, 1e-300)) + (k_to - k_from) * std::log(n_eff);
  }
  static double delta_bic(const State& from, const State& to, double n_eff) {
    return bic_change(from.cost, from.n_params, to.cost, to.n_params, n_eff);
  }

  // Every candidate on top of s, jointly; the significant ones, best first, each after the
  // backward check.
  struct StepCandidates {
    std::vector<State> cands;         // each candidate's structure, fitted jointly
    std::vector<Candidate> ranked;    // its figures against the structure it grew from
    std::vector<std::string> added;   // its label
    std::vector<std::string> replaced;  // the effect it came in place of ("" none)
    double n_eff = 0;                 // the effective sample size of the best fit
  };
  bool fit_candidates(const State& s, int step, StepCandidates& out);
  std::vector<State> expand(const State& s, int step);

  // The held-out segments are a third of a log, and a structure can be lucky on them. In a
  // stick-slip log with a slope, stick-slip alone happened to predict the three held-out segments
  // well and the training ones badly; with the slope, a breakaway placed by a hair in one held-out
  // segment cost more there than the slope gained on every other segment (delta BIC -8585 on the
  // training segments). So where the held-out segments alone refuse the plausible candidate that
  // gains most in BIC, the log's two other splits give a second opinion (each holds out another
  // third): the structure so far and the candidate refitted on each split's training segments
  // and judged on its held-out ones. The candidate is taken when it passes on both as any
  // candidate must (10 in BIC, 2 % lower held-out error, plausible); its branch then stays on the
  // one that predicted it best, so that every later step is judged on segments its fits did not
  // see.
  struct OtherSplits {
    std::array<State, kFolds> parent, cand;  // refitted on fold f's training segments (f = 1, 2)
    std::array<double, kFolds> delta_bic{};
    double refused_heldout = kNaN;
    int best = 1;  // the split whose fit predicts its held-out segments best: the branch goes on there
  };
  bool other_splits(const State& s, const State& c, const std::string& id, OtherSplits& out);

  // Drops effects that no longer pay for themselves: removing one must cost more than its BIC
  // penalty and raise the held-out error, or it goes.
  State backward(State e, const std::string& just_added, double n_eff);

  // A structure refitted on every segment (change times searched again), the paper's parameters
  // freed there if that pays, polished on the full logs. False (cost infinite) if it cannot be
  // simulated or has nothing to fit.
  bool final_fit(const State& s, FitOutcome& o);

  // The final model: refitted on every segment of every log, polished on the full logs as
  // compare runs them (final_fit, or `pre` where the final choice has done that), judged as
  // compare judges it.
  void finish(const State& s, ExplainResult& res, FitOutcome* pre = nullptr);

  std::string model_file(const ExplainResult& res) const;

  // ---- the final checks (explain_parsimony.cpp, docs/workbench.md "Parsimony")
  // Per channel, how much part i changes the prediction over every segment (the rest held), as a
  // multiple of the noise floor.
  ChannelValues contribution(const std::vector<Part>& parts, std::size_t i) const;
  // 3-fold cross-validation: per fold, the error of the segments it judges by a fit on the
  // others (every segment judged once, by a fit that did not see it); NaN where a fit failed.
  FoldValues cross_validated(const std::vector<Part>& parts, std::array<std::vector<Part>, kFolds>* fits = nullptr);
  // The structure with the change of terrain parts[i] replaced by the same terrain from the log's
  // start: the paper's parameters re-identified from the change's factors. False: not a change
  // of terrain, or several logs.
  bool constant_terrain(const std::vector<Part>& parts, std::size_t i, std::vector<Part>& out) const;
  // Effects that change the prediction by less than kMinContribution of the noise floor, or
  // with a parameter the log does not identify that a simpler form (or nothing) predicts as well,
  // or whose removal does not raise the cross-validated error, leave the model (o refitted).
  void parsimony(FitOutcome& o, std::vector<RemovedEffect>& removed);
  // Parsimony's first check alone: the weakest library effect or re-identified paper parameters,
  // where it changes the prediction by less than kMinContribution of the noise floor, leave (o
  // refitted, the removal in removed; after: what the model has changed by since the final checks,
  // "with the discovered terms, "); true if one left. Run again wherever the model changes after
  // them: an effect that mended what a stand-in got wrong may have nothing left to do.
  bool drop_weakest(FitOutcome& o, std::vector<RemovedEffect>& removed, const char* after);
  // Parsimony's second check: the first library effect with a parameter flagged not identified
  // leaves, or gives way to its simpler form, where that predicts the segments within 2 % as well
  // (o refitted, the change in removed); true if one did. forms_only: only form parameters count
  // and the effect stays, run on the model as it finally stands (a polish after the checks can
  // move a form parameter where the log no longer identifies it: a force lag of 8 ms whose
  // release ran to the end of its range).
  bool simplify_unidentified(FitOutcome& o, std::vector<RemovedEffect>& removed, bool forms_only);

  // ---- the check of form (explain_standins.cpp, docs/workbench.md "Parsimony", confirmed in form)
  // Where the model leaves structure, each library effect and the paper's parameters re-identified
  // must say the same fitted on each two thirds of the segments (and the paper's parameters must
  // not sit at the end of their range, nor be re-identified where res.library_ratio, o's error,
  // is above the noise floor in size); those that do not leave the model, the largest first,
  // and are listed in res.stand_ins.
  void confirm_in_form(FitOutcome& o, ExplainResult& res);
  // Part i's paper parameter k, at the end of its range, held at the paper's value with the rest
  // refitted, where that costs at most 2 % (the log does not identify it); true when o changed.
  // at_end: what sits there ("D_y at the end of its physical range, ..."), for the reason given.
  bool hold_one_paper_param(FitOutcome& o, std::size_t i, int k, const std::string& at_end, ExplainResult& res);
  // Why o's paper parameters (part i, re-identified) are no finding where o is at the noise floor
  // in size but not in form: held at the paper's values (held: that fit), the model is still at
  // kAtNoise in every channel. "" when the log needs them.
  std::string paper_not_needed(const FitOutcome& o, std::size_t i, FitOutcome& held);
  // Why part p's folds (its fits on each two thirds of the segments) disagree with it ("" when
  // they agree); params: the fit's parameters, p's from index at.
  std::string fold_disagreement(const Part& p, const std::array<const Part*, kFolds>& folds,
                                const std::vector<FitParam>& params, std::size_t at) const;

  // ---- discovered terms (explain_discover.cpp, docs/workbench.md "Discovered terms")
  // Terms of the dictionary chosen by sparse regression of what the model o leaves; with them,
  // library effects that no longer pay leave the model (res.removed). False: none is significant.
  bool discover(FitOutcome& o, ExplainResult& res);
  // Terms of the dictionary chosen by the regression on the model base_parts, with their
  // coefficients; false: none is significant.
  bool select_terms_on(const std::vector<Part>& base_parts, const std::vector<DictionaryTerm>& dict,
                       std::vector<Part>& chosen);
  // Library effects (terms = false) or terms that the model predicts as well without (within 2 %
  // on the 25 s segments; a term also when it changes the prediction by less than
  // kMinContribution) leave, one at a time; the library effects that left are listed in stand_ins.
  FitOutcome drop_not_paying(FitOutcome with, bool terms, std::vector<RemovedEffect>* stand_ins);
  // A term of two factors gives way to one of its factors alone (a term of the dictionary) where
  // the model predicts the 25 s segments within 2 % as well with it: y: u_mps*cos2(psi_rad) on a
  // log whose heading hardly turns is y: u_mps.
  FitOutcome simpler_terms(FitOutcome with, const std::vector<DictionaryTerm>& dict);
  // A term whose coefficient's uncertainty is over half its size is not identified ("Plausibility")
  // and leaves, the rest refitted; true if any left.
  bool drop_unidentified_terms(FitOutcome& with);

  void verdict(const State& f, ExplainResult& res) const;

  ExplainOptions opt_;
  std::vector<LogCtx> ctx_;
  std::array<Problem, kFolds> fit_;  // per fold, the segments fitted on (fold 0: the training segments)
  std::array<Problem, kFolds> judge_;  // per fold, the segments judged on (held out)
  Problem all_;
  bool folds_ = true;  // every log has a segment for each fold to judge on
  std::mutex print_;
  std::vector<std::string> dropped_;
  std::map<std::string, Part> alone_;  // "id@log" -> the effect fitted alone on the paper's model
  std::mutex alone_mutex_;
  bool limit_reached_ = false;
  std::atomic<int> structures_{0};
};

}  // namespace auger::wb::explain_internal
