// explain's structures (explain_internal.hpp): a structure's state (its training cost, held-out
// error, flags), the paper's parameters where a fit stretched them to the end of their range, and
// change times placed from their own fit or inside a held-out gap.
#include <algorithm>
#include <set>

#include "explain_internal.hpp"

namespace auger::wb::explain_internal {

using namespace search;

// An effect part's label: terrain_change of one of several logs carries the log's number.
std::string label(const Part& p, std::size_t n_logs) {
  // A discovered term by its dof and form (every term's part is one generic entry, "term").
  const std::string name = p.texts.size() >= 2 ? p.texts[0] + ": " + p.texts[1] : p.id;
  if (p.log >= 0 && n_logs > 1) return name + "@" + std::to_string(p.log + 1);
  return name;
}

std::vector<std::string> effect_labels(const std::vector<Part>& parts, std::size_t n_logs) {
  std::vector<std::string> out;
  for (const Part& p : parts)
    if (p.entry) out.push_back(label(p, n_logs));
  return out;
}

std::string key_of(const std::vector<Part>& parts, std::size_t n_logs) {
  std::vector<std::string> ids = effect_labels(parts, n_logs);
  std::sort(ids.begin(), ids.end());
  std::string k;
  for (const auto& id : ids) k += id + ",";
  bool paper = false;
  for (const Part& p : parts) paper = paper || !p.entry;
  return k + (paper ? "+paper" : "");
}

// Held-out error of a structure, pooled over the logs per channel; where that is at the noise in
// every channel (the only case at_noise reads it), its error over every segment too.
void Explainer::heldout(State& s) const {
  ChannelPool pool;
  std::vector<Model> models;
  for (std::size_t i = 0; i < ctx_.size(); ++i) {
    models.push_back(build(ctx_[i].base, s.parts, static_cast<int>(i)));
    pool.add(segments_error(models.back(), ctx_[i].data, judged_on(ctx_[i], s.fold), ctx_[i].noise));
  }
  s.h = pool.combined(s.held);
  s.all_ratio = {kNaN, kNaN, kNaN, kNaN};
  for (double v : s.held)
    if (std::isfinite(v) && v > kAtNoise) return;
  ChannelPool all;
  for (std::size_t i = 0; i < ctx_.size(); ++i)
    all.add(segments_error(models[i], ctx_[i].data, ctx_[i].all, ctx_[i].noise));
  all.combined(s.all_ratio);
}

// Cost on the training segments of a structure as it stands (no fit).
void Explainer::evaluate(State& s) {
  Eigen::VectorXd r;
  Workspace w;
  if (!residuals(fit_on(s.fold), s.parts, r, w)) throw std::runtime_error("the given model cannot be simulated on this log");
  s.cost = r.squaredNorm();
  s.fit.parts = s.parts;
  s.fit.cost = s.cost;
  s.fit.r = r;
  s.n_params = 0;
  heldout(s);
}

std::vector<FittedEffect> Explainer::fitted_of(const State& s, double s2_scale) const {
  std::vector<FittedEffect> out;
  FitOutcome plain;
  plain.parts = s.parts;
  const std::vector<FitParam> all = fit_params(s.fit.JtJ.size() ? s.fit : plain, s.fit.JtJ.size() ? s2_scale : 1.0);
  std::size_t k = 0;
  for (const Part& p : s.parts) {
    FittedEffect fe = fitted_effect(p, base_for(p), all, k);
    if (p.entry) fe.effect = label(p, ctx_.size());
    if (!p.entry && ctx_.size() > 1) fe.description += " (terrain " + p.terrain + ")";
    out.push_back(fe);
  }
  return out;
}

const Model& Explainer::base_for(const Part& p) const {
  for (const LogCtx& c : ctx_)
    if (p.entry ? (p.log < 0 || &c == &ctx_[static_cast<std::size_t>(p.log)]) : c.base.terrain.name == p.terrain)
      return c.base;
  return ctx_.front().base;
}

// The paper's parameters of every terrain among the logs, free, before the effects (or held at
// the paper's values, where the structure so far holds them).
std::vector<Part> Explainer::with_paper(const std::vector<Part>& parts) const {
  std::vector<Part> out;
  for (const Part& p : parts)
    if (!p.entry) out.push_back(p);
  std::set<std::string> have;
  for (const Part& p : out) have.insert(p.terrain);
  for (const LogCtx& c : ctx_)
    if (!have.count(c.base.terrain.name)) {
      out.push_back(make_part(kPaperParams, c.base, c.data));
      have.insert(c.base.terrain.name);
    }
  for (const Part& p : parts)
    if (p.entry) out.push_back(p);
  return out;
}

// A fit whose paper parameters end at their physical range has taken up an effect it lacked
// (every force scaled up shortens every time constant). The same structure is refitted from
// the paper's values and each effect's own fit on the paper's model, where each effect can
// take its share back; the better fit is kept.
FitOutcome Explainer::from_scratch(FitOutcome o, int fold) {
  if (!paper_at_end(o) || !std::isfinite(o.cost)) return o;
  FitOutcome again = refit(fit_on(fold), paper_start(o.parts, false), 10, 1);
  ++structures_;
  again.sims += o.sims;
  if (again.cost < o.cost) return again;
  o.sims = again.sims;
  return o;
}

// The parts with the paper's parameters back at the paper's values (held, or free) and each
// effect at its own fit on the paper's model (the first step's), where there is one.
std::vector<Part> Explainer::paper_start(std::vector<Part> start, bool hold) {
  for (Part& p : start) {
    if (!p.entry) {
      for (std::size_t i = 0; i < p.values.size(); ++i) p.values[i] = p.specs[i].default_value;
      if (hold) p.free.clear();
      continue;
    }
    std::lock_guard<std::mutex> lock(alone_mutex_);
    const auto it = alone_.find(p.id + "@" + std::to_string(p.log));
    if (it == alone_.end()) continue;
    for (std::size_t i = 0; i < p.values.size(); ++i)
      if (std::find(p.free.begin(), p.free.end(), static_cast<int>(i)) != p.free.end()) p.values[i] = it->second.values[i];
  }
  return start;
}

bool Explainer::paper_at_end(const FitOutcome& o) {
  for (const Part& p : o.parts) {
    if (p.entry || p.free.empty()) continue;
    std::vector<FitParam> f(p.specs.size());
    for (std::size_t i = 0; i < p.specs.size(); ++i) f[i].value = p.values[i];
    flag_params(f, p);
    for (const FitParam& x : f)
      if (x.flag.find("physical range") != std::string::npos) return true;
  }
  return false;
}

// The same structure with the paper's parameters held at the paper's values, where refitted
// they end at their range even after from_scratch: on a short log the training segments cannot
// tell a missing effect from stretched paper parameters, so the held-out segments judge. Held
// is a restriction: it is taken only when it predicts them better outright (not merely because
// the stretched fit counts 15 % worse for being implausible).
FitOutcome Explainer::paper_held_alternative(FitOutcome o, int fold) {
  if (!std::isfinite(o.cost) || !paper_at_end(o)) return o;
  FitOutcome held = refit(fit_on(fold), paper_start(o.parts, true), 10, 1);
  ++structures_;
  held.sims += o.sims;
  if (!std::isfinite(held.cost)) {
    o.sims = held.sims;
    return o;
  }
  State parent;
  parent.fold = fold;
  const State a = make_state(parent, o), b = make_state(parent, held);
  detail("explain:   paper's parameters held: held-out %.3f%s against %.3f%s re-identified", b.h,
         b.implausible ? " (implausible)" : "", a.h, a.implausible ? " (implausible)" : "");
  if (b.h < a.h) return held;
  o.sims = held.sims;
  return o;
}

// A change of terrain placed on top of other effects may settle where it imitates them; the
// time its own fit on the paper's model found (the first step's) is tried as a start too.
FitOutcome Explainer::change_from_alone(FitOutcome o, int log, int fold) {
  Part alone;
  {
    std::lock_guard<std::mutex> lock(alone_mutex_);
    const auto it = alone_.find(std::string(kTerrainChange) + "@" + std::to_string(log));
    if (it == alone_.end()) return o;
    alone = it->second;
  }
  if (!std::isfinite(o.cost)) return o;
  std::vector<Part> start = o.parts;
  bool changed = false;
  for (Part& p : start)
    if (p.id == kTerrainChange && p.log == log && std::fabs(p.values[0] - alone.values[0]) > 1.0) {
      p.values = alone.values;
      changed = true;
    }
  if (!changed) return o;
  FitOutcome again = research_change_times(fit_on(fold), refit(fit_on(fold), start, 10, 1), 10);
  ++structures_;
  again.sims += o.sims;
  if (again.cost < o.cost) return again;
  o.sims = again.sims;
  return o;
}

// A change of terrain that falls in a held-out segment is placed in its gap by that segment
// (search::place_changes_in_gaps).
void Explainer::place_changes_in_gaps(std::vector<Part>& parts, int fold) const {
  for (std::size_t li = 0; li < ctx_.size(); ++li) {
    const LogCtx& c = ctx_[li];
    search::place_changes_in_gaps(parts, c.base, c.data, fitted_on(c, fold), judged_on(c, fold), c.noise,
                                  static_cast<int>(li));
  }
}

State Explainer::make_state(const State& parent, FitOutcome o) const {
  place_changes_in_gaps(o.parts, parent.fold);
  State s;
  s.fold = parent.fold;
  s.parts = o.parts;
  s.cost = o.cost;
  s.n_params = o.n_params;
  s.fit = std::move(o);
  s.history = parent.history;
  heldout(s);
  for (const FittedEffect& fe : fitted_of(s, s2_scale(s))) {
    s.flagged = s.flagged || any_flag(fe.params);
    s.implausible = s.implausible || any_implausible(fe.params);
  }
  return s;
}

// The residual variance of s's fit, times n / n_eff over the segments it was fitted on
// (fit_params' s2_scale).
double Explainer::s2_scale(const State& s) const {
  const double n = static_cast<double>(s.fit.r.size());
  return s.cost / std::max(1.0, n - s.n_params) * n / n_eff_of(s.fit, fit_on(s.fold));
}

}  // namespace auger::wb::explain_internal
