// explain's discovered terms (explain_internal.hpp, discover.hpp, docs/workbench.md "Discovered
// terms"): when the library's best model does not fit a log in form, the missing term is sought in
// a dictionary of physically meaningful forms that no library effect has, by sparse regression of
// what a model leaves. Each dictionary term's effect on the simulated residuals is one simulation
// (the model is linear in a small added force, eqs. (6)-(8)), and so is each of the paper's free
// parameters' (in every fit of the regression); forward selection picks terms while they lower the
// cross-validated error (each third of the segments judged by the others); the chosen terms are
// refitted jointly with the model by simulation error, and a term of two factors gives way to one
// of them alone where that predicts as well.
// Two starts: the library's model (its effects may have taken up part of the missing term in their
// own forms, and the terms then fit what is left), and the paper's model alone (the residual is the
// missing physics itself), to which the library's effects are then added back one at a time where
// they pay. The better of the two is proposed; library effects that only stood in for the term
// leave either way.
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

bool is_term(const Part& p) { return !p.texts.empty(); }
bool is_library_effect(const Part& p) { return p.entry && p.texts.empty(); }

// A term's twin at steady speeds: the ground's drag growing by a fraction c t over the log is, at
// steady speed, every screw's thrust falling by c t (zeta = D^-1 sigma S B omega, eqs. (6)-(7));
// only the speed changes tell them apart, over the time constants M / D (29 kg / 560 N s/m =
// 0.05 s along x on sand).
// Empty where the term has none in the dictionary.
const DictionaryTerm* steady_twin(const Part& term, const std::vector<DictionaryTerm>& dict) {
  static const std::string kTimesOmega = "omega_rpm*";
  const std::string& dof = term.texts[0];
  const std::string& form = term.texts[1];
  std::string twin_dof, twin_form;
  if (dof == "drag") {
    twin_dof = "screws";
    twin_form = kTimesOmega + form;
  } else if (dof == "screws" && form.rfind(kTimesOmega, 0) == 0) {
    twin_dof = "drag";
    twin_form = form.substr(kTimesOmega.size());
  }
  const auto d = std::find_if(dict.begin(), dict.end(), [&](const DictionaryTerm& t) {
    return t.dof == twin_dof && t.form == twin_form;
  });
  return d == dict.end() ? nullptr : &*d;
}

// A term's text: its dof, form, inputs and unit in the vocabulary's spelling, with the coefficient.
void write_term(const std::string& dof, const std::string& form, double coefficient, TermText& out) {
  const TermForm f(dof, form);
  out.dof = f.dof_text();
  out.form = f.form_text();
  out.inputs = f.input_names();
  out.coefficient = coefficient;
  out.unit = f.coefficient_unit();
  out.description = f.describe(coefficient);
}

}  // namespace

bool Explainer::select_terms_on(const std::vector<Part>& base_parts, const std::vector<DictionaryTerm>& dict,
                                std::vector<Part>& chosen) {
  chosen.clear();
  // The model fitted on every segment; the regression judges each third of the segments (the
  // cross-validation folds) by coefficients fitted on the other two.
  FitOutcome base = refit(all_, base_parts, 10, 0);
  ++structures_;
  if (!std::isfinite(base.cost)) return false;
  std::vector<Eigen::VectorXd> r(kFolds);
  {
    Workspace w;
    for (int f = 0; f < kFolds; ++f)
      if (!residuals(judge_[static_cast<std::size_t>(f)], base.parts, r[static_cast<std::size_t>(f)], w)) return false;
  }
  // The paper's free parameters are columns too (nuisance, in every fit of the regression): a term
  // is judged with them free to take their share back, as the joint refit after it does.
  std::vector<std::pair<std::size_t, int>> nuisance;
  for (std::size_t p = 0; p < base.parts.size(); ++p)
    if (!base.parts[p].entry)
      for (int i : base.parts[p].free) nuisance.push_back({p, i});
  const auto K = static_cast<Eigen::Index>(nuisance.size());
  const auto P = K + static_cast<Eigen::Index>(dict.size());
  std::vector<Eigen::MatrixXd> S(kFolds);
  for (int f = 0; f < kFolds; ++f) S[static_cast<std::size_t>(f)] = Eigen::MatrixXd::Zero(r[static_cast<std::size_t>(f)].size(), P);
  std::vector<std::size_t> all(static_cast<std::size_t>(P));
  for (std::size_t j = 0; j < all.size(); ++j) all[j] = j;
  search::run_parallel(opt_.threads, all, [](std::size_t) { return -1; }, [&](std::size_t j) {
    std::vector<Part> with = base.parts;
    if (j < nuisance.size()) {
      // A step of 1 % of the parameter, away from the bound it may sit at.
      const auto [p, i] = nuisance[j];
      double& v = with[p].values[static_cast<std::size_t>(i)];
      const ParamSpec& sp = with[p].specs[static_cast<std::size_t>(i)];
      double h = 0.01 * std::max(std::fabs(v), std::fabs(sp.typical));
      if (v + h > search_upper(sp)) h = -h;
      v += h;
    } else {
      const DictionaryTerm& d = dict[j - nuisance.size()];
      with.push_back(term_part(d, d.scale));
    }
    Workspace w;
    for (std::size_t f = 0; f < static_cast<std::size_t>(kFolds); ++f) {
      Eigen::VectorXd a;
      if (!residuals(judge_[f], with, a, w)) return;
      S[f].col(static_cast<Eigen::Index>(j)) = a - r[f];
    }
  });
  structures_ += static_cast<int>(P);
  // A term chosen from the dictionary pays for the choice among its P columns as well as for its
  // coefficient (a BIC of 10 plus 2 ln P), and must lower the held-out error by 2 % as an effect must.
  const double min_bic = -kAddBic + 2.0 * std::log(static_cast<double>(dict.size()));
  const double min_held = 1.0 - (1.0 - kAddHeldout) * (1.0 - kAddHeldout);
  const Selection sel = select_terms(r, S, static_cast<int>(K), harmonic_partners(dict), n_eff_of(base, all_), kMaxTerms, min_held, min_bic);
  progress("explain: discovery: %zu dictionary terms, %zu chosen (cross-validated residual %.0f -> %.0f)",
           dict.size(), sel.columns.size(), sel.heldout_rss.front(), sel.heldout_rss.back());
  if (sel.columns.empty()) return false;
  for (std::size_t k = 0; k < sel.columns.size(); ++k) {
    const DictionaryTerm& d = dict[static_cast<std::size_t>(sel.columns[k])];
    detail("explain: discovery:   %s: %s, coefficient %.4g (cross-validated residual then %.0f)", d.dof.c_str(), d.form.c_str(),
           sel.coefficients[static_cast<Eigen::Index>(k)] * d.scale, sel.heldout_rss[k + 1]);
  }
  // From the linearized coefficients scaled back as far as the simulation says (a large term
  // changes the motion it depends on, and the linear step overshoots).
  auto with_terms = [&](double scale) {
    std::vector<Part> parts;
    for (std::size_t k = 0; k < sel.columns.size(); ++k) {
      const DictionaryTerm& d = dict[static_cast<std::size_t>(sel.columns[k])];
      parts.push_back(term_part(d, scale * sel.coefficients[static_cast<Eigen::Index>(k)] * d.scale));
    }
    return parts;
  };
  double best_cost = std::numeric_limits<double>::infinity();
  for (double scale : {1.0, 0.5, 0.25, 0.1}) {
    std::vector<Part> parts = base.parts;
    for (const Part& p : with_terms(scale)) parts.push_back(p);
    Eigen::VectorXd res_all;
    Workspace w;
    if (!residuals(all_, parts, res_all, w) || !(res_all.squaredNorm() < best_cost)) continue;
    best_cost = res_all.squaredNorm();
    chosen = with_terms(scale);
  }
  return !chosen.empty();
}

FitOutcome Explainer::drop_not_paying(FitOutcome with, bool terms, std::vector<RemovedEffect>* stand_ins) {
  for (bool again = true; again;) {
    again = false;
    const double err = compare_error(with.parts);
    for (std::size_t i = 0; i < with.parts.size(); ++i) {
      const Part& p = with.parts[i];
      // The paper's parameters re-identified are checked as a library effect is: they too can
      // stand in for the missing term (a lower sigma for a traction that sags over the log), and
      // their removal is to hold them at the paper's values.
      const bool paper = !terms && paper_free(p);
      if (terms ? !is_term(p) : !(is_library_effect(p) || paper)) continue;
      // A term that changes the prediction by less than an effect must goes without asking.
      const bool weak = terms && largest(contribution(with.parts, i)) < kMinContribution;
      FitOutcome w = refit(all_, without_part(with.parts, i), 12, 1);
      ++structures_;
      if (!std::isfinite(w.cost) || (!weak && compare_error(w.parts) > err * (1.0 + kAddHeldout))) continue;
      if (stand_ins)
        stand_ins->push_back({label(p, ctx_.size()),
                              paper ? "held at the paper's values: with the discovered term the model predicts as well "
                                      "with them (re-identified, they stood in for the missing term)"
                                    : "removed: with the discovered term the model predicts as well without it (it "
                                      "stood in for the missing term)",
                              kNaN});
      progress("explain: discovery: %s no longer pays%s; %s", label(p, ctx_.size()).c_str(),
               terms ? "" : " with the discovered terms", paper ? "held at the paper's values" : "removed");
      with = std::move(w);
      again = true;
      break;
    }
  }
  return with;
}

FitOutcome Explainer::simpler_terms(FitOutcome with, const std::vector<DictionaryTerm>& dict) {
  for (std::size_t i = 0; i < with.parts.size(); ++i) {
    if (!is_term(with.parts[i])) continue;
    const Part p = with.parts[i];
    const std::string& form = p.texts[1];
    const std::size_t star = form.find('*');
    if (star == std::string::npos) continue;
    const double err = compare_error(with.parts);
    for (const std::string& part : {form.substr(0, star), form.substr(star + 1)}) {
      const auto d = std::find_if(dict.begin(), dict.end(),
                                  [&](const DictionaryTerm& t) { return t.dof == p.texts[0] && t.form == part; });
      if (d == dict.end()) continue;
      std::vector<Part> alt = with.parts;
      alt[i] = term_part(*d, matched_coefficient(ctx_.front().base, ctx_.front().data, d->dof, form, p.values[0], d->form));
      FitOutcome w = refit(all_, alt, 12, 1);
      ++structures_;
      if (!std::isfinite(w.cost) || compare_error(w.parts) > err * (1.0 + kAddHeldout)) continue;
      progress("explain: discovery: %s: %s gives way to its simpler form %s", p.texts[0].c_str(), form.c_str(),
               d->form.c_str());
      with = std::move(w);
      break;
    }
  }
  return with;
}

bool Explainer::drop_unidentified_terms(FitOutcome& with) {
  bool any = false;
  for (bool again = true; again;) {
    again = false;
    const double n = static_cast<double>(with.r.size());
    const std::vector<FitParam> params =
        fit_params(with, with.cost / std::max(1.0, n - with.n_params) * n / n_eff_of(with, all_));
    std::size_t k = 0;
    for (std::size_t i = 0; i < with.parts.size(); ++i) {
      const Part& p = with.parts[i];
      const std::size_t at = k;
      k += p.specs.size();
      if (!is_term(p) || at >= params.size() || !(params[at].sigma > 0.5 * std::fabs(p.values[0]))) continue;
      progress("explain: discovery: %s: %s not identified (%.3g +- %.3g); removed", p.texts[0].c_str(),
               p.texts[1].c_str(), p.values[0], params[at].sigma);
      std::vector<Part> rest = with.parts;
      rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(i));
      FitOutcome w = refit(all_, rest, 12, 1);
      ++structures_;
      if (!std::isfinite(w.cost)) return any;
      with = std::move(w);
      any = again = true;
      break;
    }
  }
  return any;
}

bool Explainer::discover(FitOutcome& o, ExplainResult& res) {
  const std::vector<DictionaryTerm> dict = term_dictionary(ctx_.front().base, ctx_.front().data);
  if (dict.empty() || !folds_) return false;
  ChannelValues per_channel;
  const double err_library = compare_error(o.parts, &per_channel);
  // Where the library's model is at the noise floor in size (only its residuals' form is off: a
  // hard dead band for a smooth one), the first route keeps its effects: a term may only be added
  // to them. Where it is not, a term may take the place of effects that stood in for it there too.
  bool fails_in_size = false;
  for (double v : per_channel) fails_in_size = fails_in_size || (std::isfinite(v) && v > kVerdictNoise);
  struct Route {
    FitOutcome fit;
    std::vector<RemovedEffect> stand_ins;
    double err = std::numeric_limits<double>::infinity();
    int parts = 0;
    bool on_paper = false;  // the second route: terms found on the paper's model alone
  };
  std::vector<Route> routes;
  // 1. On the library's model.
  std::vector<Part> chosen;
  if (select_terms_on(o.parts, dict, chosen)) {
    std::vector<Part> parts = o.parts;
    parts.insert(parts.end(), chosen.begin(), chosen.end());
    Route r;
    r.fit = refit(all_, parts, 15, 1);
    ++structures_;
    if (std::isfinite(r.fit.cost)) {
      if (fails_in_size) r.fit = drop_not_paying(std::move(r.fit), false, &r.stand_ins);
      r.fit = drop_not_paying(std::move(r.fit), true, nullptr);
      routes.push_back(std::move(r));
    }
  }
  // 2. On the paper's model alone, the library's effects added back where they pay: at the noise
  // floor in size too, where an effect may have stood in for the whole of the term (a quadratic
  // drag in yaw for a traction that falls with the yaw rate, the same torque r |r| in steady
  // turns; a Coulomb friction and a change of terrain for a battery's sag: the independent
  // generator's logs ended "near the noise floor" with them kept as findings).
  std::vector<Part> paper;
  for (const Part& p : o.parts)
    if (!p.entry) paper.push_back(p);
  if (paper.size() != o.parts.size() && select_terms_on(paper, dict, chosen)) {
    std::vector<Part> parts = paper;
    parts.insert(parts.end(), chosen.begin(), chosen.end());
    Route r;
    r.on_paper = true;
    r.fit = refit(all_, parts, 15, 1);
    ++structures_;
    if (std::isfinite(r.fit.cost)) {
      // The library's effects added where they pay, then the terms they make redundant taken out,
      // then those effects that did not pay tried once more (a term they lost to may be gone).
      std::vector<const Part*> left;
      for (const Part& e : o.parts)
        if (is_library_effect(e)) left.push_back(&e);
      for (int pass = 0; pass < 2 && !left.empty(); ++pass) {
        std::vector<const Part*> refused;
        for (const Part* e : left) {
          std::vector<Part> with = r.fit.parts;
          with.push_back(*e);
          FitOutcome w = refit(all_, with, 12, 1);
          ++structures_;
          const bool pays = std::isfinite(w.cost) &&
                            compare_error(w.parts) <= (1.0 - kAddHeldout) * compare_error(r.fit.parts) &&
                            largest(contribution(w.parts, w.parts.size() - 1)) >= kMinContribution;
          progress("explain: discovery: %s on the terms found on the paper's model: %s", label(*e, ctx_.size()).c_str(),
                   pays ? "pays, kept" : "does not pay");
          if (pays) r.fit = std::move(w);
          else refused.push_back(e);
        }
        r.fit = drop_not_paying(std::move(r.fit), true, nullptr);
        left = refused;
      }
      r.fit = drop_not_paying(std::move(r.fit), false, &r.stand_ins);
      for (const Part* e : left)
        r.stand_ins.push_back({label(*e, ctx_.size()),
                               "removed: with the discovered term the model predicts as well without it (it stood in "
                               "for the missing term)",
                               kNaN});
      routes.push_back(std::move(r));
    }
  }
  for (Route& r : routes) {
    r.fit = simpler_terms(std::move(r.fit), dict);
    polish(r.fit);
    if (drop_unidentified_terms(r.fit)) polish(r.fit);
    // A library effect that the terms leave nothing to do goes as at the final checks (a 2 mm
    // offset of the centre of resistance, within its uncertainty of 0, beside a drift's terms).
    while (drop_weakest(r.fit, r.stand_ins, "with the discovered terms, ")) polish(r.fit);
    r.err = compare_error(r.fit.parts);
    r.parts = effects_in(r.fit.parts);
  }
  // The better route; of two within 2 % the one with fewer parts.
  const Route* best = nullptr;
  for (const Route& r : routes) {
    bool any_term = false;
    for (const Part& p : r.fit.parts) any_term = any_term || is_term(p);
    if (!any_term) continue;
    if (!best || r.err < best->err * (1.0 - kAddHeldout) ||
        (r.err <= best->err * (1.0 + kAddHeldout) && r.parts < best->parts))
      best = &r;
  }
  const int library_parts = effects_in(o.parts);
  if (best)
    progress("explain: discovery: the 25 s segments %.3f times the noise floor with the terms (%d fitted "
             "parameters in %d effects and terms), %.3f without (%d in %d)",
             best->err, best->fit.n_params, best->parts, err_library, o.n_params, library_parts);
  else
    progress("explain: discovery: no term is left after its checks (the 25 s segments %.3f times the noise "
             "floor without)", err_library);
  if (!best || !terms_accepted(best->err, best->fit.n_params, best->parts, err_library, o.n_params, library_parts,
                               best->on_paper && !fails_in_size))
    return false;
  res.removed.insert(res.removed.end(), best->stand_ins.begin(), best->stand_ins.end());
  const FitOutcome& with = best->fit;
  // The groups, per dof in the order first chosen, each with the error of the terms so far.
  const double n = static_cast<double>(with.r.size());
  const double s2 = with.cost / std::max(1.0, n - with.n_params) * n / n_eff_of(with, all_);
  const std::vector<FitParam> params = fit_params(with, s2);
  std::vector<Part> so_far;
  for (const Part& p : with.parts)
    if (!is_term(p)) so_far.push_back(p);
  std::size_t k = 0;
  for (std::size_t i = 0; i < with.parts.size(); ++i) {
    const Part& p = with.parts[i];
    const std::size_t at = k;
    k += p.specs.size();
    if (!is_term(p)) continue;
    DiscoveredTerm t;
    write_term(p.texts[0], p.texts[1], p.values[0], t);
    t.uncertainty = params[at].sigma;
    t.contribution = largest(contribution(with.parts, i));
    if (const DictionaryTerm* twin = steady_twin(p, dict)) {
      // Refitted in the term's place from the steady equivalent (a drag fraction c is a thrust
      // fraction -c): proposed beside it where it predicts as well, not as the term's rival.
      std::vector<Part> alt = with.parts;
      alt[i] = term_part(*twin, -p.values[0]);
      const FitOutcome w = refit(all_, alt, 12, 1);
      ++structures_;
      ChannelValues per;
      const double err = std::isfinite(w.cost) ? compare_error(w.parts, &per) : kNaN;
      progress("explain: discovery: %s: %s in place of %s: %s: %.3f times the noise floor, %.3f with it",
               twin->dof.c_str(), twin->form.c_str(), p.texts[0].c_str(), p.texts[1].c_str(), err, best->err);
      if (err <= best->err * (1.0 + kAddHeldout)) {
        DiscoveredTerm::Alternative a;
        write_term(twin->dof, twin->form, w.parts[i].values[0], a);
        a.tell_apart = "the same steady speeds, which only the speed changes (over the time constants M / D) "
                       "tell apart";
        a.ratio = largest(per);
        t.alternatives.push_back(a);
      }
    }
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
      if (is_term(p) && p.texts[0] == g.channel) so_far.push_back(p);
    compare_error(so_far, &g.ratio_after);
  }
  o = with;
  return true;
}

}  // namespace auger::wb::explain_internal
