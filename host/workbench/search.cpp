// The effect search of `diagnose` and `fit` (docs/workbench.md): each candidate effect is fitted
// by simulation error over segments re-initialised from the measured pose (not by regression on
// differentiated data), with Levenberg-Marquardt on finite-difference Jacobians, from several
// starting points, on training segments; judged on held-out segments; ranked by BIC with an
// effective sample size from the residuals' autocorrelation.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <map>
#include <mutex>
#include <numeric>
#include <sstream>
#include <thread>

#include <Eigen/Cholesky>
#include <Eigen/Dense>

#include "workbench.hpp"

namespace auger::wb {
namespace {

using Segments = std::vector<std::pair<std::size_t, std::size_t>>;
constexpr const char* kPaperParams = "paper_params";
// A held-out error above this multiple of the noise floor is beyond what logs without a missing
// effect give (those stay within 1.0-1.1x: docs/workbench.md "Calibration").
constexpr double kNominalMissRatio = 1.3;

// ---------------------------------------------------------------- what is fitted
// One effect (or paper_params) in a fit: its full parameter values and which are free.
struct Part {
  std::string id;
  const EffectRegistry::Entry* entry = nullptr;  // null for paper_params
  std::vector<ParamSpec> specs;
  std::vector<double> values;  // current full values
  std::vector<int> free;       // indices into values that Gauss-Newton moves
};

// Internal coordinates: value = typical * z, or exp(z) for log-scale parameters.
double to_value(const ParamSpec& s, double z) { return s.log_scale ? std::exp(z) : s.typical * z; }
double to_internal(const ParamSpec& s, double v) { return s.log_scale ? std::log(std::max(v, 1e-300)) : v / s.typical; }
double dvalue_dz(const ParamSpec& s, double z) { return s.log_scale ? std::exp(z) : s.typical; }

// The DOF a parameter belongs to, from its name's tokens (force_x_n -> x): the gantry moves one.
int param_dof(const std::string& name) {
  std::stringstream ss(name);
  std::string tok;
  while (std::getline(ss, tok, '_')) {
    if (tok == "x") return 0;
    if (tok == "y") return 1;
    if (tok == "psi") return 2;
  }
  return -1;
}

std::vector<ParamSpec> paper_specs(const Model& m, const Dataset& d) {
  const TerrainParams& t = m.terrain;
  std::vector<ParamSpec> s = {
      {"sigma_long", t.sigma_long, true, "eq. (7), N per rpm", "N/rpm", 1e-3, 100, t.sigma_long},
      {"sigma_lat", t.sigma_lat, true, "eq. (7), N per rpm", "N/rpm", 1e-3, 100, t.sigma_lat},
      {"D_x", t.D_x, true, "eq. (6)", "N/(m/s)", 1, 1e5, t.D_x},
      {"D_y", t.D_y, true, "eq. (6)", "N/(m/s)", 1, 1e5, t.D_y},
      {"D_psi", t.D_psi, true, "eq. (6)", "N m/(rad/s)", 0.01, 1e4, t.D_psi}};
  if (d.gantry) {
    const bool lon = d.axis == "longitudinal";
    s[lon ? 1 : 0].fitted = false;
    s[lon ? 3 : 2].fitted = false;
    s[4].fitted = false;
  }
  return s;
}

Part make_part(const std::string& id, const Model& base, const Dataset& d) {
  Part p;
  p.id = id;
  if (id == kPaperParams) {
    p.specs = paper_specs(base, d);
  } else {
    const auto& entries = EffectRegistry::builtin().entries();
    auto it = entries.find(id);
    if (it == entries.end()) throw std::invalid_argument("unknown effect '" + id + "' (auger effects lists them)");
    p.entry = &it->second;
    p.specs = it->second.params;
  }
  const int active_dof = d.gantry ? (d.axis == "longitudinal" ? 0 : 1) : -1;
  for (std::size_t i = 0; i < p.specs.size(); ++i) {
    const ParamSpec& s = p.specs[i];
    p.values.push_back(s.default_value);
    const int dof = param_dof(s.name);
    const bool usable = !d.gantry || dof < 0 || dof == active_dof;
    if (s.fitted && !s.integer && usable) p.free.push_back(static_cast<int>(i));
  }
  return p;
}

// The model with the parts applied: paper_params replaces the terrain set, effects are added
// after the base model's own.
Model build(const Model& base, const std::vector<Part>& parts) {
  TerrainParams t = base.terrain;
  std::vector<std::shared_ptr<const Effect>> effects = base.effects;
  for (const Part& p : parts) {
    if (!p.entry) {
      t.sigma_long = p.values[0];
      t.sigma_lat = p.values[1];
      t.D_x = p.values[2];
      t.D_y = p.values[3];
      t.D_psi = p.values[4];
    } else {
      effects.push_back(p.entry->make(p.values));
    }
  }
  return make_model(base.robot, t, std::move(effects));
}

// ---------------------------------------------------------------- residuals
struct Problem {
  const Dataset* data = nullptr;
  const Model* base = nullptr;
  ChannelValues noise{};
  Segments segs;
  std::vector<std::pair<std::size_t, int>> index;  // (sample, channel) of each residual
  SimOptions options;
  // Gantry: the load cell's force is a second measurement of the drive force (eq. (7) with the
  // drive effects): a dead band, lag or saturation changes it, friction does not. Its residuals
  // follow the pose residuals, normalised by its own noise floor.
  std::vector<std::size_t> force_index;
  double force_noise = kNaN;
};

void build_index(Problem& pr) {
  pr.index.clear();
  const Dataset& d = *pr.data;
  for (const auto& [b, e] : pr.segs)
    for (std::size_t k = b; k < e; ++k)
      for (int c = 0; c < kChannels; ++c)
        if (d.active[static_cast<std::size_t>(c)] && std::isfinite(d.meas[k][static_cast<std::size_t>(c)]))
          pr.index.push_back({k, c});
  pr.force_index.clear();
  if (!d.force_n.empty() && std::isfinite(pr.force_noise))
    for (const auto& [b, e] : pr.segs)
      for (std::size_t k = b; k < e; ++k)
        if (std::isfinite(d.force_n[k])) pr.force_index.push_back(k);
}

// Segment length of the search: 25 s, or a seventh of a short log, at least 5 s.
double search_segment_s(const Dataset& data) { return std::clamp(data.duration_s() / 7.0, 5.0, 25.0); }

// The search's problem on the decimated log `data` of `full`, over the segments `segs`.
Problem make_problem(const Dataset& data, const Dataset& full, const Model& base, const ChannelValues& noise,
                     Segments segs) {
  Problem pr;
  pr.data = &data;
  pr.base = &base;
  pr.noise = noise;
  pr.segs = std::move(segs);
  pr.options = sim_options_for(base);
  pr.options.n_sub = 4;  // 12.5 ms sub-steps on the 50 ms steps of the decimated log
  if (!full.force_n.empty()) pr.force_noise = estimate_noise(full.t_s, full.force_n);
  build_index(pr);
  return pr;
}

// Noise-normalised residuals of the model with the parts applied; false if the model cannot be
// built (a parameter outside what the effect accepts).
bool residuals(const Problem& pr, const std::vector<Part>& parts, Eigen::VectorXd& r, Prediction& work) {
  Model m;
  try {
    m = build(*pr.base, parts);
  } catch (const std::invalid_argument&) {
    return false;
  }
  SimOptions o = pr.options;
  o.segment_s = 0;  // each range is one segment
  for (const auto& e : m.effects)
    if (e->id() == "pose_time_offset") o.pose_delay_s = e->params().front().second;
  const Dataset& d = *pr.data;
  if (work.pred.size() != d.size()) work.pred.assign(d.size(), ChannelValues{kNaN, kNaN, kNaN, kNaN});
  if (d.gantry && work.force_n.size() != d.size()) work.force_n.assign(d.size(), kNaN);
  for (const auto& [b, e] : pr.segs) simulate_range(m, d, o, work, b, e);
  r.resize(static_cast<Eigen::Index>(pr.index.size() + pr.force_index.size()));
  for (std::size_t i = 0; i < pr.force_index.size(); ++i) {
    const std::size_t k = pr.force_index[i];
    const double q = work.force_n[k];
    r[static_cast<Eigen::Index>(pr.index.size() + i)] = std::isfinite(q) ? (q - d.force_n[k]) / pr.force_noise : 0.0;
  }
  for (std::size_t i = 0; i < pr.index.size(); ++i) {
    const auto [k, c] = pr.index[i];
    const double q = work.pred[k][static_cast<std::size_t>(c)], y = d.meas[k][static_cast<std::size_t>(c)];
    double e = std::isfinite(q) ? q - y : 0.0;
    if (c >= kPsi) e = wrap_angle(e);
    r[static_cast<Eigen::Index>(i)] = e / pr.noise[static_cast<std::size_t>(c)];
  }
  return true;
}

// ---------------------------------------------------------------- Levenberg-Marquardt
struct FitOutcome {
  std::vector<Part> parts;
  double cost = std::numeric_limits<double>::infinity();
  Eigen::MatrixXd JtJ;  // at the optimum, internal coordinates
  Eigen::VectorXd r;
  int n_params = 0;     // identifiable free parameters
  int sims = 0;
};

struct FreeRef {
  int part, index;
};

std::vector<FreeRef> free_refs(const std::vector<Part>& parts) {
  std::vector<FreeRef> f;
  for (std::size_t p = 0; p < parts.size(); ++p)
    for (int i : parts[p].free) f.push_back({static_cast<int>(p), i});
  return f;
}

void set_z(std::vector<Part>& parts, const std::vector<FreeRef>& f, const Eigen::VectorXd& z) {
  for (std::size_t j = 0; j < f.size(); ++j) {
    Part& p = parts[static_cast<std::size_t>(f[j].part)];
    const ParamSpec& s = p.specs[static_cast<std::size_t>(f[j].index)];
    p.values[static_cast<std::size_t>(f[j].index)] = std::clamp(to_value(s, z[static_cast<Eigen::Index>(j)]), s.lower, s.upper);
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

FitOutcome levenberg_marquardt(const Problem& pr, std::vector<Part> parts, int max_iter) {
  FitOutcome out;
  Prediction work;
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
  for (int it = 0; it < max_iter && P > 0; ++it) {
    // Forward differences; steps of a few % of a typical value (hard effects such as dry
    // friction are piecewise smooth: a larger step sees their slope, not their kinks).
    for (Eigen::Index j = 0; j < P; ++j) {
      Eigen::VectorXd zj = z;
      const double h = 0.03 * std::max(1.0, std::fabs(z[j]));
      zj[j] += h;
      std::vector<Part> pj = parts;
      set_z(pj, f, zj);
      const double actual = get_z(pj, f)[j] - z[j];  // the bound may cut the step
      Eigen::VectorXd rj;
      if (std::fabs(actual) < 1e-12 || !residuals(pr, pj, rj, work)) {
        zj[j] = z[j] - h;
        set_z(pj, f, zj);
        const double back = get_z(pj, f)[j] - z[j];
        if (std::fabs(back) < 1e-12 || !residuals(pr, pj, rj, work)) {
          J.col(j).setZero();
          continue;
        }
        J.col(j) = (rj - r) / back;
      } else {
        J.col(j) = (rj - r) / actual;
      }
      ++out.sims;
    }
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
  if (P > 0) out.JtJ = J.transpose() * J;
  // Parameters the data cannot see (a zero Jacobian column) do not count in the BIC.
  double amax = 0;
  for (Eigen::Index j = 0; j < P; ++j) amax = std::max(amax, out.JtJ(j, j));
  for (Eigen::Index j = 0; j < P; ++j) out.n_params += out.JtJ(j, j) > 1e-8 * amax && amax > 0;
  return out;
}

// Starting points: the typical size (with both signs where a parameter may be negative), and
// a larger one; the default for parameters that are not searched.
std::vector<std::vector<Part>> starts(const std::vector<Part>& parts) {
  std::vector<std::vector<Part>> out;
  for (int variant = 0; variant < 2; ++variant) {
    std::vector<Part> s = parts;
    for (Part& p : s)
      for (int i : p.free) {
        const ParamSpec& sp = p.specs[static_cast<std::size_t>(i)];
        double v;
        if (!p.entry) v = sp.default_value;  // paper_params: start at the paper's values
        else if (sp.log_scale) v = sp.typical * (variant == 0 ? 1.0 : 0.4);  // a limit must bite to be seen
        else if (sp.lower < 0) v = sp.typical * (variant == 0 ? 1.0 : -1.0);
        else v = sp.typical * (variant == 0 ? 1.0 : 0.3);
        if (p.id == "terrain_change" && p.entry) v = variant == 0 ? 0.8 : 1.25;  // factors
        p.values[static_cast<std::size_t>(i)] = std::clamp(v, sp.lower, sp.upper);
      }
    out.push_back(std::move(s));
    if (parts.size() == 1 && !parts[0].entry) break;  // paper_params: one start
  }
  return out;
}

constexpr const char* kCoulomb = "coulomb_friction";
constexpr const char* kStickSlip = "stick_slip_friction";

FitOutcome fit_parts_generic(const Problem& pr, const std::vector<Part>& parts, int max_iter, const Dataset& d);

// Stick-slip friction fitted alone. Its cost over (sliding level, breakaway ratio, Stribeck
// speed) is rugged: whether a start from rest breaks away in one step or the next is a jump,
// and from the generic starts (typical levels) LM stalls in a compromise (a long, shallow
// decay) far from the truth. The Coulomb fit of the same log gives the scale of the levels: it
// is a sliding level averaged with the breakaway, so the sliding level lies at 0.6-1x of it.
// A coarse grid around it (one simulation each) picks the starts, LM refines the best few,
// and the Coulomb optimum itself (ratio 1) is one of them, so stick-slip never fits worse than
// the Coulomb friction it contains.
FitOutcome fit_stick_slip(const Problem& pr, const Part& stick, int max_iter, const Dataset& d,
                          const FitOutcome* coulomb_fit) {
  FitOutcome own;
  if (!coulomb_fit || !std::isfinite(coulomb_fit->cost)) {
    own = fit_parts_generic(pr, {make_part(kCoulomb, *pr.base, d)}, max_iter, d);
    coulomb_fit = &own;
  }
  int sims = coulomb_fit == &own ? own.sims : 0;
  if (!std::isfinite(coulomb_fit->cost) || coulomb_fit->parts.size() != 1 || coulomb_fit->parts[0].values.size() < 3)
    return fit_parts_generic(pr, {stick}, max_iter, d);
  const std::vector<double>& c = coulomb_fit->parts[0].values;  // force_x_n, force_y_n, torque_psi_nm
  auto with = [&](double level_factor, double ratio, double v_s) {
    Part p = stick;
    for (int k = 0; k < 3; ++k) p.values[static_cast<std::size_t>(k)] = level_factor * c[static_cast<std::size_t>(k)];
    p.values[3] = ratio;
    p.values[4] = v_s;
    return p;
  };
  std::vector<std::pair<double, Part>> grid;
  Prediction work;
  Eigen::VectorXd r;
  for (double f : {1.0, 0.85, 0.7})
    for (double ratio : {1.3, 1.7, 2.2})
      for (double v_s : {0.001, 0.0025, 0.006}) {
        Part p = with(f, ratio, v_s);
        ++sims;
        if (residuals(pr, {p}, r, work)) grid.push_back({r.squaredNorm(), std::move(p)});
      }
  std::sort(grid.begin(), grid.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<Part> seeds{with(1.0, 1.0, 0.0025)};  // the Coulomb optimum
  for (std::size_t i = 0; i < grid.size() && i < 2; ++i) seeds.push_back(grid[i].second);
  FitOutcome best;
  for (const Part& s : seeds) {
    FitOutcome o = levenberg_marquardt(pr, {s}, max_iter);
    sims += o.sims;
    if (o.cost < best.cost) best = std::move(o);
    if (best.r.size() && best.cost < 1.3 * static_cast<double>(best.r.size())) break;  // at the noise
  }
  best.sims = sims;
  return best;
}

// The best fit of parts. coulomb_fit: the Coulomb friction fit of the same problem if known
// (stick-slip starts from it; fitted here otherwise).
FitOutcome fit_parts(const Problem& pr, const std::vector<Part>& parts, int max_iter, const Dataset& d,
                     const FitOutcome* coulomb_fit = nullptr) {
  if (parts.size() == 1 && parts[0].id == kStickSlip && parts[0].entry && parts[0].values.size() == 5)
    return fit_stick_slip(pr, parts[0], max_iter, d, coulomb_fit);
  return fit_parts_generic(pr, parts, max_iter, d);
}

// The best fit of parts over all integer choices (e.g. which screw), time grids (a change
// time) and starting points.
FitOutcome fit_parts_generic(const Problem& pr, const std::vector<Part>& parts, int max_iter, const Dataset& d) {
  // Expand integer parameters (gantry: only the two screws of the module).
  std::vector<std::vector<Part>> variants{parts};
  for (std::size_t p = 0; p < parts.size(); ++p)
    for (std::size_t i = 0; i < parts[p].specs.size(); ++i) {
      const ParamSpec& s = parts[p].specs[i];
      if (!s.integer) continue;
      const int hi = d.gantry && s.name == "screw" ? 1 : static_cast<int>(s.upper);
      std::vector<std::vector<Part>> next;
      for (const auto& v : variants)
        for (int x = static_cast<int>(s.lower); x <= hi; ++x) {
          auto w = v;
          w[p].values[i] = x;
          next.push_back(std::move(w));
        }
      variants = std::move(next);
    }
  // A change time is searched on a grid over the log, then refined around the best.
  for (std::size_t p = 0; p < parts.size(); ++p)
    if (parts[p].id == "terrain_change") {
      std::vector<std::vector<Part>> next;
      const double t0 = d.t_s.front(), T = d.duration_s();
      for (const auto& v : variants)
        for (int g = 1; g <= 9; ++g) {
          auto w = v;
          w[p].values[0] = t0 + T * g / 10.0;
          next.push_back(std::move(w));
        }
      variants = std::move(next);
    }
  FitOutcome best;
  const bool grid = variants.size() > 4;
  for (const auto& v : variants)
    for (const auto& s : starts(v)) {
      FitOutcome o = levenberg_marquardt(pr, s, grid ? 4 : max_iter);
      o.sims += best.sims;
      if (o.cost < best.cost) best = std::move(o);
      else best.sims = o.sims;
      if (grid) break;  // one start per grid point
      // At the noise already (mean squared normalised residual near 1): another start cannot do
      // better than noise, so it is skipped (half the time of diagnose).
      if (best.r.size() && best.cost < 1.3 * static_cast<double>(best.r.size())) break;
    }
  if (grid && std::isfinite(best.cost)) {
    // Refine the best grid point: neighbouring change times, then a full fit.
    for (std::size_t p = 0; p < parts.size(); ++p)
      if (parts[p].id == "terrain_change") {
        // Halving steps down to 0.1 s around the best time so far.
        for (double step = d.duration_s() / 20.0; step >= 0.1; step /= 2) {
          const double tc = best.parts[p].values[0];
          for (double t : {tc - step, tc + step}) {
            auto w = best.parts;
            w[p].values[0] = t;
            FitOutcome o = levenberg_marquardt(pr, w, 4);
            o.sims += best.sims;
            if (o.cost < best.cost) best = std::move(o);
            else best.sims = o.sims;
          }
        }
      }
    FitOutcome o = levenberg_marquardt(pr, best.parts, max_iter);
    o.sims += best.sims;
    if (o.cost <= best.cost) best = std::move(o);
  }
  return best;
}

// ---------------------------------------------------------------- segments and statistics
// Segments of about segment_s, each starting at a measured pose.
Segments make_segments(const Dataset& d, double segment_s) {
  Segments s;
  std::size_t b = d.size();
  for (std::size_t k = 0; k < d.size(); ++k) {
    const auto& m = d.meas[k];
    const bool pose = std::isfinite(m[kX]) && std::isfinite(m[kY]) && std::isfinite(m[kPsi]);
    if (!pose) continue;
    if (b == d.size()) b = k;
    else if (d.t_s[k] - d.t_s[b] >= segment_s) {
      s.push_back({b, k});
      b = k;
    }
  }
  if (b < d.size()) {
    if (!s.empty() && d.t_s.back() - d.t_s[b] < 0.4 * segment_s) s.back().second = d.size();  // no stub
    else s.push_back({b, d.size()});
  }
  return s;
}

// Lag-1 autocorrelation of residuals, within each (segment, channel) run.
double lag1_autocorrelation(const Problem& pr, const Eigen::VectorXd& r) {
  double num = 0, den = 0;
  std::array<long, kChannels> last;
  last.fill(-1);
  std::size_t seg_of_last[kChannels] = {0, 0, 0, 0};
  std::size_t seg = 0;
  for (std::size_t i = 0; i < pr.index.size(); ++i) {
    const auto [k, c] = pr.index[i];
    while (seg + 1 < pr.segs.size() && k >= pr.segs[seg].second) ++seg;
    const double v = r[static_cast<Eigen::Index>(i)];
    den += v * v;
    const auto cc = static_cast<std::size_t>(c);
    if (last[cc] >= 0 && seg_of_last[cc] == seg) num += v * r[last[cc]];
    last[cc] = static_cast<long>(i);
    seg_of_last[cc] = seg;
  }
  return den > 0 ? std::clamp(num / den, 0.0, 0.999) : 0.0;
}

double combined_ratio(const ErrorStats& e, const Dataset& d) {
  double s = 0;
  int n = 0;
  for (int c = 0; c < kChannels; ++c)
    if (d.active[static_cast<std::size_t>(c)] && std::isfinite(e.ratio_to_noise[static_cast<std::size_t>(c)])) {
      s += e.ratio_to_noise[static_cast<std::size_t>(c)] * e.ratio_to_noise[static_cast<std::size_t>(c)];
      ++n;
    }
  return n ? std::sqrt(s / n) : kNaN;
}

ErrorStats segments_error(const Model& m, const Dataset& d, const Segments& segs, const ChannelValues& noise) {
  Prediction p;
  p.pred.assign(d.size(), ChannelValues{kNaN, kNaN, kNaN, kNaN});
  SimOptions o = sim_options_for(m);
  o.segment_s = 0;
  o.n_sub = 4;  // as the search simulates the decimated log
  for (const auto& [b, e] : segs) simulate_range(m, d, o, p, b, e);
  return error_stats(d, p, noise);
}

std::vector<FitParam> fit_params(const FitOutcome& o, double s2_scale) {
  // Gauss-Newton covariance in internal coordinates, scaled by the residual variance and by
  // n / n_eff (s2_scale): residuals of a simulation are autocorrelated, so the plain formula
  // would be far too confident.
  std::vector<FitParam> out;
  const std::vector<FreeRef> f = free_refs(o.parts);
  Eigen::MatrixXd cov;
  if (!f.empty() && o.JtJ.size()) {
    Eigen::MatrixXd A = o.JtJ;
    for (Eigen::Index j = 0; j < A.rows(); ++j) A(j, j) += 1e-12 * std::max(1.0, A(j, j));
    cov = A.inverse() * s2_scale;
  }
  for (std::size_t p = 0; p < o.parts.size(); ++p) {
    const Part& part = o.parts[p];
    for (std::size_t i = 0; i < part.specs.size(); ++i) {
      FitParam fp{part.specs[i].name, part.values[i], kNaN, part.specs[i].unit};
      for (std::size_t j = 0; j < f.size(); ++j)
        if (f[j].part == static_cast<int>(p) && f[j].index == static_cast<int>(i) && cov.size()) {
          const double v = cov(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(j));
          const double z = to_internal(part.specs[i], part.values[i]);
          fp.sigma = std::sqrt(std::max(v, 0.0)) * dvalue_dz(part.specs[i], z);
        }
      out.push_back(fp);
    }
  }
  return out;
}

std::string describe(const Part& p, const Model& base) {
  if (!p.entry) {
    char buf[300];
    std::snprintf(buf, sizeof buf,
                  "the paper's own parameters re-identified: sigma_long %.3g (was %.3g), sigma_lat %.3g (was %.3g), "
                  "D_x %.4g (was %.4g), D_y %.4g (was %.4g), D_psi %.3g (was %.3g)",
                  p.values[0], base.terrain.sigma_long, p.values[1], base.terrain.sigma_lat, p.values[2],
                  base.terrain.D_x, p.values[3], base.terrain.D_y, p.values[4], base.terrain.D_psi);
    return buf;
  }
  return p.entry->describe ? p.entry->describe(p.values) : p.entry->doc;
}

// Which experiment separates two effects that explain a log equally well.
std::string tell_apart(const std::string& a, const std::string& b) {
  auto is = [&](const char* x, const char* y) { return (a == x && b == y) || (a == y && b == x); };
  auto any = [&](std::initializer_list<const char*> xs) {
    int n = 0;
    for (const char* x : xs) n += (a == x) + (b == x);
    return n == 2;
  };
  if (is("force_lag", "pose_time_offset"))
    return "steps of screw speed with the camera running: a force lag rounds the start of each motion, a "
           "time offset shifts starts and stops alike by the same time";
  if (any({"coulomb_friction", "stick_slip_friction", "screw_dead_band"}))
    return "slow moves with all screws at one low speed, then with one pair fast and one slow: a dead band "
           "depends on each screw's speed, dry friction on the body's motion; a breakaway shows in starts from rest";
  if (is("imu_heading_bias", "imu_heading_drift"))
    return "a longer log or two logs minutes apart: a drift grows with time, a bias stays";
  if (any({kPaperParams, "quadratic_drag", "traction_saturation", "terrain_change"}))
    return "runs at constant 5, 10, 15, 20 rpm: linear drag gives speeds proportional to omega, quadratic drag "
           "and saturation flatten the fast end, a terrain change shows as a step in time";
  if (any({"terrain_slope", "resistance_offset"}))
    return "the same path driven at two headings: a slope depends on the heading, a resistance offset does not";
  return "a log that excites both: vary speed, direction and heading";
}

// Candidates of the library for this log.
std::vector<std::string> candidate_ids(const Dataset& d, const DiagnoseOptions& o) {
  std::vector<std::string> ids;
  for (const auto& le : effect_library()) {
    if (!o.only.empty() && std::find(o.only.begin(), o.only.end(), le.id) == o.only.end()) continue;
    if (le.needs_imu && !d.active[kImuPsi]) continue;
    if (d.gantry && (le.needs_imu || le.id == "resistance_offset")) continue;
    ids.push_back(le.id);
  }
  return ids;
}

}  // namespace

Dataset decimate_for_search(const Dataset& d, double max_dt_s) {
  // Keep every row with a pose and enough others that no step is longer than max_dt_s; a kept
  // row's omega is the time-weighted mean of the rows it stands for (each row's omega is the
  // mean over the interval ending at its t_s, so the mean over the merged interval is exact).
  // The dynamics step is exact for a held force, so a 50 ms step loses only the variation of
  // omega inside it: five times fewer steps for the hundreds of simulations of a search.
  Dataset c = d;
  c.t_s.clear();
  c.omega_rpm.clear();
  c.meas.clear();
  c.force_n.clear();
  Vec4 acc = Vec4::Zero();
  double acc_t = 0;
  for (std::size_t k = 0; k < d.size(); ++k) {
    const double dt = k ? d.t_s[k] - d.t_s[k - 1] : 0.0;
    acc += dt * d.omega_rpm[k];
    acc_t += dt;
    const auto& m = d.meas[k];
    const bool pose = std::isfinite(m[kX]) && std::isfinite(m[kY]) && std::isfinite(m[kPsi]);
    const bool due = c.t_s.empty() || k + 1 == d.size() || (k + 1 < d.size() && d.t_s[k + 1] - c.t_s.back() > max_dt_s + 1e-9);
    // Dense poses (a 100 Hz gantry encoder) are thinned to the same max_dt_s.
    const bool spaced = c.t_s.empty() || d.t_s[k] - c.t_s.back() >= max_dt_s - 1e-9;
    if (!((pose && spaced) || due)) continue;
    c.t_s.push_back(d.t_s[k]);
    c.omega_rpm.push_back(acc_t > 0 ? Vec4(acc / acc_t) : d.omega_rpm[k]);
    c.meas.push_back(m);
    if (!d.force_n.empty()) c.force_n.push_back(d.force_n[k]);
    acc.setZero();
    acc_t = 0;
  }
  return c;
}

// ---------------------------------------------------------------- library
std::vector<LibraryEffect> effect_library() {
  std::vector<LibraryEffect> out;
  {
    LibraryEffect p;
    p.id = kPaperParams;
    p.summary = "re-identification of the paper's own parameters sigma_long, sigma_lat, D_x, D_y, D_psi "
                "(eqs. (15)-(17)); written to the model file's [terrain.NAME], not as an [[effect]]";
    RobotParams rp;
    p.params = paper_specs(make_model(rp, {"sand", 0.812, 0.247, 560.33, 320.08, 11.46}), Dataset{});
    for (const auto& s : p.params) p.units.push_back(s.unit);
    out.push_back(p);
  }
  for (const auto& [id, e] : EffectRegistry::builtin().entries()) {
    LibraryEffect le;
    le.id = id;
    le.summary = e.doc;
    le.params = e.params;
    for (const auto& s : e.params) le.units.push_back(s.unit);
    le.needs_imu = e.needs_imu;
    out.push_back(le);
  }
  return out;
}

// ---------------------------------------------------------------- diagnose
DiagnoseResult diagnose(const Dataset& full, ModelChoice mc, const DiagnoseOptions& opt) {
  DiagnoseResult res;
  res.model = std::move(mc);
  const Model& base = res.model.model;
  res.noise_floor = estimate_noise_floor(full);
  const Dataset data = decimate_for_search(full);
  for (int c = 0; c < kChannels; ++c)
    if (data.active[static_cast<std::size_t>(c)] && !std::isfinite(res.noise_floor[static_cast<std::size_t>(c)]))
      throw std::runtime_error(std::string("cannot estimate the noise floor of ") + channel_name(c) +
                               ": too few consecutive measurements");

  // Training and held-out segments interleaved (every third held out), so that something that
  // starts at some time (a terrain change) is in both.
  const Segments all = make_segments(data, search_segment_s(data));
  Segments train, held;
  for (std::size_t s = 0; s < all.size(); ++s) (s % 3 == 2 ? held : train).push_back(all[s]);
  if (held.empty() && train.size() > 1) {
    held.push_back(train.back());
    train.pop_back();
  }
  if (held.empty()) held = train;

  Problem pr = make_problem(data, full, base, res.noise_floor, train);

  {
    Prediction p;  // as compare reports it
    simulate(base, full, sim_options_for(base), p);
    res.nominal = error_stats(full, p, res.noise_floor);
  }
  res.nominal_heldout_ratio = combined_ratio(segments_error(base, data, held, res.noise_floor), data);
  Eigen::VectorXd r0;
  Prediction work;
  residuals(pr, {}, r0, work);
  const double cost0 = r0.squaredNorm();
  const double n = static_cast<double>(r0.size());
  res.n = n;

  std::vector<std::string> ids = candidate_ids(data, opt);
  // Stick-slip starts from the Coulomb fit (fit_stick_slip): fitted last, so the Coulomb fit is
  // done (or nearly) when a thread reaches it and the threads rarely wait.
  std::stable_partition(ids.begin(), ids.end(), [](const std::string& id) { return id != kStickSlip; });
  const auto coulomb_at = std::find(ids.begin(), ids.end(), kCoulomb);
  const std::size_t coulomb_i = static_cast<std::size_t>(coulomb_at - ids.begin());
  std::vector<FitOutcome> outcomes(ids.size());
  std::vector<char> fitted(ids.size(), 0);
  std::condition_variable fitted_cv;
  std::atomic<std::size_t> next{0};
  std::mutex print;
  std::size_t done = 0;
  auto worker = [&]() {
    for (std::size_t i; (i = next++) < ids.size();) {
      const FitOutcome* coulomb_fit = nullptr;
      if (ids[i] == kStickSlip && coulomb_i < ids.size()) {
        std::unique_lock<std::mutex> lock(print);
        fitted_cv.wait(lock, [&] { return fitted[coulomb_i] != 0; });
        coulomb_fit = &outcomes[coulomb_i];  // not written again once fitted
      }
      FitOutcome o = fit_parts(pr, {make_part(ids[i], base, data)}, 20, data, coulomb_fit);
      std::lock_guard<std::mutex> lock(print);
      ++done;
      if (opt.progress)
        std::fprintf(stderr, "diagnose: %zu/%zu %s fitted (%d simulations)\n", done, ids.size(), ids[i].c_str(), o.sims);
      outcomes[i] = std::move(o);
      fitted[i] = 1;
      fitted_cv.notify_all();
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < std::max(1, opt.threads); ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();

  // n_eff from the best candidate's residuals (what is left is closest to the noise there).
  std::size_t best_i = 0;
  for (std::size_t i = 0; i < outcomes.size(); ++i)
    if (outcomes[i].cost < outcomes[best_i].cost) best_i = i;
  const double rho = outcomes.empty() || !std::isfinite(outcomes[best_i].cost)
                         ? lag1_autocorrelation(pr, r0)
                         : lag1_autocorrelation(pr, outcomes[best_i].r);
  res.n_eff = std::clamp(n * (1 - rho) / (1 + rho), std::min(n, 10.0), n);
  const double scale = n / res.n_eff;

  for (std::size_t i = 0; i < outcomes.size(); ++i) {
    const FitOutcome& o = outcomes[i];
    if (!std::isfinite(o.cost)) continue;
    Candidate c;
    c.fitted.effect = ids[i];
    const double s2 = o.cost / std::max(1.0, n - o.n_params);
    c.fitted.params = fit_params(o, s2 * scale);
    c.fitted.description = describe(o.parts[0], base);
    c.train_cost = o.cost;
    // BIC with the effective sample size: n_eff ln(RSS / n) + k ln(n_eff), against the nominal.
    c.delta_bic = res.n_eff * std::log(std::max(o.cost, 1e-300) / std::max(cost0, 1e-300)) +
                  o.n_params * std::log(res.n_eff);
    const Model m = build(base, o.parts);
    const ErrorStats he = segments_error(m, data, held, res.noise_floor);
    c.heldout_rms = he.rms;
    c.heldout_ratio = combined_ratio(he, data);
    res.candidates.push_back(std::move(c));
  }
  // Rank: candidates that also improve the held-out part first, then by delta BIC.
  std::sort(res.candidates.begin(), res.candidates.end(), [&](const Candidate& a, const Candidate& b) {
    const bool ga = a.heldout_ratio < res.nominal_heldout_ratio, gb = b.heldout_ratio < res.nominal_heldout_ratio;
    if (ga != gb) return ga;
    return a.delta_bic < b.delta_bic;
  });
  // Near ties: neighbours whose held-out errors are within 10 % and BIC gains within 10 %, or
  // whose held-out errors are within 2 %.
  for (std::size_t i = 0; i + 1 < res.candidates.size(); ++i) {
    Candidate& a = res.candidates[i];
    Candidate& b = res.candidates[i + 1];
      const bool held_close = std::fabs(a.heldout_ratio - b.heldout_ratio) <= 0.1 * std::max(a.heldout_ratio, 1e-9);
    const bool bic_close = std::fabs(a.delta_bic - b.delta_bic) <= std::max(10.0, 0.1 * std::fabs(a.delta_bic));
    // Held-out errors within 2 % cannot be told apart on new data, whatever the training BIC says.
    const bool held_same = std::fabs(a.heldout_ratio - b.heldout_ratio) <= 0.02 * std::max(a.heldout_ratio, 1e-9);
    if (((held_close && bic_close) || held_same) && a.delta_bic < -10 && b.delta_bic < -10) {
      a.near_tie = b.near_tie = true;
      if (a.tell_apart.empty()) a.tell_apart = tell_apart(a.fitted.effect, b.fitted.effect);
      b.tell_apart = tell_apart(a.fitted.effect, b.fitted.effect);
    }
  }
  // Significant: beyond what logs with no missing effect produce (docs/workbench.md,
  // "Calibration"): the nominal model misses clearly on held-out data and the best candidate
  // removes a clear share of that on held-out data, with a clear BIC gain.
  const Candidate* best = res.candidates.empty() ? nullptr : &res.candidates.front();
  const double nominal_excess = res.nominal_heldout_ratio;
  res.significant = best && (nominal_excess > kNominalMissRatio ||
                             (nominal_excess > 1.1 && best->delta_bic < -20 &&
                              best->heldout_ratio < res.nominal_heldout_ratio * 0.9));
  // Explained: the best candidate leaves at most 1.5x the noise, or removes 80 % of the excess.
  const bool explained = best && res.significant &&
                         (best->heldout_ratio < 1.5 ||
                          res.nominal_heldout_ratio - best->heldout_ratio > 0.8 * (res.nominal_heldout_ratio - 1.0));
  Model remaining_model = base;
  if (res.significant && explained) {
    // The best candidate's model, rebuilt from its fitted values.
    std::vector<Part> parts{make_part(best->fitted.effect, base, data)};
    for (std::size_t i = 0; i < parts[0].values.size(); ++i) parts[0].values[i] = best->fitted.params[i].value;
    remaining_model = build(base, parts);
  }
  res.where = worst_windows(window_errors(remaining_model, full, res.noise_floor, 5.0, sim_options_for(remaining_model)), 5);
  char buf[600];
  if (!best || !res.significant) {
    std::snprintf(buf, sizeof buf,
                  "no missing effect: the nominal model is within %.2fx the noise floor on held-out data and no "
                  "library effect improves it beyond what logs without a missing effect show",
                  res.nominal_heldout_ratio);
  } else if (!explained) {
    std::snprintf(buf, sizeof buf,
                  "nothing in the library explains what remains: the best candidate (%s) leaves %.2fx the noise "
                  "floor on held-out data (nominal %.2fx); the model fails most at t = %.1f-%.1f s in %s",
                  best->fitted.effect.c_str(), best->heldout_ratio, res.nominal_heldout_ratio,
                  res.where.empty() ? 0.0 : res.where[0].t_start_s, res.where.empty() ? 0.0 : res.where[0].t_end_s,
                  res.where.empty() ? "-" : channel_name(res.where[0].dof));
  } else {
    std::snprintf(buf, sizeof buf, "most likely missing: %s (held-out error %.2fx the noise floor, nominal %.2fx)%s",
                  best->fitted.description.c_str(), best->heldout_ratio, res.nominal_heldout_ratio,
                  best->near_tie ? "; near tie with the next candidate, see tell_apart" : "");
  }
  res.verdict = buf;
  return res;
}

// ---------------------------------------------------------------- fit
FitResult fit(const Dataset& full, ModelChoice mc, const std::vector<std::string>& ids, bool progress) {
  FitResult res;
  res.before = mc;
  const Model& base = mc.model;
  res.noise_floor = estimate_noise_floor(full);
  const Dataset data = decimate_for_search(full);
  Problem pr = make_problem(data, full, base, res.noise_floor, make_segments(data, search_segment_s(data)));
  std::vector<Part> parts{make_part(kPaperParams, base, data)};
  for (const auto& id : ids)
    if (id != kPaperParams) parts.push_back(make_part(id, base, data));
  // First each effect alone from the paper's parameters (so its start is sensible), then all
  // together with the paper's parameters, eqs. (15)-(17).
  for (std::size_t p = 1; p < parts.size(); ++p) {
    FitOutcome o = fit_parts(pr, {parts[p]}, 12, data);
    if (std::isfinite(o.cost)) parts[p] = o.parts[0];
    if (progress) std::fprintf(stderr, "fit: %s alone done (%d simulations)\n", parts[p].id.c_str(), o.sims);
  }
  // Joint fit: integer choices and change times stay where the single fits put them.
  std::vector<Part> joint = parts;
  for (auto& p : joint)
    for (auto& s : p.specs)
      if (s.integer) s.fitted = false;
  FitOutcome o = levenberg_marquardt(pr, joint, 20);
  // Restarts with a fresh damping while they still gain (a stalled LM step is often a poor
  // finite-difference direction, not the optimum).
  for (int restart = 0; restart < 3 && std::isfinite(o.cost); ++restart) {
    FitOutcome again = levenberg_marquardt(pr, o.parts, 20);
    const bool gained = again.cost < o.cost * (1 - 1e-4);
    again.sims += o.sims;
    if (again.cost < o.cost) o = std::move(again);
    if (!gained) break;
  }
  if (progress) std::fprintf(stderr, "fit: joint fit done (%d simulations)\n", o.sims);
  // A last polish on the full log as compare runs it (10 ms rows, 25 s segments): the decimated
  // log's 50 ms steps differ from it by a little, which matters once the fit is near the noise.
  if (std::isfinite(o.cost) && full.size() != data.size()) {
    Problem pf = pr;
    pf.data = &full;
    pf.segs = make_segments(full, 25.0);
    pf.options.n_sub = SimOptions{}.n_sub;
    build_index(pf);  // force_noise as pr's: both from the full log
    FitOutcome polished = levenberg_marquardt(pf, o.parts, 6);
    if (progress) std::fprintf(stderr, "fit: polished on the full log (%d simulations)\n", polished.sims);
    if (std::isfinite(polished.cost)) {
      // Keep the decimated fit's statistics (same parameters, n_eff below from its residuals).
      o.parts = polished.parts;
      Eigen::VectorXd r;
      Prediction work;
      if (residuals(pr, o.parts, r, work)) {
        o.r = r;
        o.cost = r.squaredNorm();
      }
    }
  }
  if (!std::isfinite(o.cost)) throw std::runtime_error("the fit failed: no parameter set gives a valid model");
  const double n = static_cast<double>(o.r.size());
  const double rho = lag1_autocorrelation(pr, o.r);
  const double n_eff = std::clamp(n * (1 - rho) / (1 + rho), std::min(n, 10.0), n);
  const std::vector<FitParam> all_params = fit_params(o, o.cost / std::max(1.0, n - o.n_params) * n / n_eff);
  std::size_t k = 0;
  for (const Part& p : o.parts) {
    FittedEffect fe;
    fe.effect = p.id;
    for (std::size_t i = 0; i < p.specs.size(); ++i) fe.params.push_back(all_params[k++]);
    fe.description = describe(p, base);
    res.effects.push_back(fe);
  }
  res.after = mc;
  res.after.model = build(base, o.parts);
  res.after.source = "fitted from " + data.path;
  // Reported as compare reports it (segments of 25 s), so the two commands agree.
  Prediction p;
  simulate(base, full, sim_options_for(base), p);
  res.err_before = error_stats(full, p, res.noise_floor);
  simulate(res.after.model, full, sim_options_for(res.after.model), p);
  res.err_after = error_stats(full, p, res.noise_floor);
  res.model_toml = model_to_toml(res.after.model, data, res.effects);
  return res;
}

// ---------------------------------------------------------------- model file
std::string model_to_toml(const Model& m, const Dataset& d, const std::vector<FittedEffect>& effects) {
  std::ostringstream o;
  o.precision(10);
  o << "# Written by auger fit from " << d.path << " (docs/workbench.md). Schema: docs/model.md.\n";
  o << "schema = 1\nomega_unit = \"rpm\"\nframe = \"rep103\"\n\n";
  const RobotParams& r = m.robot;
  if (d.gantry) {
    o << "[gantry]\nmass_kg = " << r.m_kg << "\n\n";
  } else {
    o << "[robot]\nr_s_m = " << r.r_s_m << "\nphi_deg = " << r.phi_rad * 180 / kPi << "\nl_x_m = " << r.l_x_m
      << "\nl_y_m = " << r.l_y_m << "\nalpha_deg = " << r.alpha_rad * 180 / kPi << "\nm_kg = " << r.m_kg
      << "\nI_z_kgm2 = " << r.I_z_kgm2 << "\nomega_max_rpm = " << r.omega_max_rpm << "\n\n";
  }
  const TerrainParams& t = m.terrain;
  o << "# paper_params (eqs. (15)-(17)), re-identified\n";
  o << "[terrain." << (t.name.empty() ? "sand" : t.name) << "]\nsigma_long = " << t.sigma_long
    << "\nsigma_lat = " << t.sigma_lat << "\nD_x = " << t.D_x << "\nD_y = " << t.D_y << "\n";
  if (!d.gantry) o << "D_psi = " << t.D_psi << "\n";
  for (const auto& e : m.effects) {
    std::string words;
    for (const auto& fe : effects)
      if (fe.effect == e->id()) words = fe.description;
    o << "\n";
    if (!words.empty()) o << "# " << words << "\n";
    o << "[[effect]]\nid = \"" << e->id() << "\"\n";
    for (const auto& [name, value] : e->params()) o << name << " = " << value << "\n";
  }
  return o.str();
}

}  // namespace auger::wb
