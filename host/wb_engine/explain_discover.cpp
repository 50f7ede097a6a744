// explain's discovered terms (explain_internal.hpp, discover.hpp, docs/workbench.md "Discovered
// terms"): when the library's best model does not fit a log in form, the missing term is sought in
// a dictionary of physically meaningful forms by sparse regression of what the model leaves. Each
// dictionary term's effect on the simulated residuals is computed by one simulation (the model
// is linear in a small added force, eqs. (6)-(8)); forward selection picks terms on the training
// segments while they lower the held-out error; the chosen terms are then refitted jointly with
// the model by simulation error, and library effects that only stood in for them leave.
#include <algorithm>
#include <cstdio>
#include <limits>
#include <mutex>

#include "auger/term_form.hpp"
#include "discover.hpp"
#include "explain_internal.hpp"

namespace auger::wb::explain_internal {

using namespace search;

namespace {

constexpr int kMaxTerms = 4;

Part term_part(const DictionaryTerm& d, double coefficient) {
  Part p = make_term_part(d.dof, d.form, d.scale);
  p.values[0] = coefficient;
  return p;
}

}  // namespace

bool Explainer::discover(FitOutcome& o, ExplainResult& res) {
  const std::vector<DictionaryTerm> dict = term_dictionary(ctx_.front().base, ctx_.front().data);
  if (dict.empty() || !folds_) return false;
  // The model as the training segments of the search's split fit it: the regression is judged on
  // segments neither saw.
  FitOutcome base = refit(fit_on(0), o.parts, 10, 0);
  ++structures_;
  if (!std::isfinite(base.cost)) return false;
  Eigen::VectorXd r_train, r_held;
  {
    Workspace w;
    if (!residuals(fit_on(0), base.parts, r_train, w) || !residuals(judge_[0], base.parts, r_held, w)) return false;
  }
  const auto P = static_cast<Eigen::Index>(dict.size());
  Eigen::MatrixXd S_train = Eigen::MatrixXd::Zero(r_train.size(), P), S_held = Eigen::MatrixXd::Zero(r_held.size(), P);
  std::vector<std::size_t> all(dict.size());
  for (std::size_t j = 0; j < all.size(); ++j) all[j] = j;
  search::run_parallel(opt_.threads, all, [](std::size_t) { return -1; }, [&](std::size_t j) {
    std::vector<Part> with = base.parts;
    with.push_back(term_part(dict[j], dict[j].scale));
    Eigen::VectorXd a, b;
    Workspace w;
    if (!residuals(fit_on(0), with, a, w) || !residuals(judge_[0], with, b, w)) return;
    S_train.col(static_cast<Eigen::Index>(j)) = a - r_train;
    S_held.col(static_cast<Eigen::Index>(j)) = b - r_held;
  });
  structures_ += static_cast<int>(dict.size());
  const double n_eff = n_eff_of(base, fit_on(0));
  // A term chosen from the dictionary pays for the choice among its P columns as well as for its
  // coefficient (a BIC of 10 plus 2 ln P), and must lower the held-out error by 2 % as an effect must.
  const double min_bic = -kAddBic + 2.0 * std::log(static_cast<double>(P));
  const double min_held = 1.0 - (1.0 - kAddHeldout) * (1.0 - kAddHeldout);
  const Selection sel = select_terms(r_train, S_train, r_held, S_held, n_eff, kMaxTerms, min_held, min_bic);
  progress("explain: discovery: %zu dictionary terms, %zu chosen on the training segments (held-out residual %.0f -> %.0f)",
           dict.size(), sel.columns.size(), sel.heldout_rss.front(), sel.heldout_rss.back());
  if (sel.columns.empty()) return false;
  for (std::size_t k = 0; k < sel.columns.size(); ++k) {
    const DictionaryTerm& d = dict[static_cast<std::size_t>(sel.columns[k])];
    detail("explain: discovery:   %s: %s, coefficient %.4g (held-out residual then %.0f)", d.dof.c_str(), d.form.c_str(),
           sel.coefficients[static_cast<Eigen::Index>(k)] * d.scale, sel.heldout_rss[k + 1]);
  }

  // The chosen terms refitted with the model by simulation error on every segment, from the
  // linearized coefficients scaled back as far as the simulation says (a large term changes the
  // motion it depends on, and the linear step overshoots).
  auto with_terms = [&](double scale) {
    std::vector<Part> parts = o.parts;
    for (std::size_t k = 0; k < sel.columns.size(); ++k) {
      const DictionaryTerm& d = dict[static_cast<std::size_t>(sel.columns[k])];
      parts.push_back(term_part(d, scale * sel.coefficients[static_cast<Eigen::Index>(k)] * d.scale));
    }
    return parts;
  };
  double best_scale = 1.0, best_cost = std::numeric_limits<double>::infinity();
  for (double scale : {1.0, 0.5, 0.25, 0.1}) {
    Eigen::VectorXd r;
    Workspace w;
    if (!residuals(all_, with_terms(scale), r, w)) continue;
    if (r.squaredNorm() < best_cost) {
      best_cost = r.squaredNorm();
      best_scale = scale;
    }
  }
  FitOutcome with = refit(all_, with_terms(best_scale), 15, 1);
  ++structures_;
  if (!std::isfinite(with.cost)) return false;
  const double err_before = compare_error(o.parts);
  std::vector<RemovedEffect> stand_ins;
  // Library effects that stood in for the missing term (a slope, a terrain change fitted to a
  // force no library effect has) leave when the model predicts as well without them.
  for (bool again = true; again;) {
    again = false;
    const double err = compare_error(with.parts);
    for (std::size_t i = 0; i < with.parts.size(); ++i) {
      const Part& p = with.parts[i];
      if (!p.entry || !p.texts.empty()) continue;
      std::vector<Part> without = with.parts;
      without.erase(without.begin() + static_cast<std::ptrdiff_t>(i));
      FitOutcome w = refit(all_, without, 12, 1);
      ++structures_;
      if (!std::isfinite(w.cost) || compare_error(w.parts) > err * (1.0 + kAddHeldout)) continue;
      stand_ins.push_back({label(p, ctx_.size()),
                             "removed: with the discovered term the model predicts as well without it (it stood in for "
                             "the missing term)",
                             kNaN});
      progress("explain: discovery: %s no longer pays with the discovered terms; removed", label(p, ctx_.size()).c_str());
      with = std::move(w);
      again = true;
      break;
    }
  }
  // Each term must be physically significant as an effect must, and the whole must predict the
  // 25 s segments 2 % better than the library model.
  for (bool again = true; again;) {
    again = false;
    for (std::size_t i = 0; i < with.parts.size(); ++i) {
      if (with.parts[i].texts.empty()) continue;
      const ChannelValues c = contribution(with.parts, i);
      double m = 0;
      for (double v : c)
        if (std::isfinite(v)) m = std::max(m, v);
      if (m >= kMinContribution) continue;
      std::vector<Part> rest = with.parts;
      rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(i));
      FitOutcome w = refit(all_, rest, 12, 1);
      ++structures_;
      if (!std::isfinite(w.cost)) continue;
      with = std::move(w);
      again = true;
      break;
    }
  }
  polish(with);
  bool any_term = false;
  for (const Part& p : with.parts) any_term = any_term || !p.texts.empty();
  const double err_after = compare_error(with.parts);
  progress("explain: discovery: the 25 s segments %.3f times the noise floor with the terms, %.3f without", err_after,
           err_before);
  if (!any_term || !(err_after <= (1.0 - kAddHeldout) * err_before)) return false;  // (the stand-ins stay)
  res.removed.insert(res.removed.end(), stand_ins.begin(), stand_ins.end());
  // The groups, per dof in the order first chosen, each with the error of the terms so far.
  const double n = static_cast<double>(with.r.size());
  const double s2 = with.cost / std::max(1.0, n - with.n_params) * n / n_eff_of(with, all_);
  const std::vector<FitParam> params = fit_params(with, s2);
  std::vector<Part> so_far;
  for (const Part& p : with.parts)
    if (p.texts.empty()) so_far.push_back(p);
  std::size_t k = 0;
  for (std::size_t i = 0; i < with.parts.size(); ++i) {
    const Part& p = with.parts[i];
    const std::size_t at = k;
    k += p.specs.size();
    if (p.texts.empty()) continue;
    const TermForm f(p.texts[0], p.texts[1]);
    DiscoveredTerm t;
    t.dof = f.dof_text();
    t.form = f.form_text();
    t.inputs = f.input_names();
    t.coefficient = p.values[0];
    t.uncertainty = params[at].sigma;
    t.unit = f.coefficient_unit();
    t.description = f.describe(p.values[0]);
    double m = 0;
    for (double v : contribution(with.parts, i))
      if (std::isfinite(v)) m = std::max(m, v);
    t.contribution = m;
    auto g = std::find_if(res.discovered.begin(), res.discovered.end(),
                          [&](const DiscoveredGroup& x) { return x.channel == t.dof; });
    if (g == res.discovered.end()) {
      res.discovered.push_back({t.dof, {}, {}});
      g = res.discovered.end() - 1;
    }
    g->terms.push_back(t);
  }
  for (DiscoveredGroup& g : res.discovered) {
    for (const Part& p : with.parts)
      if (!p.texts.empty() && p.texts[0] == g.channel) so_far.push_back(p);
    compare_error(so_far, &g.ratio_after);
  }
  o = std::move(with);
  return true;
}

}  // namespace auger::wb::explain_internal
