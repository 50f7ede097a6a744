// The effect search's machinery (search.hpp, docs/workbench.md): each model under test is fitted
// by simulation error over segments re-initialised from the measured pose (not by regression on
// differentiated data), with Levenberg-Marquardt on finite-difference Jacobians, from several
// starting points, on training segments; judged on held-out segments.
#include "fitting.hpp"

#include "auger/online_estimator.hpp"
#include "auger/term_form.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace auger::wb {
namespace search {
namespace {

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
  // The absolute limits are the core's (auger/online_estimator.hpp), which clamps the online
  // estimate to them.
  auto r = [](int k) { return terrain_range(k); };
  std::vector<ParamSpec> s = {
      spec("sigma_long", t.sigma_long, "eq. (7), N per rpm", "N/rpm", 1e-3, 100, r(0).lower, r(0).upper),
      spec("sigma_lat", t.sigma_lat, "eq. (7), N per rpm", "N/rpm", 1e-3, 100, r(1).lower, r(1).upper),
      spec("D_x", t.D_x, "eq. (6)", "N/(m/s)", 1, 1e5, r(2).lower, r(2).upper),
      spec("D_y", t.D_y, "eq. (6)", "N/(m/s)", 1, 1e5, r(3).lower, r(3).upper),
      spec("D_psi", t.D_psi, "eq. (6)", "N m/(rad/s)", 0.01, 1e4, r(4).lower, r(4).upper)};
  if (d.gantry) {
    const bool lon = d.axis == "longitudinal";
    s[lon ? 1 : 0].fitted = false;
    s[lon ? 3 : 2].fitted = false;
    s[4].fitted = false;
  }
  return s;
}

// Without a pose only the IMU heading is compared (docs/workbench.md "A log without pose"): these
// parameters act on x and y alone (or are the IMU heading's offset, which each segment's start
// on the IMU heading takes up) and are held at their defaults.
bool acts_only_without_yaw(const std::string& id, const std::string& param) {
  static const std::vector<std::pair<std::string, std::vector<std::string>>> held = {
      {kPaperParams, {"sigma_long", "sigma_lat", "D_x", "D_y"}},
      {"coulomb_friction", {"force_x_n", "force_y_n"}},
      {"stick_slip_friction", {"force_x_n", "force_y_n"}},
      {"quadratic_drag", {"c_x_nspm2", "c_y_nspm2"}},
      {"imu_heading_drift", {"bias_rad"}}};
  for (const auto& [effect, params] : held)
    if (effect == id) return std::find(params.begin(), params.end(), param) != params.end();
  return false;
}

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
    const bool usable = (!d.gantry || dof < 0 || dof == active_dof) &&
                        (d.gantry || d.has_pose() || !acts_only_without_yaw(id, s.name));
    if (s.fitted && !s.integer && usable) p.free.push_back(static_cast<int>(i));
  }
  return p;
}

Part make_term_part(const std::string& dof, const std::string& form, double typical_coefficient) {
  const TermForm f(dof, form);  // checks both
  Part p;
  p.id = "term";
  const auto& entries = EffectRegistry::builtin().entries();
  p.entry = &entries.at(p.id);
  p.specs = p.entry->params;
  p.specs[0].typical = typical_coefficient > 0 && std::isfinite(typical_coefficient) ? typical_coefficient : 1.0;
  p.specs[0].unit = f.coefficient_unit();
  p.values = {0.0};
  p.free = {0};
  p.texts = {f.dof_text(), f.form_text()};
  return p;
}

std::vector<Part> parts_of(const Model& model, const Dataset& d, const std::vector<std::vector<std::string>>& online) {
  std::vector<Part> out;
  for (const auto& e : model.effects) {
    const auto texts = e->text_params();
    Part p;
    if (!texts.empty()) {
      // A discovered term: its coefficient's typical size from its value.
      const double c = e->params().front().second;
      p = make_term_part(texts.at(0).second, texts.at(1).second, std::fabs(c) > 0 ? std::fabs(c) : 1.0);
      p.values = {c};
    } else {
      p = make_part(e->id(), model, d);
      const auto values = e->params();
      for (std::size_t k = 0; k < p.values.size() && k < values.size(); ++k) p.values[k] = values[k].second;
    }
    if (out.size() < online.size()) p.online = online[out.size()];
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
      effects.push_back(p.entry->build(p.values, p.texts));
    }
  }
  return make_model(base.robot, t, std::move(effects));
}

std::vector<std::vector<std::string>> online_marks(const std::vector<std::vector<std::string>>& base_online,
                                                   std::size_t base_effects, const std::vector<Part>& parts, int log) {
  std::vector<std::vector<std::string>> out(base_effects);
  for (std::size_t i = 0; i < base_effects && i < base_online.size(); ++i) out[i] = base_online[i];
  for (const Part& p : parts)
    if (p.entry && (p.log < 0 || p.log == log)) out.push_back(p.online);
  return out;
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
    const SimOptions own = sim_options_for(m);
    o.pose_delay_s = own.pose_delay_s;
    o.warm_s = own.warm_s;
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
  c.pose_t_s.clear();
  Vec4 acc = Vec4::Zero();
  double acc_t = 0, last_pose_s = -1e300;
  for (std::size_t k = 0; k < d.size(); ++k) {
    const double dt = k ? d.t_s[k] - d.t_s[k - 1] : 0.0;
    acc += dt * d.omega_rpm[k];
    acc_t += dt;
    const auto& m = d.meas[k];
    const bool pose = is_start_row(d, k);
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
    if (!d.pose_t_s.empty()) c.pose_t_s.push_back(d.pose_t_s[k]);
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
    for (const auto& s : p.params) {
      p.units.push_back(s.unit);
      if (search::acts_only_without_yaw(p.id, s.name)) p.held_without_pose.push_back(s.name);
    }
    out.push_back(p);
  }
  // Effects a rail (one module, yaw held) cannot show: the centre of resistance, the yaw
  // inertia, turning couplings, a blocked screw's moment.
  static const char* yaw_only[] = {"resistance_offset", "yaw_time_constant", "rigid_body_coupling", "screw_blocking"};
  // Effects the IMU heading alone cannot show: forces along x and y only, the pose's own timing,
  // and the IMU's offset (each segment starts on the IMU heading).
  static const char* needs_pose[] = {"terrain_slope", "rigid_body_coupling", "pose_time_offset", "imu_heading_bias"};
  for (const auto& [id, e] : EffectRegistry::builtin().entries()) {
    if (!e.text_params.empty()) continue;  // a discovered term: proposed by explain, not a candidate
    LibraryEffect le;
    le.id = id;
    le.summary = e.doc;
    le.params = e.params;
    for (const auto& s : e.params) le.units.push_back(s.unit);
    le.needs_imu = e.needs_imu;
    le.yaw_only = std::find(std::begin(yaw_only), std::end(yaw_only), id) != std::end(yaw_only);
    le.needs_pose = std::find(std::begin(needs_pose), std::end(needs_pose), id) != std::end(needs_pose);
    for (const auto& ps : e.params)
      if (search::acts_only_without_yaw(id, ps.name)) le.held_without_pose.push_back(ps.name);
    out.push_back(le);
  }
  return out;
}


}  // namespace auger::wb
