// The engine of `fit` (docs/workbench.md): the paper's parameters re-identified together with the
// effects added, polished on the full log, and the model file that fit and explain write.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "discover.hpp"
#include "fitting.hpp"

namespace auger::wb {

using namespace search;

namespace {

FitResult fit_on_this_thread(const Dataset& full, ModelChoice mc, const std::vector<std::string>& ids, bool progress,
                             const std::vector<std::pair<std::string, std::string>>& terms,
                             const std::vector<std::string>& hold) {
  FitResult res;
  res.before = mc;
  const Model& base = mc.model;
  NoiseColour colour;
  res.noise_floor = estimate_noise_floor(full, &colour);
  res.segment_floor = segment_floor(res.noise_floor, colour);
  const Dataset data = decimate_for_search(full);
  const Problem pr = make_problem(data, full, base, res.segment_floor, make_segments(data, search_segment_s(data)));
  std::vector<Part> parts{make_part(kPaperParams, base, data)};
  for (const std::string& name : hold) {
    Part& pp = parts.front();
    std::size_t i = 0;
    while (i < pp.specs.size() && pp.specs[i].name != name) ++i;
    if (i == pp.specs.size())
      throw std::invalid_argument("--hold " + name + ": paper_params has sigma_long, sigma_lat, D_x, D_y, D_psi");
    pp.free.erase(std::remove(pp.free.begin(), pp.free.end(), static_cast<int>(i)), pp.free.end());
  }
  for (const auto& id : ids)
    if (id != kPaperParams) parts.push_back(make_part(id, base, data));
  for (const auto& [dof, form] : terms) parts.push_back(make_term_part(dof, form, term_scale(base, data, dof, form)));
  // First each effect alone from the paper's parameters (so its start is sensible), then all
  // together with the paper's parameters, eqs. (15)-(17).
  for (std::size_t p = 1; p < parts.size(); ++p) {
    FitOutcome o = fit_candidate(pr, {}, parts[p], 12);
    if (std::isfinite(o.cost)) parts[p] = o.parts.back();
    if (progress) std::fprintf(stderr, "fit: %s alone done (%d simulations)\n", parts[p].id.c_str(), o.sims);
  }
  FitOutcome o = research_change_times(pr, refit(pr, parts, 20), 20);
  if (progress) std::fprintf(stderr, "fit: joint fit done (%d simulations)\n", o.sims);
  // A last polish on the full log as compare runs it (10 ms rows, 25 s segments): the decimated
  // log's 50 ms steps differ from it by a little, which matters once the fit is near the noise.
  if (std::isfinite(o.cost) && full.size() != data.size()) {
    Problem pf = pr;
    LogTerm& t = pf.terms.front();
    t.data = &full;
    t.segs = make_segments(full, 25.0);
    t.options.n_sub = SimOptions{}.n_sub;
    build_index(t);  // force_noise as pr's: both from the full log
    FitOutcome polished = levenberg_marquardt(pf, o.parts, 6);
    if (progress) std::fprintf(stderr, "fit: polished on the full log (%d simulations)\n", polished.sims);
    if (std::isfinite(polished.cost)) {
      // Keep the decimated fit's statistics (same parameters, n_eff below from its residuals).
      o.parts = polished.parts;
      Eigen::VectorXd r;
      Workspace work;
      if (residuals(pr, o.parts, r, work)) {
        o.r = r;
        o.cost = r.squaredNorm();
      }
    }
  }
  if (!std::isfinite(o.cost)) throw std::runtime_error("the fit failed: no parameter set gives a valid model");
  o = settle_stalls(pr, std::move(o));  // a size the stalled robot bounds only from below
  const double n = static_cast<double>(o.r.size());
  const double n_eff = effective_n(n, lag1_autocorrelation(pr, o.r));
  const std::vector<FitParam> all_params = fit_params(o, o.cost / std::max(1.0, n - o.n_params) * n / n_eff);
  std::size_t k = 0;
  for (const Part& p : o.parts) {
    res.effects.push_back(fitted_effect(p, base, all_params, k));
  }
  res.after = mc;
  res.after.model = build(base, o.parts);
  res.after.online = online_marks(mc.online, base.effects.size(), o.parts);
  res.after.source = "fitted from " + data.path;
  // Reported as compare reports it (segments of 25 s), so the two commands agree.
  Prediction p;
  simulate(base, full, sim_options_for(base), p);
  res.err_before = error_stats(full, p, res.segment_floor);
  simulate(res.after.model, full, sim_options_for(res.after.model), p);
  res.err_after = error_stats(full, p, res.segment_floor);
  res.model_toml = write_model_file(fitted_model_file(res.after.model, data, res.effects, res.after.online));
  return res;
}

}  // namespace

FitResult fit(const Dataset& full, ModelChoice mc, const std::vector<std::string>& ids, bool progress,
              const std::vector<std::pair<std::string, std::string>>& terms, const std::vector<std::string>& hold,
              int threads) {
  // One task: the other threads, idle from the start, take the columns of its Jacobians
  // (share_loop), where most of a fit's simulations are.
  FitResult res;
  run_parallel(threads, {0}, [](std::size_t) { return -1; },
               [&](std::size_t) { res = fit_on_this_thread(full, std::move(mc), ids, progress, terms, hold); });
  return res;
}

// ---------------------------------------------------------------- model file
ModelFile fitted_model_file(const Model& m, const Dataset& d, const std::vector<FittedEffect>& effects,
                            const std::vector<std::vector<std::string>>& online) {
  ModelFile f;
  f.comment = "Written by auger fit from " + d.path + " (docs/workbench.md). Schema: docs/model.md.";
  if (d.gantry)
    f.gantry_mass_kg = m.robot.m_kg;
  else
    f.robot = m.robot;
  TerrainEntry t;
  t.params = m.terrain;
  if (t.params.name.empty()) t.params.name = "sand";
  if (d.gantry) t.params.D_psi = kNaN;
  bool refitted = false;
  for (const auto& fe : effects) refitted = refitted || (fe.effect == kPaperParams && !fe.held);
  t.comment = refitted ? "paper_params (eqs. (15)-(17)), re-identified" : "paper_params (eqs. (15)-(17)), not refitted here";
  f.terrains.push_back(t);
  std::map<std::string, int> seen;  // the n-th model effect of an id is the n-th fitted one (several terms)
  for (std::size_t i = 0; i < m.effects.size(); ++i) {
    const auto& e = m.effects[i];
    EffectConfig c;
    c.id = e->id();
    int n = seen[c.id]++;
    for (const auto& fe : effects)
      if (fe.effect == e->id() && n-- == 0) c.comment = fe.description;
    for (const auto& [name, value] : e->params()) {
      c.params.push_back({name, value, 0, 0});
      c.params.back().online = i < online.size() && std::count(online[i].begin(), online[i].end(), name) > 0;
    }
    for (const auto& [name, value] : e->text_params()) c.texts.push_back({name, value, 0, 0});
    f.effects.push_back(std::move(c));
  }
  return f;
}

}  // namespace auger::wb
