// The effect search's machinery (search.hpp is its public side), shared by diagnose and fit
// (search.cpp, search_diagnose.cpp) and explain (explain.cpp); internal to the workbench engine
// (docs/workbench.md "diagnose", point 1).
// A model under test is a list of Parts (the paper's parameters, library effects), fitted by
// simulation error over segments of one or more logs (a Problem) with Levenberg-Marquardt.
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "search.hpp"

namespace auger::wb::search {

using Segments = std::vector<std::pair<std::size_t, std::size_t>>;
constexpr const char* kPaperParams = "paper_params";
constexpr const char* kTerrainChange = "terrain_change";

// One effect (or paper_params) in a fit: its full parameter values and which are free.
struct Part {
  std::string id;
  const EffectRegistry::Entry* entry = nullptr;  // null for paper_params
  std::vector<ParamSpec> specs;
  std::vector<double> values;  // current full values
  std::vector<int> free;       // indices into values that Gauss-Newton moves
  int log = -1;                // the log it applies to (-1: every log of the problem)
  std::string terrain;         // paper_params: the terrain set it re-identifies
  std::vector<std::string> texts;  // text parameters (a discovered term's dof and form)
  std::vector<double> at_least;    // per parameter: a lower bound from a stalled robot (settle_stalls; 0 none)
  std::vector<std::string> online;  // parameters its model file marks `online = true` (ModelChoice::online)
};

// A part for an effect id (or paper_params) at its defaults; the free parameters are those the
// data can move (a gantry moves one DOF). Throws std::invalid_argument on an unknown id.
Part make_part(const std::string& id, const Model& base, const Dataset& d);
// A discovered term (auger/term_form.hpp) as a part: its coefficient free, typical_coefficient the
// size its fit starts from and scales by. Throws std::invalid_argument on a bad dof or form.
Part make_term_part(const std::string& dof, const std::string& form, double typical_coefficient);
// The parts of a model's own effects, at the model's values (so they can be refitted), with
// their marks (ModelChoice::online, aligned with model.effects; empty: none).
std::vector<Part> parts_of(const Model& model, const Dataset& d,
                           const std::vector<std::vector<std::string>>& online = {});
// The model without its effects (the base the parts are applied to).
Model without_effects(const Model& model);
// The model with the parts that apply to log `log` (paper_params replaces the terrain set, the
// effects are added after the base model's own).
Model build(const Model& base, const std::vector<Part>& parts, int log = 0);
// The online marks of build(base, parts, log)'s effects, in its order: base_online (aligned with
// base.effects) then each part's own, so an effect the fit dropped takes its marks with it.
std::vector<std::vector<std::string>> online_marks(const std::vector<std::vector<std::string>>& base_online,
                                                   std::size_t base_effects, const std::vector<Part>& parts,
                                                   int log = 0);
// Parts with nothing free (held while other parts are fitted).
std::vector<Part> frozen(std::vector<Part> parts);

// One log's share of a problem: its segments and the residuals' (sample, channel) index.
struct LogTerm {
  const Dataset* data = nullptr;
  const Model* base = nullptr;
  ChannelValues noise{};
  Segments segs;
  std::vector<std::pair<std::size_t, int>> index;
  SimOptions options;
  int log = 0;
  // Gantry: the load cell's force is a second measurement of the drive force (eq. (7) with the
  // drive effects): a dead band, lag or saturation changes it, friction does not. Its residuals
  // follow the pose residuals, normalised by its own noise floor.
  std::vector<std::size_t> force_index;
  double force_noise = kNaN;
  std::size_t size() const { return index.size() + force_index.size(); }
};
struct Problem {
  std::vector<LogTerm> terms;
  std::size_t size() const;
  const Dataset& data(int log = 0) const;
};

// Segments of about segment_s, each starting at a measured pose.
Segments make_segments(const Dataset& d, double segment_s);
// Segment length of the search: 25 s, or a seventh of a short log, at least 5 s.
double search_segment_s(const Dataset& data);
// Training and held-out segments, interleaved (every third held out), so that something that
// starts at some time (a terrain change) is in both.
void split_segments(const Segments& all, Segments& train, Segments& held);
// The problem over `segs` of the decimated log `data` of `full` (the force noise from the full
// log); add_log adds one more log to it.
Problem make_problem(const Dataset& data, const Dataset& full, const Model& base, const ChannelValues& noise,
                     Segments segs);
void add_log(Problem& pr, const Dataset& data, const Dataset& full, const Model& base, const ChannelValues& noise,
             Segments segs, int log);
void build_index(LogTerm& t);

using Workspace = std::vector<Prediction>;
// Noise-normalised residuals of the model with the parts applied, all logs one after the other;
// false if the model cannot be built (a parameter outside what the effect accepts).
bool residuals(const Problem& pr, const std::vector<Part>& parts, Eigen::VectorXd& r, Workspace& work);

struct FitOutcome {
  std::vector<Part> parts;
  double cost = std::numeric_limits<double>::infinity();
  Eigen::MatrixXd JtJ;  // at the optimum, internal coordinates
  Eigen::VectorXd r;
  int n_params = 0;     // identifiable free parameters
  int sims = 0;
};
FitOutcome levenberg_marquardt(const Problem& pr, std::vector<Part> parts, int max_iter);
// Whether levenberg_marquardt keeps the fit with its forms held at their defaults (sized, its cost
// sized_cost) over the one with them freed (out): where every freed form stayed within 5 % of its
// typical size from its default, or one ran to the end of its physical range while the cost fell
// by less than a fifth, or freeing them gained nothing.
bool keep_sized_fit(const std::vector<Part>& sized, double sized_cost, const FitOutcome& out);
// The bounds of the search: a parameter's own bounds and its physical range, the stricter.
double search_lower(const ParamSpec& s);
double search_upper(const ParamSpec& s);
// Whether v lies at a bound: within a thousandth of it for a log-scale parameter, else of its
// physical range (of its typical size where that range is open).
bool near_bound(const ParamSpec& s, double v, double bound);
// -1 (+1) where v lies at the lower (upper) end of a physical range that is stricter than the
// parameter's own bounds; 0 elsewhere. The effect's own bounds are definitions (a breakaway ratio of 1 is Coulomb
// friction, a force limit of 1e6 N none), not ends a fit runs into.
int physical_end(const ParamSpec& s, double v);
// Levenberg-Marquardt restarted with a fresh damping while it still gains (a stalled step is
// often a poor finite-difference direction, not the optimum).
FitOutcome refit(const Problem& pr, std::vector<Part> parts, int max_iter, int restarts = 3);
// A size left on a plateau where the model's robot is stalled and the log's is not (its column
// of the Jacobian zero, the fit better at its lower end) is started again from that end.
FitOutcome leave_plateaus(const Problem& pr, FitOutcome o, int max_iter);
// A stalled robot: a free size (a friction level, a dead band, a blocking force) that the log
// cannot see above some value (any larger one predicts the same, the robot stuck as it is) is
// moved down near the lowest value that predicts the same, that value recorded as a lower bound
// (at_least).
FitOutcome settle_stalls(const Problem& pr, FitOutcome o);

// The best fit of the last part with the parts before it held, over integer choices (which
// screw), a change time searched over the whole log first, and several starts. coulomb_fit: the
// Coulomb friction fit of the same problem and held parts (stick-slip starts from it).
FitOutcome fit_candidate(const Problem& pr, const std::vector<Part>& held, const Part& candidate, int max_iter,
                         const FitOutcome* coulomb_fit = nullptr);
// The candidate fitted on top of `state`, then everything (integers and change times kept)
// refitted jointly: how a candidate is judged once other effects are in the model.
FitOutcome fit_joint(const Problem& pr, const std::vector<Part>& state, const Part& candidate, int max_iter,
                     const FitOutcome* coulomb_fit = nullptr);
// Change times (terrain_change) searched over the whole log again with the other parts held at
// o's values, then everything refitted; the better fit is returned.
FitOutcome research_change_times(const Problem& pr, FitOutcome o, int max_iter);
// Each change time profiled: every other parameter refitted at times over the whole log.
FitOutcome profile_change_time(const Problem& pr, FitOutcome o, int max_iter);
// fit_joint's second half: everything refitted from `first`, fit_candidate's result.
FitOutcome refit_joint(const Problem& pr, const std::vector<Part>& state, const Part& candidate, FitOutcome first,
                       int max_iter);

// Runs fn(i) for every index of `which` on `threads` threads (the caller's included); an index
// whose wait_for is another index (>= 0) starts only when that one is done. The first exception
// of a task is rethrown to the caller once every thread has ended (tasks not started by then are
// skipped).
void run_parallel(int threads, const std::vector<std::size_t>& which, const std::function<int(std::size_t)>& wait_for,
                  const std::function<void(std::size_t)>& fn);
// Runs fn(i) for i in [0, n) on the calling thread, with any worker of run_parallel that has no
// task of its own left helping: a long task's independent fits (a change time's grid) then use
// the thread that would idle. fn(i) must touch only what is its own (its result slot).
void share_loop(std::size_t n, const std::function<void(std::size_t)>& fn);

// Lag-1 autocorrelation of residuals, within each (log, segment, channel) run.
double lag1_autocorrelation(const Problem& pr, const Eigen::VectorXd& r);
// n (1 - rho) / (1 + rho), at least min(n, 10).
double effective_n(double n, double rho);
double combined_ratio(const ErrorStats& e, const Dataset& d);
ErrorStats segments_error(const Model& m, const Dataset& d, const Segments& segs, const ChannelValues& noise);
// A terrain change of log `log` whose time falls in a segment judged but not fitted is placed
// inside that gap where the judged segment puts it (explain's steps and diagnose's candidates).
void place_changes_in_gaps(std::vector<Part>& parts, const Model& base, const Dataset& data, const Segments& fitted,
                           const Segments& judged, const ChannelValues& noise, int log);
// Parameter values with 1-sigma uncertainties (Gauss-Newton covariance, times s2_scale).
std::vector<FitParam> fit_params(const FitOutcome& o, double s2_scale);
std::string describe(const Part& p, const Model& base);
// p as reported: its id, its parameters (the next p.specs.size() of `all`, from k on; k advances),
// its description, and whether it was held at its values.
FittedEffect fitted_effect(const Part& p, const Model& base, const std::vector<FitParam>& all, std::size_t& k);
// Which experiment separates two effects that explain a log equally well.
std::string tell_apart(const std::string& a, const std::string& b);
// The library's candidates for this log (effects that need an IMU heading only with one; a
// gantry log gets no yaw effects).
std::vector<std::string> candidate_ids(const Dataset& d, const std::vector<std::string>& only = {});
// Flags of implausible or unidentifiable values (docs/workbench.md "Plausibility").
void flag_params(std::vector<FitParam>& params, const Part& part);
bool any_flag(const std::vector<FitParam>& params);
// A flag that makes a fit implausible (outside or at the end of a physical range), as opposed
// to an unidentified parameter (an effect that fitted as a simpler one it contains).
bool any_implausible(const std::vector<FitParam>& params);

}  // namespace auger::wb::search
