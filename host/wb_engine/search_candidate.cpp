// One candidate fitted by the search (fitting.hpp): integer choices enumerated, a change time
// searched over the whole log and profiled, stick-slip from the Coulomb fit, several starts; then
// everything refitted jointly with the structure it joins.
#include "fitting.hpp"

#include <algorithm>
#include <cmath>

namespace auger::wb {
namespace search {
namespace {

constexpr const char* kCoulomb = "coulomb_friction";
constexpr const char* kStickSlip = "stick_slip_friction";

const Dataset& log_data(const Problem& pr, const Part& p) { return pr.data(p.log < 0 ? 0 : p.log); }

}  // namespace

// ---------------------------------------------------------------- one candidate
namespace {

// Starting points of the candidate (the last part): the typical size (with both signs where a
// parameter may be negative), and a larger one. Held parts keep their values.
std::vector<std::vector<Part>> starts(const std::vector<Part>& parts) {
  std::vector<std::vector<Part>> out;
  for (int variant = 0; variant < 2; ++variant) {
    std::vector<Part> s = parts;
    Part& p = s.back();
    for (int i : p.free) {
      const ParamSpec& sp = p.specs[static_cast<std::size_t>(i)];
      double v;
      if (!p.entry || sp.form) v = sp.default_value;  // paper_params: the paper's values; a form: its default
      else if (sp.log_scale) v = sp.typical * (variant == 0 ? 1.0 : 0.4);  // a limit must bite to be seen
      else if (sp.lower < 0) v = sp.typical * (variant == 0 ? 1.0 : -1.0);
      else v = sp.typical * (variant == 0 ? 1.0 : 0.3);
      if (p.id == kTerrainChange) v = variant == 0 ? 0.8 : 1.25;  // factors
      p.values[static_cast<std::size_t>(i)] = std::clamp(v, search_lower(sp), search_upper(sp));
    }
    out.push_back(std::move(s));
    if (!p.entry) break;  // paper_params: one start
  }
  return out;
}

// Stick-slip friction. Its cost over (sliding level, breakaway ratio, Stribeck speed) is
// rugged: whether a start from rest breaks away in one step or the next is a jump, and from the
// generic starts (typical levels) LM stalls in a compromise (a long, shallow decay) far from the
// truth. The Coulomb fit of the same log gives the scale of the levels: it is a sliding level
// averaged with the breakaway, so the sliding level lies at 0.6-1x of it. A coarse grid around
// it (one simulation each) picks the starts, LM refines the best few, and the Coulomb optimum
// itself (ratio 1) is one of them, so stick-slip never fits worse than the Coulomb friction it
// contains.
FitOutcome fit_stick_slip(const Problem& pr, const std::vector<Part>& held, const Part& stick, int max_iter,
                          const FitOutcome* coulomb_fit) {
  FitOutcome own;
  if (!coulomb_fit || !std::isfinite(coulomb_fit->cost)) {
    own = fit_candidate(pr, held, make_part(kCoulomb, *pr.terms.front().base, pr.data()), max_iter);
    coulomb_fit = &own;
  }
  int sims = coulomb_fit == &own ? own.sims : 0;
  std::vector<Part> base = held;
  base.push_back(stick);
  if (!std::isfinite(coulomb_fit->cost) || coulomb_fit->parts.empty() || coulomb_fit->parts.back().values.size() < 3) {
    std::vector<Part> p = base;
    FitOutcome best;
    for (const auto& s : starts(p)) {
      FitOutcome o = levenberg_marquardt(pr, s, max_iter);
      if (o.cost < best.cost) best = std::move(o);
    }
    return best;
  }
  const std::vector<double>& c = coulomb_fit->parts.back().values;  // force_x_n, force_y_n, torque_psi_nm
  auto with = [&](double level_factor, double ratio, double v_s) {
    std::vector<Part> p = base;
    Part& s = p.back();
    for (int k = 0; k < 3; ++k) s.values[static_cast<std::size_t>(k)] = level_factor * c[static_cast<std::size_t>(k)];
    s.values[3] = ratio;
    s.values[4] = v_s;
    return p;
  };
  std::vector<std::pair<double, std::vector<Part>>> grid;
  Workspace work;
  Eigen::VectorXd r;
  for (double f : {1.0, 0.85, 0.7})
    for (double ratio : {1.3, 1.7, 2.2})
      for (double v_s : {0.001, 0.0025, 0.006}) {
        std::vector<Part> p = with(f, ratio, v_s);
        ++sims;
        if (residuals(pr, p, r, work)) grid.push_back({r.squaredNorm(), std::move(p)});
      }
  std::sort(grid.begin(), grid.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::vector<Part>> seeds{with(1.0, 1.0, 0.0025)};  // the Coulomb optimum
  for (std::size_t i = 0; i < grid.size() && i < 2; ++i) seeds.push_back(grid[i].second);
  FitOutcome best;
  for (const auto& s : seeds) {
    FitOutcome o = levenberg_marquardt(pr, s, max_iter);
    sims += o.sims;
    if (o.cost < best.cost) best = std::move(o);
    if (best.r.size() && best.cost < 1.3 * static_cast<double>(best.r.size())) break;  // at the noise
  }
  best.sims = sims;
  return best;
}

// The time of a jump of the IMU heading's bias (imu_heading_bias's t_step_s). Camera heading minus
// IMU heading is the bias itself plus both sensors' noise, with no model in between, so the best
// split of it into two constant levels (least squares over every row that has both, prefix sums)
// places the jump to a frame or two, where a search over the time through the simulation would
// need a grid of fits (a cost that jumps with the time: no gradient). At least 5 % of the log on
// either side; the split must take a fifth of the difference's variance (white noise gives the
// best split of a few thousand frames about 0.1 %, a pose clock drifting by 0.2 s over the log 16
// %; an 8 mrad jump in 4 mrad of noise 30 %) and more than a line does (a drift, linear or
// settling, is fitted by imu_heading_drift; on the independent generator's logs a line took 35-89
// % of a drifting IMU's difference and more than the best split in 4 of 5). Without these, a jump
// at a random time had mended the yaw dynamics' misfit in the IMU heading of a log whose IMU had
// no bias at all. False: no such jump, or no IMU or camera heading.
bool imu_step_start(const Dataset& d, double& t_step_s) {
  std::vector<double> t, diff;
  for (std::size_t k = 0; k < d.size(); ++k) {
    const double psi = d.meas[k][kPsi], imu = d.meas[k][kImuPsi];
    if (!std::isfinite(psi) || !std::isfinite(imu)) continue;
    const double v = wrap_angle(imu - psi);
    t.push_back(d.t_s[k]);
    diff.push_back(diff.empty() ? v : diff.front() + wrap_angle(v - diff.front()));
  }
  if (diff.size() < 40) return false;
  const JumpSplit j = split_jump(t, diff, 0.05 * (t.back() - t.front()), 1);
  t_step_s = j.levels_t_s;
  return j.total_ss > 0 && j.levels_ss >= 0.2 * j.total_ss && j.levels_ss > j.line_ss;
}

// A jump of the IMU heading's bias is taken only where it lowers the cost by this share: two
// levels and a time fit a constant bias's noise better too.
constexpr double kImuStepGain = 0.02;

std::size_t param_index(const Part& p, const char* name) {
  for (std::size_t i = 0; i < p.specs.size(); ++i)
    if (p.specs[i].name == name) return i;
  return p.specs.size();
}

FitOutcome with_imu_step(const Problem& pr, FitOutcome o, std::size_t c, int max_iter) {
  const Part& p = o.parts[c];
  if (!std::isfinite(o.cost) || !p.entry || p.id != "imu_heading_bias") return o;
  const std::size_t bias = param_index(p, "bias_rad"), step = param_index(p, "t_step_s"),
                    before = param_index(p, "before_rad");
  if (std::max({bias, step, before}) >= p.values.size() || p.values[step] != 0) return o;
  double t_step_s = 0;
  if (!imu_step_start(log_data(pr, p), t_step_s)) return o;
  std::vector<Part> w = o.parts;
  w[c].values[step] = t_step_s;
  w[c].values[before] = w[c].values[bias];  // both levels from the constant's (the heading is linear in both)
  FitOutcome s = levenberg_marquardt(pr, std::move(w), max_iter);
  s.sims += o.sims;
  if (s.cost < (1 - kImuStepGain) * o.cost) return s;
  o.sims = s.sims;
  return o;
}

}  // namespace

FitOutcome fit_candidate(const Problem& pr, const std::vector<Part>& held_in, const Part& candidate, int max_iter,
                         const FitOutcome* coulomb_fit) {
  const std::vector<Part> held = frozen(held_in);
  if (candidate.id == kStickSlip && candidate.entry && candidate.values.size() == 5)
    return fit_stick_slip(pr, held, candidate, max_iter, coulomb_fit);
  std::vector<Part> parts = held;
  parts.push_back(candidate);
  const std::size_t c = parts.size() - 1;
  const Dataset& d = log_data(pr, candidate);
  // Integer parameters (which screw) are enumerated (gantry: only the two screws of the module).
  std::vector<std::vector<Part>> variants{parts};
  for (std::size_t i = 0; i < candidate.specs.size(); ++i) {
    const ParamSpec& s = candidate.specs[i];
    if (!s.integer) continue;
    const int hi = d.gantry && s.name == "screw" ? 1 : static_cast<int>(s.upper);
    std::vector<std::vector<Part>> next;
    for (const auto& v : variants)
      for (int x = static_cast<int>(s.lower); x <= hi; ++x) {
        auto w = v;
        w[c].values[i] = x;
        next.push_back(std::move(w));
      }
    variants = std::move(next);
  }
  // A change time is searched over the whole log first, on a grid of about 2.5 % of its length
  // (a local search from a few starts settled in local minima: a change placed 10 s early with
  // the factors inverted fits a stretch of the log), then refined around the two best times.
  const bool change = candidate.id == kTerrainChange;
  if (change) {
    std::vector<std::vector<Part>> next;
    const double t0 = d.t_s.front(), T = d.duration_s();
    for (const auto& v : variants)
      for (int g = 1; g < 40; ++g) {
        auto w = v;
        w[c].values[0] = t0 + T * g / 40.0;
        next.push_back(std::move(w));
      }
    variants = std::move(next);
  }
  const bool grid = variants.size() > 4;
  std::vector<FitOutcome> tried;
  int sims = 0;
  FitOutcome best;
  // A grid has one start per point, each fit independent of the others: shared with an idle
  // worker, then taken in the grid's order (the same result on any number of threads).
  if (grid) {
    std::vector<FitOutcome> at_point(variants.size());
    share_loop(variants.size(), [&](std::size_t g) {
      at_point[g] = levenberg_marquardt(pr, starts(variants[g]).front(), change ? 2 : 4);
    });
    for (FitOutcome& o : at_point) {
      sims += o.sims;
      if (change && std::isfinite(o.cost)) tried.push_back(o);
      if (o.cost < best.cost) best = std::move(o);
    }
  } else {
    for (const auto& v : variants)
      for (const auto& s : starts(v)) {
        FitOutcome o = levenberg_marquardt(pr, s, max_iter);
        sims += o.sims;
        const bool at_noise = o.r.size() && o.cost < 1.3 * static_cast<double>(o.r.size());
        if (o.cost < best.cost) best = std::move(o);
        // At the noise already (mean squared normalised residual near 1): another start cannot do
        // better than noise, so it is skipped.
        if (at_noise) break;
      }
  }
  if (change && !tried.empty()) {
    // Refine the two best grid times that are not neighbours: halving steps down to 0.1 s.
    std::sort(tried.begin(), tried.end(), [](const FitOutcome& a, const FitOutcome& b) { return a.cost < b.cost; });
    std::vector<FitOutcome> seeds{tried.front()};
    const double spacing = d.duration_s() / 40.0;
    for (const FitOutcome& o : tried)
      if (std::fabs(o.parts[c].values[0] - seeds.front().parts[c].values[0]) > 1.5 * spacing) {
        seeds.push_back(o);
        break;
      }
    for (FitOutcome s : seeds) {
      for (double step = spacing / 2; step >= 0.1; step /= 2) {
        const double tc = s.parts[c].values[0];
        for (double t : {tc - step, tc + step}) {
          auto w = s.parts;
          w[c].values[0] = t;
          FitOutcome o = levenberg_marquardt(pr, w, 2);
          sims += o.sims;
          if (o.cost < s.cost) s = std::move(o);
        }
      }
      if (s.cost < best.cost) best = std::move(s);
    }
  }
  if (grid && std::isfinite(best.cost)) {
    FitOutcome o = levenberg_marquardt(pr, best.parts, max_iter);
    sims += o.sims;
    if (o.cost <= best.cost) best = std::move(o);
  }
  best.sims = sims;
  return with_imu_step(pr, leave_plateaus(pr, std::move(best), max_iter), c, max_iter);
}

FitOutcome fit_joint(const Problem& pr, const std::vector<Part>& state, const Part& candidate, int max_iter,
                     const FitOutcome* coulomb_fit) {
  return refit_joint(pr, state, candidate, fit_candidate(pr, state, candidate, max_iter, coulomb_fit), max_iter);
}

FitOutcome research_change_times(const Problem& pr, FitOutcome o, int max_iter) {
  // A change time was placed by the candidate's own search, before the others were refitted with
  // it; with them refitted it may belong elsewhere (a change placed early with its factors
  // inverted can imitate another effect over a stretch). Searched over the whole log again with
  // the others held, then everything refitted.
  if (!std::isfinite(o.cost)) return o;
  // Once (a second round, the others refitted to the new time, moved it by less than the grid).
  for (int round = 0; round < 1; ++round) {
  bool moved_any = false;
  for (std::size_t c = 0; c < o.parts.size(); ++c) {
    if (o.parts[c].id != kTerrainChange || !o.parts[c].entry) continue;
    std::vector<Part> held = o.parts;
    held.erase(held.begin() + static_cast<std::ptrdiff_t>(c));
    FitOutcome moved = fit_candidate(pr, held, o.parts[c], 4);
    o.sims += moved.sims;
    if (!(moved.cost < o.cost) || std::fabs(moved.parts.back().values[0] - o.parts[c].values[0]) < 1e-9) continue;
    std::vector<Part> again = o.parts;
    again[c].values = moved.parts.back().values;
    FitOutcome r = refit(pr, again, max_iter, 1);
    r.sims += o.sims;
    if (r.cost < o.cost) {
      o = std::move(r);
      moved_any = true;
    } else {
      o.sims = r.sims;
    }
  }
  if (!moved_any) break;
  }
  return o;
}

FitOutcome profile_change_time(const Problem& pr, FitOutcome o, int max_iter) {
  // The time searched with the others held may still be a local minimum of the joint problem: an
  // effect fitted before the change came in has absorbed part of it (a saturation that imitates
  // the weaker traction after the change), and it holds the change where it fits around that.
  // So the time is profiled: at 15 times over the log every other parameter is refitted with it
  // (a few steps from the fit at hand), the best time is refined by halving, and the whole is
  // refitted; the result replaces the fit only if it is better.
  if (!std::isfinite(o.cost)) return o;
  for (std::size_t c = 0; c < o.parts.size(); ++c) {
    if (o.parts[c].id != kTerrainChange || !o.parts[c].entry) continue;
    const Dataset& d = log_data(pr, o.parts[c]);
    const double t0 = d.t_s.front(), T = d.duration_s(), spacing = T / 16.0;
    FitOutcome best;
    int sims = 0;
    std::vector<FitOutcome> at_time(15);
    share_loop(at_time.size(), [&](std::size_t g) {
      std::vector<Part> w = o.parts;
      w[c].values[0] = t0 + spacing * static_cast<double>(g + 1);
      at_time[g] = levenberg_marquardt(pr, std::move(w), 3);
    });
    for (FitOutcome& x : at_time) {
      sims += x.sims;
      if (x.cost < best.cost) best = std::move(x);
    }
    if (!std::isfinite(best.cost)) continue;
    for (double step = spacing / 2; step >= 0.2; step /= 2) {
      const double tc = best.parts[c].values[0];
      for (double t : {tc - step, tc + step}) {
        std::vector<Part> w = best.parts;
        w[c].values[0] = t;
        FitOutcome x = levenberg_marquardt(pr, std::move(w), 2);
        sims += x.sims;
        if (x.cost < best.cost) best = std::move(x);
      }
    }
    FitOutcome again = refit(pr, best.parts, max_iter, 1);
    sims += again.sims;
    again.sims = o.sims + sims;
    if (again.cost < o.cost) o = std::move(again);
    else o.sims += sims;
  }
  return o;
}

FitOutcome refit_joint(const Problem& pr, const std::vector<Part>& state, const Part& candidate, FitOutcome first,
                       int max_iter) {
  if (!std::isfinite(first.cost)) return first;
  // Everything free again, except integer choices and change times, which stay where the
  // candidate's own search put them.
  std::vector<Part> joint = first.parts;
  for (std::size_t p = 0; p < joint.size(); ++p) {
    const Part& original = p + 1 < joint.size() ? state[p] : candidate;
    joint[p].free = original.free;
  }
  FitOutcome o = refit(pr, joint, max_iter, 1);
  o.sims += first.sims;
  if (!(o.cost <= first.cost)) {
    first.sims = o.sims;
    o = std::move(first);
  }
  // A state whose paper parameters sit at the end of their physical range has taken up an
  // effect it lacked (sigma and D scaled up together shorten every time constant, as a yaw
  // time constant would): the structure with one more effect is also tried from the paper's
  // own values, where that effect can take its share back.
  bool at_end = false;
  for (const Part& p : o.parts) {
    if (p.entry) continue;
    for (std::size_t i = 0; i < p.values.size(); ++i) {
      const ParamSpec& sp = p.specs[i];
      const double span = search_upper(sp) - search_lower(sp);
      at_end = at_end || std::fabs(p.values[i] - search_lower(sp)) <= 1e-3 * span ||
               std::fabs(p.values[i] - search_upper(sp)) <= 1e-3 * span;
    }
  }
  // (Only when the change is the candidate: with it in the state already, its time was searched
  // when it came in, and again at the end.)
  if (candidate.id == kTerrainChange) o = profile_change_time(pr, research_change_times(pr, std::move(o), max_iter), max_iter);
  if (at_end) {
    std::vector<Part> fresh = joint;
    for (Part& p : fresh)
      if (!p.entry)
        for (std::size_t i = 0; i < p.values.size(); ++i) p.values[i] = p.specs[i].default_value;
    FitOutcome again = refit(pr, fresh, max_iter, 1);
    again.sims += o.sims;
    if (again.cost < o.cost) return again;
    o.sims = again.sims;
  }
  return o;
}

}  // namespace search
}  // namespace auger::wb
