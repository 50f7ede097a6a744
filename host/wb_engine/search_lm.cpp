// Levenberg-Marquardt on the search's problems (fitting.hpp): finite-difference Jacobians in
// internal coordinates (a parameter over its typical size, or its log), the search kept inside
// each parameter's physical range, and the Gauss-Newton covariance of a fit's parameters.
#include "fitting.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>

namespace auger::wb {
namespace search {
namespace {

// Internal coordinates: value = typical * z, or exp(z) for log-scale parameters.
double to_value(const ParamSpec& s, double z) { return s.log_scale ? std::exp(z) : s.typical * z; }
double to_internal(const ParamSpec& s, double v) { return s.log_scale ? std::log(std::max(v, 1e-300)) : v / s.typical; }
double dvalue_dz(const ParamSpec& s, double z) { return s.log_scale ? std::exp(z) : s.typical; }

struct FreeRef {
  int part, index;
};

std::vector<FreeRef> free_refs(const std::vector<Part>& parts) {
  std::vector<FreeRef> f;
  for (std::size_t p = 0; p < parts.size(); ++p)
    for (int i : parts[p].free) {
      // A parameter that acts only while another is nonzero (ParamSpec::acts_with) has no gradient
      // while that one is 0: a column of zeros, and an uncertainty of infinity.
      const int with = parts[p].specs[static_cast<std::size_t>(i)].acts_with;
      if (with >= 0 && parts[p].values[static_cast<std::size_t>(with)] == 0) continue;
      f.push_back({static_cast<int>(p), i});
    }
  return f;
}

void set_z(std::vector<Part>& parts, const std::vector<FreeRef>& f, const Eigen::VectorXd& z) {
  for (std::size_t j = 0; j < f.size(); ++j) {
    Part& p = parts[static_cast<std::size_t>(f[j].part)];
    const ParamSpec& s = p.specs[static_cast<std::size_t>(f[j].index)];
    p.values[static_cast<std::size_t>(f[j].index)] =
        std::clamp(to_value(s, z[static_cast<Eigen::Index>(j)]), search_lower(s), search_upper(s));
  }
}

Eigen::VectorXd get_z(const std::vector<Part>& parts, const std::vector<FreeRef>& f) {
  Eigen::VectorXd z(static_cast<Eigen::Index>(f.size()));
  for (std::size_t j = 0; j < f.size(); ++j) {
    const Part& p = parts[static_cast<std::size_t>(f[j].part)];
    z[static_cast<Eigen::Index>(j)] = to_internal(p.specs[static_cast<std::size_t>(f[j].index)],
                                                  p.values[static_cast<std::size_t>(f[j].index)]);
  }
  return z;
}

}  // namespace

// The search stays inside a parameter's physical range as well as its bounds: outside it the
// fit trades one effect against another (sigma and D scaled up together imitate a shorter yaw
// time constant) and the values mean nothing. A value at such a bound is flagged.
double search_lower(const ParamSpec& s) { return std::max(s.lower, s.physical_lower); }
double search_upper(const ParamSpec& s) { return std::min(s.upper, s.physical_upper); }

bool near_bound(const ParamSpec& s, double v, double bound) {
  const double span = s.physical_upper - s.physical_lower;
  const double tol = s.log_scale ? 1e-3 * std::fabs(bound) : 1e-3 * (std::isfinite(span) ? span : std::fabs(s.typical));
  return std::fabs(v - bound) <= tol;
}

int physical_end(const ParamSpec& s, double v) {
  if (s.physical_lower > s.lower && near_bound(s, v, s.physical_lower)) return -1;
  if (s.physical_upper < s.upper && near_bound(s, v, s.physical_upper)) return 1;
  return 0;
}

namespace {

// A form at the end of its physical range is kept only where its cost is at most this multiple
// of the default form's.
constexpr double kFormAtEndGain = 0.8;

FitOutcome lm_free(const Problem& pr, std::vector<Part> parts, int max_iter) {
  FitOutcome out;
  Workspace work;
  const std::vector<FreeRef> f = free_refs(parts);
  const auto P = static_cast<Eigen::Index>(f.size());
  Eigen::VectorXd z = get_z(parts, f);
  set_z(parts, f, z);  // clamp the start into the bounds
  z = get_z(parts, f);
  Eigen::VectorXd r;
  if (!residuals(pr, parts, r, work)) return out;
  ++out.sims;
  double cost = r.squaredNorm();
  Eigen::MatrixXd J(r.size(), P);
  double lambda = 1e-3;
  bool have_j = false;
  std::vector<Workspace> col_work(static_cast<std::size_t>(P));  // one per column: each its own thread's
  for (int it = 0; it < max_iter && P > 0; ++it) {
    // Forward differences; steps of a few % of a typical value (hard effects such as dry
    // friction are piecewise smooth: a larger step sees their slope, not their kinks).
    // The columns are independent simulations: shared with an idle worker (each column its
    // own; the same Jacobian on any number of threads).
    std::vector<char> simulated(static_cast<std::size_t>(P), 0);
    share_loop(static_cast<std::size_t>(P), [&](std::size_t col) {
      const auto j = static_cast<Eigen::Index>(col);
      Eigen::VectorXd zj = z;
      const double h = 0.03 * std::max(1.0, std::fabs(z[j]));
      zj[j] += h;
      std::vector<Part> pj = parts;
      set_z(pj, f, zj);
      const double actual = get_z(pj, f)[j] - z[j];  // the bound may cut the step
      Eigen::VectorXd rj;
      if (std::fabs(actual) < 1e-12 || !residuals(pr, pj, rj, col_work[col])) {
        zj[j] = z[j] - h;
        set_z(pj, f, zj);
        const double back = get_z(pj, f)[j] - z[j];
        if (std::fabs(back) < 1e-12 || !residuals(pr, pj, rj, col_work[col])) {
          J.col(j).setZero();
          return;
        }
        J.col(j) = (rj - r) / back;
      } else {
        J.col(j) = (rj - r) / actual;
      }
      simulated[col] = 1;
    });
    for (char c : simulated) out.sims += c;
    have_j = true;
    const Eigen::MatrixXd A = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * r;
    bool improved = false;
    for (int tries = 0; tries < 6; ++tries) {
      Eigen::MatrixXd Al = A;
      for (Eigen::Index j = 0; j < P; ++j) Al(j, j) += lambda * std::max(A(j, j), 1e-9);
      const Eigen::VectorXd step = Al.ldlt().solve(-g);
      if (!step.allFinite()) {
        lambda *= 10;
        continue;
      }
      std::vector<Part> trial = parts;
      set_z(trial, f, z + step);
      Eigen::VectorXd rt;
      if (!residuals(pr, trial, rt, work)) {
        lambda *= 10;
        continue;
      }
      ++out.sims;
      const double ct = rt.squaredNorm();
      if (ct < cost) {
        const double gain = (cost - ct) / std::max(cost, 1e-300);
        parts = std::move(trial);
        z = get_z(parts, f);
        r = std::move(rt);
        cost = ct;
        lambda = std::max(lambda / 5, 1e-7);
        improved = true;
        if (gain < 1e-5) it = max_iter;  // converged
        break;
      }
      lambda *= 8;
    }
    if (!improved) break;
  }
  out.parts = std::move(parts);
  out.cost = cost;
  out.r = std::move(r);
  if (P > 0 && have_j) out.JtJ = J.transpose() * J;
  // Parameters the data cannot see (a zero Jacobian column) do not count in the BIC.
  double amax = 0;
  for (Eigen::Index j = 0; j < out.JtJ.rows(); ++j) amax = std::max(amax, out.JtJ(j, j));
  for (Eigen::Index j = 0; j < out.JtJ.rows(); ++j) out.n_params += out.JtJ(j, j) > 1e-8 * amax && amax > 0;
  return out;
}

}  // namespace

bool keep_sized_fit(const std::vector<Part>& sized, double sized_cost, const FitOutcome& out) {
  // Forms that end within 5 % of their typical size from their defaults are the default forms,
  // and the sized fit, which holds them there exactly, is kept: a dry friction's tanh reached over
  // 0.1 mm/s is its hard sign, but creeps, so a level the stalled robot bounds only from below
  // (settle_stalls) ran to the end of its range instead. Every part is looked at: in a joint
  // refit, one part's form that moved must not hide another's run to its end.
  bool near_default = std::isfinite(out.cost), at_end = false;
  for (std::size_t p = 0; p < out.parts.size(); ++p)
    for (int i : out.parts[p].free) {
      const ParamSpec& s = out.parts[p].specs[static_cast<std::size_t>(i)];
      if (!s.form || std::find(sized[p].free.begin(), sized[p].free.end(), i) != sized[p].free.end()) continue;
      const double v = out.parts[p].values[static_cast<std::size_t>(i)];
      near_default = near_default && std::fabs(v - s.default_value) <= 0.05 * std::fabs(s.typical);
      const int end = physical_end(s, v);
      at_end = at_end || (end != 0 && end != physical_end(s, s.default_value));
    }
  // A form freed to the end of its physical range that gains little is no form the log identifies
  // (a force lag's release run to 0.1 of its build-up beside a pose clock that drifts took the
  // candidate out of the search's beam): the default form, sized, is kept. One that takes a fifth
  // of the cost or more is the form the log has, only larger than the range allows (soil of 4
  // times the robot's mass moved sideways, fitted at 3, the end).
  at_end = at_end && out.cost > kFormAtEndGain * sized_cost;
  return near_default || at_end || !(out.cost < sized_cost);
}

FitOutcome levenberg_marquardt(const Problem& pr, std::vector<Part> parts, int max_iter) {
  // An effect whose form parameters (ParamSpec::form) are still at their defaults is fitted in
  // size first, its form held, then in everything: freed together from a wrong size, a dead band's
  // asymmetry took up what its width should have (width 0.83 rpm, asymmetry 0.67 for a symmetric
  // band of 2 rpm beside Coulomb friction, 1.9 times the noise floor).
  std::vector<Part> sized = parts;
  bool staged = false;
  for (Part& p : sized) {
    bool at_default = true, any_form = false;
    for (int i : p.free) {
      const ParamSpec& s = p.specs[static_cast<std::size_t>(i)];
      if (!s.form || (s.acts_with >= 0 && p.values[static_cast<std::size_t>(s.acts_with)] == 0)) continue;
      any_form = true;
      at_default = at_default && p.values[static_cast<std::size_t>(i)] == s.default_value;
    }
    if (!any_form || !at_default) continue;
    p.free.erase(std::remove_if(p.free.begin(), p.free.end(),
                                [&](int i) { return p.specs[static_cast<std::size_t>(i)].form; }),
                 p.free.end());
    staged = true;
  }
  if (!staged) return lm_free(pr, std::move(parts), max_iter);
  FitOutcome first = lm_free(pr, sized, max_iter);
  if (!std::isfinite(first.cost)) return lm_free(pr, std::move(parts), max_iter);
  for (std::size_t p = 0; p < parts.size(); ++p) first.parts[p].free = parts[p].free;
  FitOutcome out = lm_free(pr, first.parts, max_iter);
  out.sims += first.sims;
  if (keep_sized_fit(sized, first.cost, out)) {
    // Its parts as fitted: the form held (its JtJ has no column for it).
    for (std::size_t p = 0; p < parts.size(); ++p) first.parts[p].free = sized[p].free;
    first.sims = out.sims;
    return first;
  }
  return out;
}

FitOutcome refit(const Problem& pr, std::vector<Part> parts, int max_iter, int restarts) {
  FitOutcome o = levenberg_marquardt(pr, std::move(parts), max_iter);
  for (int restart = 0; restart < restarts && std::isfinite(o.cost); ++restart) {
    FitOutcome again = levenberg_marquardt(pr, o.parts, max_iter);
    const bool gained = again.cost < o.cost * (1 - 1e-4);
    again.sims += o.sims;
    if (again.cost < o.cost) o = std::move(again);
    else o.sims = again.sims;
    if (!gained) break;
  }
  return o;
}

namespace {

// A free size (not an integer, not signed) whose Jacobian column is zero at the optimum, above the
// lower end of its search: where the model's robot is stalled, the log cannot see it there.
struct FlatSize {
  std::size_t part, index;
  double lower;  // the lower end of its search (0, or the smallest positive value of a log scale)
};
std::vector<FlatSize> flat_sizes(const FitOutcome& o) {
  std::vector<FlatSize> out;
  const std::vector<FreeRef> f = free_refs(o.parts);
  if (!std::isfinite(o.cost) || o.JtJ.rows() != static_cast<Eigen::Index>(f.size())) return out;
  double amax = 0;
  for (Eigen::Index j = 0; j < o.JtJ.rows(); ++j) amax = std::max(amax, o.JtJ(j, j));
  for (std::size_t j = 0; j < f.size(); ++j) {
    const auto p = static_cast<std::size_t>(f[j].part), i = static_cast<std::size_t>(f[j].index);
    const ParamSpec& s = o.parts[p].specs[i];
    const auto jj = static_cast<Eigen::Index>(j);
    if (!o.parts[p].entry || s.integer || s.lower < 0 || o.JtJ(jj, jj) > 1e-8 * amax) continue;
    const double lo = std::max(search_lower(s), s.log_scale ? 1e-12 : 0.0);
    if (o.parts[p].values[i] > lo * (1 + 1e-6) + 1e-12) out.push_back({p, i, lo});
  }
  return out;
}

}  // namespace

// A size started above what the log allows can stall the robot in the model where the log has it
// move: dry friction of 0.15 N m in yaw for a log with none holds the turn, and any other value
// above the yaw drive predicts the same, so the size's Jacobian column is zero and LM keeps it
// (Coulomb friction 9.2 times the noise floor on held-out data, 1.08 started from zero). Such a
// size is tried at its lower end (one simulation); where that fits better, LM starts again there.
FitOutcome leave_plateaus(const Problem& pr, FitOutcome o, int max_iter) {
  for (int round = 0; round < 2; ++round) {
    Workspace work;
    Eigen::VectorXd r;
    std::vector<Part> moved = o.parts;
    bool any = false;
    for (const FlatSize& z : flat_sizes(o)) {
      if (o.parts[z.part].specs[z.index].form) continue;  // a form has no size to stall with
      std::vector<Part> trial = o.parts;
      trial[z.part].values[z.index] = z.lower;
      ++o.sims;
      if (residuals(pr, trial, r, work) && r.squaredNorm() < o.cost * (1 - 1e-6)) {
        moved[z.part].values[z.index] = z.lower;
        any = true;
      }
    }
    if (!any) return o;
    FitOutcome again = levenberg_marquardt(pr, std::move(moved), max_iter);
    again.sims += o.sims;
    if (!(again.cost < o.cost)) {
      o.sims = again.sims;
      return o;
    }
    o = std::move(again);
  }
  return o;
}

// LM leaves a parameter on such a plateau where it started (10 N of lateral friction for a
// truth of 25 N, +- 1e7 N: the robot never slid sideways against either): the value is an
// accident of the start, and only the plateau's lower edge is in the log. Found by bisection
// between the search's lower bound (where the cost must differ, else the log does not see the
// parameter at all and it is left alone) and the value, 16 simulations per parameter.
FitOutcome settle_stalls(const Problem& pr, FitOutcome o) {
  const std::vector<FlatSize> flat = flat_sizes(o);
  if (flat.empty()) return o;
  Workspace work;
  Eigen::VectorXd r;
  const double tol = 1e-9 * std::max(o.cost, 1.0);
  auto cost_with = [&](std::size_t p, std::size_t i, double v) {
    std::vector<Part> trial = o.parts;
    trial[p].values[i] = v;
    ++o.sims;
    return residuals(pr, trial, r, work) ? r.squaredNorm() : std::numeric_limits<double>::infinity();
  };
  for (const FlatSize& z : flat) {
    const std::size_t p = z.part, i = z.index;
    const ParamSpec& s = o.parts[p].specs[i];
    const double v0 = o.parts[p].values[i], lo0 = z.lower;
    if (!(cost_with(p, i, lo0) > o.cost + tol)) continue;  // invisible everywhere: not a stall
    double lo = lo0, hi = v0;
    for (int k = 0; k < 16; ++k) {
      const double mid = s.log_scale ? std::sqrt(lo * hi) : 0.5 * (lo + hi);
      if (cost_with(p, i, mid) <= o.cost + tol) hi = mid;
      else lo = mid;
    }
    // No plateau below the value (its column was zero for another reason): not a bound.
    if (!(hi < v0 * (1 - 1e-3))) continue;
    // The model keeps a margin above the edge: the full log's 10 ms speeds peak above the
    // decimated log's 50 ms means, and at the edge itself the robot would break away there.
    o.parts[p].values[i] = std::min(v0, 1.1 * hi);
    o.parts[p].at_least.resize(o.parts[p].specs.size(), 0.0);
    o.parts[p].at_least[i] = hi;
  }
  if (residuals(pr, o.parts, r, work)) {
    o.r = r;
    o.cost = r.squaredNorm();
  }
  return o;
}

std::vector<FitParam> fit_params(const FitOutcome& o, double s2_scale) {
  // Gauss-Newton covariance in internal coordinates, scaled by the residual variance and by
  // n / n_eff (s2_scale): residuals of a simulation are autocorrelated, so the plain formula
  // would be far too confident.
  std::vector<FitParam> out;
  const std::vector<FreeRef> f = free_refs(o.parts);
  Eigen::MatrixXd cov;
  if (!f.empty() && o.JtJ.rows() == static_cast<Eigen::Index>(f.size())) {
    Eigen::MatrixXd A = o.JtJ;
    for (Eigen::Index j = 0; j < A.rows(); ++j) A(j, j) += 1e-12 * std::max(1.0, A(j, j));
    cov = A.inverse() * s2_scale;
  }
  for (std::size_t p = 0; p < o.parts.size(); ++p) {
    const Part& part = o.parts[p];
    std::vector<FitParam> mine;
    for (std::size_t i = 0; i < part.specs.size(); ++i) {
      FitParam fp{part.specs[i].name, part.values[i], kNaN, part.specs[i].unit, ""};
      for (std::size_t j = 0; j < f.size(); ++j)
        if (f[j].part == static_cast<int>(p) && f[j].index == static_cast<int>(i) && cov.size()) {
          const double v = cov(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(j));
          const double z = to_internal(part.specs[i], part.values[i]);
          fp.sigma = std::sqrt(std::max(v, 0.0)) * dvalue_dz(part.specs[i], z);
        }
      mine.push_back(fp);
    }
    flag_params(mine, part);
    out.insert(out.end(), mine.begin(), mine.end());
  }
  return out;
}

}  // namespace search
}  // namespace auger::wb
