// The effect search's machinery (search.hpp, docs/workbench.md): each model under test is fitted
// by simulation error over segments re-initialised from the measured pose (not by regression on
// differentiated data), with Levenberg-Marquardt on finite-difference Jacobians, from several
// starting points, on training segments; judged on held-out segments.
#include "fitting.hpp"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include <Eigen/Cholesky>

namespace auger::wb {
namespace search {
namespace {

constexpr const char* kCoulomb = "coulomb_friction";
constexpr const char* kStickSlip = "stick_slip_friction";
constexpr const char* kTerrainChange = "terrain_change";

// Internal coordinates: value = typical * z, or exp(z) for log-scale parameters.
double to_value(const ParamSpec& s, double z) { return s.log_scale ? std::exp(z) : s.typical * z; }
double to_internal(const ParamSpec& s, double v) { return s.log_scale ? std::log(std::max(v, 1e-300)) : v / s.typical; }
double dvalue_dz(const ParamSpec& s, double z) { return s.log_scale ? std::exp(z) : s.typical; }

// The DOF a parameter belongs to, from its name's tokens (force_x_n -> x, force_max_lat_n -> y):
// the gantry moves one.
int param_dof(const std::string& name) {
  std::stringstream ss(name);
  std::string tok;
  while (std::getline(ss, tok, '_')) {
    if (tok == "x" || tok == "long") return 0;
    if (tok == "y" || tok == "lat") return 1;
    if (tok == "psi") return 2;
  }
  return -1;
}

std::vector<ParamSpec> paper_specs(const Model& m, const Dataset& d) {
  const TerrainParams& t = m.terrain;
  // Physical ranges: within a factor of 3 of the terrain's table values (Tables 2-3 span sigma
  // 0.09-0.81 N/rpm, D 23-560 N/(m/s) across terrains), and absolute limits for a 29 kg robot.
  // Beyond them the log is from other ground than its metadata says, or the fit traded sigma and
  // D against a missing effect: both scaled up together keep every steady speed and shorten every
  // time constant, as a missing yaw time constant would.
  auto spec = [](const char* name, double v, const char* doc, const char* unit, double lo, double hi, double abs_lo,
                 double abs_hi) {
    ParamSpec s{name, v, true, doc, unit, lo, hi, v};
    const double plo = std::isfinite(v) && v > 0 ? std::max(abs_lo, v / 3.0) : abs_lo;
    const double phi = std::isfinite(v) && v > 0 ? std::min(abs_hi, v * 3.0) : abs_hi;
    return s.physical(plo, phi);
  };
  std::vector<ParamSpec> s = {spec("sigma_long", t.sigma_long, "eq. (7), N per rpm", "N/rpm", 1e-3, 100, 0.02, 3),
                              spec("sigma_lat", t.sigma_lat, "eq. (7), N per rpm", "N/rpm", 1e-3, 100, 0.01, 2),
                              spec("D_x", t.D_x, "eq. (6)", "N/(m/s)", 1, 1e5, 10, 5000),
                              spec("D_y", t.D_y, "eq. (6)", "N/(m/s)", 1, 1e5, 5, 5000),
                              spec("D_psi", t.D_psi, "eq. (6)", "N m/(rad/s)", 0.01, 1e4, 0.2, 200)};
  if (d.gantry) {
    const bool lon = d.axis == "longitudinal";
    s[lon ? 1 : 0].fitted = false;
    s[lon ? 3 : 2].fitted = false;
    s[4].fitted = false;
  }
  return s;
}

const Dataset& log_data(const Problem& pr, const Part& p) { return pr.data(p.log < 0 ? 0 : p.log); }

bool applies(const Part& p, const LogTerm& t) {
  if (p.log >= 0 && p.log != t.log) return false;
  return p.entry || p.terrain.empty() || p.terrain == t.base->terrain.name;
}

}  // namespace

// ---------------------------------------------------------------- parts
Part make_part(const std::string& id, const Model& base, const Dataset& d) {
  Part p;
  p.id = id;
  if (id == kPaperParams) {
    p.specs = paper_specs(base, d);
    p.terrain = base.terrain.name;
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

std::vector<Part> parts_of(const Model& model, const Dataset& d) {
  std::vector<Part> out;
  for (const auto& e : model.effects) {
    Part p = make_part(e->id(), model, d);
    const auto values = e->params();
    for (std::size_t i = 0; i < p.values.size() && i < values.size(); ++i) p.values[i] = values[i].second;
    out.push_back(std::move(p));
  }
  return out;
}

Model without_effects(const Model& model) { return make_model(model.robot, model.terrain, {}); }

Model build(const Model& base, const std::vector<Part>& parts, int log) {
  TerrainParams t = base.terrain;
  std::vector<std::shared_ptr<const Effect>> effects = base.effects;
  for (const Part& p : parts) {
    if (p.log >= 0 && p.log != log) continue;
    if (!p.entry) {
      if (!p.terrain.empty() && p.terrain != base.terrain.name) continue;
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

std::vector<Part> frozen(std::vector<Part> parts) {
  for (Part& p : parts) p.free.clear();
  return parts;
}

// ---------------------------------------------------------------- problem
std::size_t Problem::size() const {
  std::size_t n = 0;
  for (const LogTerm& t : terms) n += t.size();
  return n;
}

const Dataset& Problem::data(int log) const {
  for (const LogTerm& t : terms)
    if (t.log == log) return *t.data;
  return *terms.front().data;
}

void build_index(LogTerm& t) {
  t.index.clear();
  const Dataset& d = *t.data;
  for (const auto& [b, e] : t.segs)
    for (std::size_t k = b; k < e; ++k)
      for (int c = 0; c < kChannels; ++c)
        if (d.active[static_cast<std::size_t>(c)] && std::isfinite(d.meas[k][static_cast<std::size_t>(c)]))
          t.index.push_back({k, c});
  t.force_index.clear();
  if (!d.force_n.empty() && std::isfinite(t.force_noise))
    for (const auto& [b, e] : t.segs)
      for (std::size_t k = b; k < e; ++k)
        if (std::isfinite(d.force_n[k])) t.force_index.push_back(k);
}

double search_segment_s(const Dataset& data) { return std::clamp(data.duration_s() / 7.0, 5.0, 25.0); }

void split_segments(const Segments& all, Segments& train, Segments& held) {
  train.clear();
  held.clear();
  for (std::size_t s = 0; s < all.size(); ++s) (s % 3 == 2 ? held : train).push_back(all[s]);
  if (held.empty() && train.size() > 1) {
    held.push_back(train.back());
    train.pop_back();
  }
  if (held.empty()) held = train;
}

void add_log(Problem& pr, const Dataset& data, const Dataset& full, const Model& base, const ChannelValues& noise,
             Segments segs, int log) {
  LogTerm t;
  t.data = &data;
  t.base = &base;
  t.noise = noise;
  t.segs = std::move(segs);
  t.log = log;
  t.options = sim_options_for(base);
  t.options.n_sub = 4;  // 12.5 ms sub-steps on the 50 ms steps of the decimated log
  t.options.segment_s = 0;  // each range is one segment
  if (!full.force_n.empty()) t.force_noise = estimate_noise(full.t_s, full.force_n);
  build_index(t);
  pr.terms.push_back(std::move(t));
}

Problem make_problem(const Dataset& data, const Dataset& full, const Model& base, const ChannelValues& noise,
                     Segments segs) {
  Problem pr;
  add_log(pr, data, full, base, noise, std::move(segs), 0);
  return pr;
}

bool residuals(const Problem& pr, const std::vector<Part>& parts, Eigen::VectorXd& r, Workspace& work) {
  r.resize(static_cast<Eigen::Index>(pr.size()));
  if (work.size() != pr.terms.size()) work.resize(pr.terms.size());
  Eigen::Index at = 0;
  for (std::size_t ti = 0; ti < pr.terms.size(); ++ti) {
    const LogTerm& t = pr.terms[ti];
    Model m;
    try {
      std::vector<Part> mine;
      for (const Part& p : parts)
        if (applies(p, t)) mine.push_back(p);
      m = build(*t.base, mine, t.log);
    } catch (const std::invalid_argument&) {
      return false;
    }
    SimOptions o = t.options;
    o.pose_delay_s = sim_options_for(m).pose_delay_s;
    const Dataset& d = *t.data;
    Prediction& w = work[ti];
    if (w.pred.size() != d.size()) w.pred.assign(d.size(), ChannelValues{kNaN, kNaN, kNaN, kNaN});
    if (d.gantry && w.force_n.size() != d.size()) w.force_n.assign(d.size(), kNaN);
    for (const auto& [b, e] : t.segs) simulate_range(m, d, o, w, b, e);
    for (std::size_t i = 0; i < t.index.size(); ++i) {
      const auto [k, c] = t.index[i];
      const double q = w.pred[k][static_cast<std::size_t>(c)], y = d.meas[k][static_cast<std::size_t>(c)];
      double e = std::isfinite(q) ? q - y : 0.0;
      if (c >= kPsi) e = wrap_angle(e);
      r[at++] = e / t.noise[static_cast<std::size_t>(c)];
    }
    for (std::size_t k : t.force_index) {
      const double q = w.force_n[k];
      r[at++] = std::isfinite(q) ? (q - d.force_n[k]) / t.force_noise : 0.0;
    }
  }
  return r.allFinite();
}

// ---------------------------------------------------------------- Levenberg-Marquardt
namespace {

struct FreeRef {
  int part, index;
};

std::vector<FreeRef> free_refs(const std::vector<Part>& parts) {
  std::vector<FreeRef> f;
  for (std::size_t p = 0; p < parts.size(); ++p)
    for (int i : parts[p].free) f.push_back({static_cast<int>(p), i});
  return f;
}

// The search stays inside a parameter's physical range as well as its bounds: outside it the
// fit trades one effect against another (sigma and D scaled up together imitate a shorter yaw
// time constant) and the values mean nothing. A value at such a bound is flagged.
double search_lower(const ParamSpec& s) { return std::max(s.lower, s.physical_lower); }
double search_upper(const ParamSpec& s) { return std::min(s.upper, s.physical_upper); }

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

FitOutcome levenberg_marquardt(const Problem& pr, std::vector<Part> parts, int max_iter) {
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
      if (!p.entry) v = sp.default_value;  // paper_params: start at the paper's values
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
  for (const auto& v : variants)
    for (const auto& s : starts(v)) {
      FitOutcome o = levenberg_marquardt(pr, s, grid ? (change ? 2 : 4) : max_iter);
      sims += o.sims;
      if (change && std::isfinite(o.cost)) tried.push_back(o);
      const bool at_noise = o.r.size() && o.cost < 1.3 * static_cast<double>(o.r.size());
      if (o.cost < best.cost) best = std::move(o);
      if (grid) break;  // one start per grid point
      // At the noise already (mean squared normalised residual near 1): another start cannot do
      // better than noise, so it is skipped.
      if (at_noise) break;
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
  return best;
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
    for (int g = 1; g < 16; ++g) {
      std::vector<Part> w = o.parts;
      w[c].values[0] = t0 + spacing * g;
      FitOutcome x = levenberg_marquardt(pr, std::move(w), 3);
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

// ---------------------------------------------------------------- threads
void run_parallel(int threads, const std::vector<std::size_t>& which, const std::function<int(std::size_t)>& wait_for,
                  const std::function<void(std::size_t)>& fn) {
  std::atomic<std::size_t> next{0};
  std::set<std::size_t> done;
  std::condition_variable cv;
  std::mutex m;
  auto worker = [&]() {
    for (std::size_t n; (n = next++) < which.size();) {
      const std::size_t i = which[n];
      const int w = wait_for(i);
      // (Waiting is only for an index that is also run: a job scheduled earlier in `which`.)
      if (w >= 0 && std::find(which.begin(), which.end(), static_cast<std::size_t>(w)) != which.end()) {
        std::unique_lock<std::mutex> lock(m);
        cv.wait(lock, [&] { return done.count(static_cast<std::size_t>(w)) != 0; });
      }
      fn(i);
      {
        std::lock_guard<std::mutex> lock(m);
        done.insert(i);
      }
      cv.notify_all();
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < std::max(1, threads); ++t) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
}

// ---------------------------------------------------------------- statistics
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

double lag1_autocorrelation(const Problem& pr, const Eigen::VectorXd& r) {
  double num = 0, den = 0;
  Eigen::Index at = 0;
  for (const LogTerm& t : pr.terms) {
    std::array<long, kChannels> last;
    last.fill(-1);
    std::size_t seg_of_last[kChannels] = {0, 0, 0, 0};
    std::size_t seg = 0;
    for (std::size_t i = 0; i < t.index.size(); ++i) {
      const auto [k, c] = t.index[i];
      while (seg + 1 < t.segs.size() && k >= t.segs[seg].second) ++seg;
      const double v = r[at + static_cast<Eigen::Index>(i)];
      den += v * v;
      const auto cc = static_cast<std::size_t>(c);
      if (last[cc] >= 0 && seg_of_last[cc] == seg) num += v * r[at + last[cc]];
      last[cc] = static_cast<long>(i);
      seg_of_last[cc] = seg;
    }
    at += static_cast<Eigen::Index>(t.size());
  }
  return den > 0 ? std::clamp(num / den, 0.0, 0.999) : 0.0;
}

double effective_n(double n, double rho) { return std::clamp(n * (1 - rho) / (1 + rho), std::min(n, 10.0), n); }

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

void flag_params(std::vector<FitParam>& params, const Part& part) {
  for (std::size_t i = 0; i < params.size() && i < part.specs.size(); ++i) {
    const ParamSpec& s = part.specs[i];
    FitParam& p = params[i];
    p.flag.clear();
    const bool searched = std::find(part.free.begin(), part.free.end(), static_cast<int>(i)) != part.free.end();
    if (!s.fitted || s.integer) continue;
    char buf[200];
    if (!searched) continue;  // held at its default: nothing was fitted
    // At the end of the physical range where it is stricter than the effect's own bounds (those
    // are definitions: a breakaway ratio of 1 is Coulomb friction, a force limit of 1e6 N none).
    const double pspan = s.physical_upper - s.physical_lower;
    auto near = [&](double bound) {
      const double tol = s.log_scale ? 1e-3 * std::fabs(bound) : 1e-3 * (std::isfinite(pspan) ? pspan : std::fabs(s.typical));
      return std::fabs(p.value - bound) <= tol;
    };
    const bool at_lo = s.physical_lower > s.lower && near(s.physical_lower);
    const bool at_hi = s.physical_upper < s.upper && near(s.physical_upper);
    if (p.value < s.physical_lower || p.value > s.physical_upper) {
      std::snprintf(buf, sizeof buf, "outside the physical range %g..%g %s", s.physical_lower, s.physical_upper,
                    s.unit.c_str());
      p.flag = buf;
    } else if ((at_lo || at_hi) && part.entry && std::isfinite(p.sigma) && p.sigma > 0.5 * std::fabs(p.value)) {
      // An effect's value that the log bounds from one side only (a blocked screw that never
      // slides says its force is at least what the others push with): a plausible value lies
      // within its uncertainty. (The paper's parameters at the end of their range are the sign
      // of an effect they have taken up, however uncertain.)
      std::snprintf(buf, sizeof buf, "not identified by this log: at the end of its physical range, %g %s, +- %.2g",
                    at_lo ? s.physical_lower : s.physical_upper, s.unit.c_str(), p.sigma);
      p.flag = buf;
    } else if (at_lo || at_hi) {
      std::snprintf(buf, sizeof buf, "at the end of its physical range, %g %s", at_lo ? s.physical_lower : s.physical_upper,
                    s.unit.c_str());
      p.flag = buf;
    } else if (searched && std::isfinite(p.sigma) && p.sigma > std::fabs(p.value) && p.sigma > 0.5 * std::fabs(s.typical)) {
      // (A value near zero known to a small fraction of its typical size is identified: it is zero.)
      p.flag = "uncertainty larger than the value: not identified by this log";
    }
  }
}

bool any_implausible(const std::vector<FitParam>& params) {
  for (const FitParam& p : params)
    if (p.flag.rfind("outside", 0) == 0 || p.flag.rfind("at the end", 0) == 0) return true;
  return false;
}

bool any_flag(const std::vector<FitParam>& params) {
  for (const FitParam& p : params)
    if (!p.flag.empty()) return true;
  return false;
}

std::string describe(const Part& p, const Model& base) {
  if (!p.entry && p.free.empty()) {
    char buf[300];
    std::snprintf(buf, sizeof buf,
                  "the paper's own parameters, held at its values: sigma_long %.3g N/rpm, sigma_lat %.3g N/rpm, D_x %.4g "
                  "N/(m/s), D_y %.4g N/(m/s), D_psi %.3g N m/(rad/s)",
                  p.values[0], p.values[1], p.values[2], p.values[3], p.values[4]);
    return buf;
  }
  if (!p.entry) {
    char buf[300];
    std::snprintf(buf, sizeof buf,
                  "the paper's own parameters re-identified: sigma_long %.3g N/rpm (was %.3g), sigma_lat %.3g N/rpm "
                  "(was %.3g), D_x %.4g N/(m/s) (was %.4g), D_y %.4g N/(m/s) (was %.4g), D_psi %.3g N m/(rad/s) (was %.3g)",
                  p.values[0], base.terrain.sigma_long, p.values[1], base.terrain.sigma_lat, p.values[2],
                  base.terrain.D_x, p.values[3], base.terrain.D_y, p.values[4], base.terrain.D_psi);
    return buf;
  }
  return p.entry->describe ? p.entry->describe(p.values) : p.entry->doc;
}

FittedEffect fitted_effect(const Part& p, const Model& base, const std::vector<FitParam>& all, std::size_t& k) {
  FittedEffect fe;
  fe.effect = p.id;
  for (std::size_t i = 0; i < p.specs.size() && k < all.size(); ++i) fe.params.push_back(all[k++]);
  fe.description = describe(p, base);
  fe.held = p.free.empty();
  return fe;
}

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
  if (any({"coulomb_friction", "stick_slip_friction", "screw_dead_band", "screw_blocking"}))
    return "slow moves with all screws at one low speed, then with one pair fast and one slow: a dead band "
           "depends on each screw's speed, dry friction on the body's motion, blocking on a screw standing "
           "still while the others push; a breakaway shows in starts from rest";
  if (is("imu_heading_bias", "imu_heading_drift"))
    return "a longer log or two logs minutes apart: a drift grows with time, a bias stays";
  if (any({kPaperParams, "quadratic_drag", "traction_saturation", "terrain_change"}))
    return "runs at constant 5, 10, 15, 20 rpm: linear drag gives speeds proportional to omega, quadratic drag "
           "and saturation flatten the fast end, a terrain change shows as a step in time";
  if (any({"terrain_slope", "resistance_offset"}))
    return "the same path driven at two headings: a slope depends on the heading, a resistance offset does not";
  if (any({"yaw_time_constant", "force_lag", "rigid_body_coupling"}))
    return "quick turns on the spot, then quick turns while driving forward: a yaw time constant shapes every "
           "turn, a force lag every start, the Coriolis coupling only turns made while moving";
  return "a log that excites both: vary speed, direction and heading";
}

std::vector<std::string> candidate_ids(const Dataset& d, const std::vector<std::string>& only) {
  std::vector<std::string> ids;
  for (const auto& le : effect_library()) {
    if (!only.empty() && std::find(only.begin(), only.end(), le.id) == only.end()) continue;
    if (le.needs_imu && !d.active[kImuPsi]) continue;
    if (d.gantry && (le.needs_imu || le.yaw_only)) continue;
    ids.push_back(le.id);
  }
  return ids;
}

}  // namespace search

// ---------------------------------------------------------------- decimation
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
  double acc_t = 0, last_pose_s = -1e300;
  for (std::size_t k = 0; k < d.size(); ++k) {
    const double dt = k ? d.t_s[k] - d.t_s[k - 1] : 0.0;
    acc += dt * d.omega_rpm[k];
    acc_t += dt;
    const auto& m = d.meas[k];
    const bool pose = std::isfinite(m[kX]) && std::isfinite(m[kY]) && std::isfinite(m[kPsi]);
    const bool due = c.t_s.empty() || k + 1 == d.size() || (k + 1 < d.size() && d.t_s[k + 1] - c.t_s.back() > max_dt_s + 1e-9);
    // Dense poses (a 100 Hz gantry encoder) are thinned to the same max_dt_s; sparser ones are all
    // kept, whatever their phase against the rows kept in between.
    const bool spaced = d.t_s[k] - last_pose_s >= max_dt_s - 1e-9;
    if (!((pose && spaced) || due)) continue;
    if (pose && spaced) last_pose_s = d.t_s[k];
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
    p.id = search::kPaperParams;
    p.summary = "re-identification of the paper's own parameters sigma_long, sigma_lat, D_x, D_y, D_psi "
                "(eqs. (15)-(17)); written to the model file's [terrain.NAME], not as an [[effect]]";
    RobotParams rp;
    p.params = search::make_part(search::kPaperParams, make_model(rp, {"sand", 0.812, 0.247, 560.33, 320.08, 11.46}),
                                 Dataset{})
                   .specs;
    for (const auto& s : p.params) p.units.push_back(s.unit);
    out.push_back(p);
  }
  // Effects a rail (one module, yaw held) cannot show: the centre of resistance, the yaw
  // inertia, turning couplings, a blocked screw's moment.
  static const char* yaw_only[] = {"resistance_offset", "yaw_time_constant", "rigid_body_coupling", "screw_blocking"};
  for (const auto& [id, e] : EffectRegistry::builtin().entries()) {
    LibraryEffect le;
    le.id = id;
    le.summary = e.doc;
    le.params = e.params;
    for (const auto& s : e.params) le.units.push_back(s.unit);
    le.needs_imu = e.needs_imu;
    le.yaw_only = std::find(std::begin(yaw_only), std::end(yaw_only), id) != std::end(yaw_only);
    out.push_back(le);
  }
  return out;
}

}  // namespace auger::wb
