// explain's step (explain_internal.hpp): every library candidate fitted on top of a structure,
// the promising ones refitted jointly with everything, the significant ones taken (with the other
// splits' second opinion where the held-out segments alone refuse the strongest), each after the
// backward check that drops an effect no longer paying for itself.
#include <algorithm>
#include <set>

#include "explain_internal.hpp"

namespace auger::wb::explain_internal {

using namespace search;

std::vector<Explainer::Task> Explainer::tasks_for(const State& s) const {
  std::vector<Task> t;
  bool paper = false;
  for (const Part& p : s.parts) paper = paper || !p.entry;
  auto task = [&](const std::string& id, int log) {
    Task x;
    x.state = &s;
    x.id = id;
    x.log = log;
    return x;
  };
  if (!paper) t.push_back(task(kPaperParams, -1));
  for (const std::string& id : candidate_ids(ctx_.front().data, opt_.only)) {
    if (id == kPaperParams) continue;
    const bool per_log = id == kTerrainChange && ctx_.size() > 1;
    for (int log = per_log ? 0 : -1; log < (per_log ? static_cast<int>(ctx_.size()) : 0); ++log) {
      bool in = false;
      for (const Part& p : s.parts) in = in || (p.id == id && p.log == log);
      if (!in) t.push_back(task(id, log));
    }
  }
  // Stick-slip last, after the Coulomb fit it starts from. With a Coulomb friction chosen
  // already, stick-slip comes in its place (it contains it): on top of it, the two would share
  // the sliding level and the fit settles in a tiny stiction add-on that the backward check
  // then strands without its sliding part.
  std::stable_partition(t.begin(), t.end(), [](const Task& x) { return x.id != kStickSlip; });
  for (const Part& p : s.parts)
    if (p.entry && p.id == kCoulomb)
      for (Task& x : t)
        if (x.id == kStickSlip) x.replaces = kCoulomb;
  for (std::size_t i = 0; i < t.size(); ++i)
    if (t[i].id == kStickSlip)
      for (std::size_t j = 0; j < t.size(); ++j)
        if (t[j].id == kCoulomb) t[i].wait_for = static_cast<int>(j);
  return t;
}

// Two passes: every candidate fitted on top of the state held (cheap: only its own
// parameters), then the promising ones refitted jointly with everything (the expensive part).
// Promising: the five best by training cost on the first step (three later) and any that gains
// at least 10 % of what the best gains.
void Explainer::run_tasks(std::vector<Explainer::Task>& tasks, const State& s, int step) {
  std::vector<std::size_t> all(tasks.size());
  for (std::size_t i = 0; i < tasks.size(); ++i) all[i] = i;
  std::atomic<std::size_t> finished{0};
  const std::vector<Part> state = with_paper(s.parts);
  const Problem& pr = fit_on(s.fold);
  // The state without the part a task replaces, and that part as the task's start.
  auto base_of = [&](const Task& t) {
    std::vector<Part> b;
    for (const Part& p : state)
      if (t.replaces.empty() || !p.entry || p.id != t.replaces) b.push_back(p);
    return b;
  };
  run_parallel(tasks, all, [&](std::size_t i) {
    Task& t = tasks[i];
    if (t.id == kPaperParams) {
      t.out = refit(pr, state, 12, 1);
      t.joint = true;
    } else if (!t.replaces.empty()) {
      FitOutcome hint;
      for (const Part& p : state)
        if (p.entry && p.id == t.replaces) hint.parts = {p};
      hint.cost = s.cost;
      t.first = fit_candidate(pr, base_of(t), candidate_part(t), 12, &hint);
    } else {
      const FitOutcome* hint = t.wait_for >= 0 ? &tasks[static_cast<std::size_t>(t.wait_for)].first : nullptr;
      t.first = fit_candidate(pr, state, candidate_part(t), 12, hint);
    }
    ++structures_;
    detail("explain: step %d: %zu/%zu candidates fitted on top (%s, %d simulations)", step, ++finished,
             tasks.size(), t.id.c_str(), (t.joint ? t.out : t.first).sims);
  });
  std::vector<std::pair<double, std::size_t>> gains;
  double best_gain = 0;
  for (std::size_t i = 0; i < tasks.size(); ++i) {
    if (tasks[i].joint || !std::isfinite(tasks[i].first.cost)) continue;
    const double g = s.cost - tasks[i].first.cost;
    gains.push_back({g, i});
    best_gain = std::max(best_gain, g);
  }
  std::sort(gains.begin(), gains.end(), std::greater<>());
  std::vector<std::size_t> joint;
  // (Even one that gains nothing held on top: the state's own fit may have absorbed it.)
  // Stick-slip that gains no more than the Coulomb friction it contains is that friction, with
  // its breakaway unidentified: not refitted (it was the costliest joint fit).
  double coulomb_cost = std::numeric_limits<double>::infinity();
  for (const Task& t : tasks)
    if (t.id == kCoulomb && std::isfinite(t.first.cost)) coulomb_cost = t.first.cost;
  for (std::size_t k = 0; k < gains.size(); ++k) {
    const Task& t = tasks[gains[k].second];
    if (t.id == kStickSlip && t.first.cost >= coulomb_cost * (1.0 - 1e-3)) continue;
    if (k < (s.parts.empty() ? 5u : 3u) || (gains[k].first > 0 && gains[k].first >= 0.1 * best_gain) ||
        !t.replaces.empty())
      joint.push_back(gains[k].second);
  }
  // The longest first, so that the other thread does the rest meanwhile: a change of terrain's
  // joint refit profiles its time (a third to two thirds of a step's simulations), stick-slip
  // searches its breakaway. (Each joint refit is independent of the others: the order changes
  // only when each ends.)
  auto cost_rank = [&](std::size_t i) { return tasks[i].id == kTerrainChange ? 0 : tasks[i].id == kStickSlip ? 1 : 2; };
  std::stable_sort(joint.begin(), joint.end(), [&](std::size_t a, std::size_t b) { return cost_rank(a) < cost_rank(b); });
  for (Task& t : tasks) t.wait_for = -1;
  finished = 0;
  // Each effect's fit on the paper's model alone (the first step's), kept as a start.
  if (s.parts.empty())
    for (const Task& t : tasks)
      if (!t.joint && std::isfinite(t.first.cost) && !t.first.parts.empty()) {
        std::lock_guard<std::mutex> lock(alone_mutex_);
        alone_[t.id + "@" + std::to_string(t.log)] = t.first.parts.back();
      }
  run_parallel(tasks, joint, [&](std::size_t i) {
    Task& t = tasks[i];
    t.out = refit_joint(pr, t.replaces.empty() ? state : base_of(t), candidate_part(t), t.first, 10);
    t.out = from_scratch(std::move(t.out), s.fold);
    if (t.id == kTerrainChange) t.out = change_from_alone(std::move(t.out), t.log, s.fold);
    t.out = paper_held_alternative(std::move(t.out), s.fold);
    t.joint = true;
    ++structures_;
    detail("explain: step %d: %zu/%zu refitted jointly (%s, %d simulations)", step, ++finished, joint.size(),
             t.id.c_str(), t.out.sims);
  });
}

Part Explainer::candidate_part(const Task& t) const {
  Part cand = make_part(t.id, ctx_.front().base, ctx_[static_cast<std::size_t>(std::max(t.log, 0))].data);
  cand.log = t.log;
  return cand;
}

// Every candidate fitted on top of s, then the promising ones jointly: their states and their
// figures against s (false: none could be fitted).
bool Explainer::fit_candidates(const State& s, int step, StepCandidates& out) {
  std::vector<Task> tasks = tasks_for(s);
  run_tasks(tasks, s, step);
  std::vector<State>& cands = out.cands;
  std::vector<Candidate>& ranked = out.ranked;
  std::vector<std::string>&added = out.added, &replaced = out.replaced;
  double& n_eff = out.n_eff;
  {
    const FitOutcome* best = nullptr;
    for (const Task& t : tasks)
      if (t.joint && std::isfinite(t.out.cost) && (!best || t.out.cost < best->cost)) best = &t.out;
    if (!best) return false;
    n_eff = n_eff_of(*best, fit_on(s.fold));
  }
  for (Task& t : tasks) {
    if (!t.joint || !std::isfinite(t.out.cost)) continue;
    State e = make_state(s, std::move(t.out));
    Candidate c;
    c.fitted.effect = t.log >= 0 && ctx_.size() > 1 ? t.id + "@" + std::to_string(t.log + 1) : t.id;
    const std::vector<FittedEffect> f = fitted_of(e, 1.0);
    for (const FittedEffect& fe : f)
      if (fe.effect == c.fitted.effect) c.fitted = fe;
    c.train_cost = e.cost;
    c.delta_bic = delta_bic(s, e, n_eff);
    c.heldout_rms = e.held;
    c.heldout_ratio = e.h;
    c.flagged = e.flagged;
    c.implausible = e.implausible;
    detail("explain: step %d: candidate %s: held-out %.3f (x %.2f y %.2f psi %.2f imu_psi %.2f), delta BIC %.1f%s", step,
           c.fitted.effect.c_str(), e.h, e.held[0], e.held[1], e.held[2], e.held[3], c.delta_bic,
           e.implausible ? ", implausible" : "");
    for (const FittedEffect& fe : f) detail("explain:   %s: %s", fe.effect.c_str(), fe.description.c_str());
    ranked.push_back(c);
    cands.push_back(std::move(e));
    added.push_back(c.fitted.effect);
    replaced.push_back(t.replaces);
  }
  return true;
}

// Every candidate on top of s, jointly; the significant ones, best first, each after the
// backward check.
std::vector<State> Explainer::expand(const State& s, int step) {
  StepCandidates fitted;
  if (!fit_candidates(s, step, fitted)) return {};
  std::vector<State>& cands = fitted.cands;
  const std::vector<Candidate>& ranked = fitted.ranked;
  const std::vector<std::string>&added = fitted.added, &replaced = fitted.replaced;
  const double n_eff = fitted.n_eff;
  // Significant: a strong BIC gain and a clear drop of the held-out error (far from the noise,
  // a large drop of the held-out error alone: significant_gain).
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < cands.size(); ++i)
    if (significant_gain(ranked[i].delta_bic, s.h, cands[i].h)) order.push_back(i);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return score(cands[a]) < score(cands[b]);
  });
  // None passes both: the plausible one with the strongest BIC gain gets the other splits'
  // second opinion, once per branch, unless the held-out error is at the noise already (only
  // the residual tests kept the search going: nothing is left for a lucky split to hide).
  OtherSplits other;
  if (order.empty() && s.fold == 0 && folds_ && !at_noise(s)) {
    std::size_t pick = cands.size();
    for (std::size_t i = 0; i < cands.size(); ++i)
      if (ranked[i].delta_bic < kAddBic && !cands[i].implausible &&
          (pick == cands.size() || ranked[i].delta_bic < ranked[pick].delta_bic))
        pick = i;
    if (pick < cands.size() && other_splits(s, cands[pick], added[pick], other)) {
      other.refused_heldout = cands[pick].h;
      cands[pick] = std::move(other.cand[static_cast<std::size_t>(other.best)]);
      order.push_back(pick);
    }
  }
  if (order.empty()) {
    progress("explain: step %d: no candidate is significant (best held-out %.2f, the model %.2f times the noise)",
             step, cands.empty() ? kNaN : std::min_element(cands.begin(), cands.end(), [](const State& a, const State& b) { return a.h < b.h; })->h,
             s.h);
    return {};
  }
  std::vector<Candidate> sig;
  for (std::size_t i : order) sig.push_back(ranked[i]);
  // Near ties of the best (as diagnose marks neighbours): carried along in the beam.
  std::vector<char> tied(sig.size(), 0);
  for (std::size_t k = 1; k < sig.size(); ++k) {
    std::vector<Candidate> pair{sig.front(), sig[k]};
    mark_near_ties(pair);
    if (pair[1].near_tie) {
      tied[k] = 1;
      sig[k].tell_apart = pair[1].tell_apart;
    }
  }
  // The best few go on (a beam: the next step may show that the second was the right one);
  // near ties of the best are listed with it as alternatives.
  std::vector<State> out;
  for (std::size_t j = 0; j < order.size() && static_cast<int>(out.size()) < opt_.beam; ++j) {
    const std::size_t i = order[j];
    const bool on_other = cands[i].fold != s.fold;
    const double n_eff_i = on_other ? n_eff_of(cands[i].fit, fit_on(cands[i].fold)) : n_eff;
    State e = backward(std::move(cands[i]), added[i], n_eff_i);
    ExplainStep st;
    st.index = static_cast<int>(s.history.size());
    st.added = added[i];
    st.dropped = dropped_;
    if (!replaced[i].empty()) st.dropped.insert(st.dropped.begin(), replaced[i]);
    st.effects = effect_labels(e.parts, ctx_.size());
    st.heldout_ratio = e.held;
    st.heldout_combined = e.h;
    st.delta_bic = ranked[i].delta_bic;
    st.flagged = e.flagged;
    st.implausible = e.implausible;
    st.paper_held = paper_held(e.parts);
    st.split = e.fold + 1;
    if (on_other) {
      st.second_opinion = true;
      st.refused_heldout = other.refused_heldout;
      st.refused_from = s.h;
      for (int f = 1; f < kFolds; ++f) {
        const auto fi = static_cast<std::size_t>(f);
        st.split_heldout.push_back(other.cand[fi].h);
        st.split_from.push_back(other.parent[fi].h);
        st.split_delta_bic.push_back(other.delta_bic[fi]);
      }
    }
    st.fitted = fitted_of(e, s2_scale(e));
    for (std::size_t k = 0; k < sig.size(); ++k)
      if (k != j && (tied[k] || (j > 0 && k == 0))) {
        st.alternatives.push_back(sig[k]);
        if (j > 0 && k == 0) st.alternatives.back().tell_apart = sig[j].tell_apart;
      }
    e.history.push_back(st);
    progress("explain: step %d: + %s: held-out error %.2f times the noise floor (was %.2f%s), delta BIC %.1f%s",
             step, added[i].c_str(), e.h, on_other ? other.parent[static_cast<std::size_t>(other.best)].h : s.h,
             on_other ? (" on split " + std::to_string(other.best + 1)).c_str() : "",
             ranked[i].delta_bic,
             !replaced[i].empty() ? " (in place of the Coulomb friction)" : dropped_.empty() ? "" : " (dropped some)");
    out.push_back(std::move(e));
  }
  return out;
}

bool Explainer::other_splits(const State& s, const State& c, const std::string& id, OtherSplits& out) {
  bool pass = true;
  std::string words;
  for (int f = 1; f < kFolds && pass; ++f) {
    const auto fi = static_cast<std::size_t>(f);
    State p;
    p.fold = f;
    p.history = s.history;
    if (s.n_params == 0) {
      p.parts = s.parts;  // the model as given: nothing to refit
      evaluate(p);
    } else {
      FitOutcome o = refit(fit_on(f), s.parts, 10, 1);
      ++structures_;
      if (!std::isfinite(o.cost)) return false;
      p = make_state(p, std::move(o));
    }
    FitOutcome o = refit(fit_on(f), c.parts, 10, 1);
    ++structures_;
    if (!std::isfinite(o.cost)) return false;
    out.cand[fi] = make_state(p, std::move(o));
    out.delta_bic[fi] = delta_bic(p, out.cand[fi], n_eff_of(out.cand[fi].fit, fit_on(f)));
    out.parent[fi] = std::move(p);
    const State& a = out.cand[fi];
    pass = significant_gain(out.delta_bic[fi], out.parent[fi].h, a.h) && !a.implausible;
    char buf[160];
    std::snprintf(buf, sizeof buf, "%s split %d: %.2f against %.2f, delta BIC %.1f%s", words.empty() ? "" : ";", f + 1,
                  a.h, out.parent[fi].h, out.delta_bic[fi], a.implausible ? ", implausible" : "");
    words += buf;
  }
  if (pass && out.cand[2].h < out.cand[1].h) out.best = 2;
  progress("explain: %s refused by the held-out segments alone (%.2f against %.2f); %s: %s", id.c_str(), c.h, s.h,
           words.c_str(), pass ? "taken" : "refused there too");
  return pass;
}

// Drops effects that no longer pay for themselves: removing one must cost more than its BIC
// penalty and raise the held-out error, or it goes.
State Explainer::backward(State e, const std::string& just_added, double n_eff) {
  dropped_.clear();
  for (bool again = true; again;) {
    again = false;
    for (std::size_t i = 0; i < e.parts.size(); ++i) {
      const Part& p = e.parts[i];
      if (!p.entry || label(p, ctx_.size()) == just_added) continue;
      std::vector<Part> without = e.parts;
      without.erase(without.begin() + static_cast<std::ptrdiff_t>(i));
      FitOutcome o = refit(fit_on(e.fold), without, 10, 1);
      ++structures_;
      if (!std::isfinite(o.cost)) continue;
      State w = make_state(e, std::move(o));
      const double gain_bic = delta_bic(w, e, n_eff);  // negative: e is better than w
      // It pays when it is worth its parameters on the training segments and helps on the held-out
      // ones; an effect whose removal raises the held-out error by as much as an effect must lower
      // it (2 %) stays whatever the training segments say (a joint fit that stopped short of its
      // optimum can leave it looking worthless there).
      const bool pays = (gain_bic < -2.0 && w.h > e.h * 1.002) || w.h > e.h * (1.0 + kAddHeldout);
      if (!pays) {
        progress("explain: backward check: %s no longer pays for itself (delta BIC %.1f, held-out %.3f without, %.3f with); dropped",
                 label(p, ctx_.size()).c_str(), gain_bic, w.h, e.h);
        dropped_.push_back(label(p, ctx_.size()));
        w.history = e.history;
        e = std::move(w);
        again = true;
        break;
      }
    }
  }
  return e;
}

}  // namespace auger::wb::explain_internal
