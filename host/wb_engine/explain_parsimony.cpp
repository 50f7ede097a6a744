// explain's final checks (explain_internal.hpp, docs/workbench.md "Parsimony"): an effect stays in
// the final model only when it is physically significant (it changes the prediction by a stated
// share of the noise floor), its parameters are identified (or a simpler form predicts as
// well), and it is confirmed by 3-fold cross-validation (every segment judged once by a fit that
// did not see it). A search over structures judged on one split can keep an effect that only
// mends a misfit of another (a 0.5 % change of terrain, a 16 ms pose offset beside a form the
// library does not have), and a reader takes every effect named as a finding.
#include <algorithm>
#include <cstdio>

#include "explain_internal.hpp"

namespace auger::wb::explain_internal {

using namespace search;

// The simpler form an effect reduces to when a parameter of it is not identified: an effect with
// form parameters (ParamSpec::form) off their defaults to its default form (a settling IMU drift
// to the linear one, saturation pooled over the footprint to each screw's own, a dead band of any
// form to the symmetric dead zone, drag on the speed over ground to each axis's own, a yaw time
// constant's soil spring to none, tanh dry friction to the hard sign); stick-slip friction to
// Coulomb friction at its sliding level, a linear drift to a bias, a force lag with a dead time
// to the plain lag. False: none.
bool simpler_form(const Part& p, const Dataset& d, Part& out) {
  bool off_default = false;
  for (std::size_t k = 0; k < p.specs.size() && k < p.values.size(); ++k)
    off_default = off_default || (p.specs[k].form && p.values[k] != p.specs[k].default_value);
  if (off_default) {
    out = p;
    for (std::size_t k = 0; k < p.specs.size() && k < p.values.size(); ++k)
      if (p.specs[k].form) out.values[k] = p.specs[k].default_value;
    out.free.erase(std::remove_if(out.free.begin(), out.free.end(),
                                  [&](int k) { return p.specs[static_cast<std::size_t>(k)].form; }),
                   out.free.end());
    return true;
  }
  if (p.id == "stick_slip_friction") {
    out = make_part("coulomb_friction", Model{}, d);
    for (std::size_t k = 0; k < 3 && k < p.values.size(); ++k) out.values[k] = p.values[k];
    out.log = p.log;
    return true;
  }
  if (p.id == "imu_heading_drift") {
    out = make_part("imu_heading_bias", Model{}, d);
    out.values[0] = p.values[0];
    out.log = p.log;
    return true;
  }
  if (p.id == "force_lag" && p.values.size() > 1 && p.values[1] != 0) {
    out = p;
    out.values[1] = 0;
    out.free.erase(std::remove(out.free.begin(), out.free.end(), 1), out.free.end());
    return true;
  }
  return false;
}

std::string simpler_form_name(const Part& from, const Part& to) {
  if (to.id != from.id) return to.id;
  if (to.id == "force_lag")
    return to.id + (to.values.size() > 2 && to.values[2] != from.values[2] ? " with the same lag both ways"
                                                                             : " without its dead time");
  if (to.id == "imu_heading_drift") return to.id + " as a linear drift";
  if (to.id == "traction_saturation") return to.id + " per screw";
  if (to.id == "rigid_body_coupling") return to.id + " of the rigid body alone (no added mass)";
  if (to.id == "screw_dead_band") return to.id + " as a symmetric dead zone";
  if (to.id == "quadratic_drag") return to.id + " per axis";
  if (to.id == "coulomb_friction") return to.id + " as a hard sign (sticking below its level)";
  if (to.id == "yaw_time_constant") return to.id + " of first order (no soil spring)";
  if (to.id == "screw_blocking") return to.id + " at once (no sinking in, no hysteresis)";
  return to.id + " in its default form";
}

std::vector<Part> without_part(std::vector<Part> parts, std::size_t i) {
  Part& p = parts[i];
  if (p.entry) {
    parts.erase(parts.begin() + static_cast<std::ptrdiff_t>(i));
    return parts;
  }
  for (std::size_t k = 0; k < p.values.size(); ++k) p.values[k] = p.specs[k].default_value;
  p.free.clear();
  return parts;
}

double largest(const ChannelValues& v) {
  const double m = largest_finite(v);
  return std::isfinite(m) ? std::max(m, 0.0) : 0.0;
}

ChannelValues Explainer::contribution(const std::vector<Part>& parts, std::size_t i) const {
  ChannelValues out{kNaN, kNaN, kNaN, kNaN};
  Eigen::VectorXd a, b;
  Workspace w;
  if (!residuals(all_, parts, a, w) || !residuals(all_, without_part(parts, i), b, w)) return out;
  std::array<double, kChannels> sum{}, n{};
  Eigen::Index at = 0;
  for (const LogTerm& t : all_.terms) {
    for (const auto& [k, c] : t.index) {
      const double d = a[at] - b[at];
      sum[static_cast<std::size_t>(c)] += d * d;
      n[static_cast<std::size_t>(c)] += 1;
      ++at;
    }
    at += static_cast<Eigen::Index>(t.force_index.size());
  }
  for (int c = 0; c < kChannels; ++c)
    if (n[static_cast<std::size_t>(c)] > 0) out[static_cast<std::size_t>(c)] = std::sqrt(sum[static_cast<std::size_t>(c)] / n[static_cast<std::size_t>(c)]);
  return out;
}

bool Explainer::constant_terrain(const std::vector<Part>& parts, std::size_t i, std::vector<Part>& out) const {
  // One log only: with several, the paper's parameters of a terrain are shared by its logs and
  // the change is one log's.
  const Part& c = parts[i];
  if (c.id != kTerrainChange || !c.entry || ctx_.size() != 1 || c.values.size() < 3) return false;
  out = parts;
  out.erase(out.begin() + static_cast<std::ptrdiff_t>(i));
  for (Part& p : out) {
    if (p.entry || p.terrain != ctx_.front().base.terrain.name) continue;
    // Traction (sigma_long, sigma_lat) times sigma_factor, resistance (D_x, D_y, D_psi) times
    // drag_factor, re-identified from there.
    for (std::size_t k = 0; k < p.values.size(); ++k) p.values[k] *= k < 2 ? c.values[1] : c.values[2];
    p.free = make_part(kPaperParams, ctx_.front().base, ctx_.front().data).free;
    return true;
  }
  return false;
}

FoldValues Explainer::cross_validated(const std::vector<Part>& parts, std::array<std::vector<Part>, kFolds>* fits) {
  FoldValues per_fold;
  per_fold.fill(kNaN);
  for (int f = 0; f < kFolds; ++f) {
    // A change time is searched again on the fold's training segments: placed by a fit on every
    // segment, it would have seen the segments it is judged on, and a change that only mends a
    // misfit somewhere (a form the library lacks) would be confirmed by its own placement.
    FitOutcome o = research_change_times(fit_on(f), refit(fit_on(f), parts, 8, 0), 8);
    ++structures_;
    if (!std::isfinite(o.cost)) return per_fold;
    if (fits) (*fits)[static_cast<std::size_t>(f)] = o.parts;
    ChannelPool pool;
    for (std::size_t i = 0; i < ctx_.size(); ++i) {
      const Model m = build(ctx_[i].base, o.parts, static_cast<int>(i));
      pool.add(segments_error(m, ctx_[i].data, judged_on(ctx_[i], f), ctx_[i].noise));
    }
    ChannelValues per;
    per_fold[static_cast<std::size_t>(f)] = pool.combined(per);
  }
  return per_fold;
}

bool Explainer::drop_weakest(FitOutcome& o, std::vector<RemovedEffect>& removed, const char* after) {
  std::size_t weakest = o.parts.size();
  double weakest_c = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < o.parts.size(); ++i) {
    const Part& p = o.parts[i];
    if (!((p.entry && p.texts.empty()) || paper_free(p))) continue;  // (terms have their own checks)
    const double c = largest(contribution(o.parts, i));
    if (c < weakest_c) {
      weakest_c = c;
      weakest = i;
    }
  }
  if (weakest == o.parts.size() || !(weakest_c < kMinContribution)) return false;
  const Part& p = o.parts[weakest];
  RemovedEffect r{label(p, ctx_.size()), "", weakest_c};
  if (!p.entry && ctx_.size() > 1) r.effect += " (terrain " + p.terrain + ")";
  char why[300];
  std::snprintf(why, sizeof why, "%s: %sit changes the prediction by at most %.2f times the noise floor (less than %.1f)",
                p.entry ? "removed" : "held at the paper's values", after, weakest_c, kMinContribution);
  r.why = why;
  FitOutcome again = refit(all_, without_part(o.parts, weakest), 12, 1);
  ++structures_;
  if (!std::isfinite(again.cost)) return false;
  progress("explain: final check: %s %s", r.effect.c_str(), why);
  o = std::move(again);
  removed.push_back(r);
  return true;
}

bool Explainer::simplify_unidentified(FitOutcome& o, std::vector<RemovedEffect>& removed, bool forms_only) {
  const std::vector<FitParam> params = params_on_all(o);
  std::size_t k = 0;
  for (std::size_t i = 0; i < o.parts.size(); ++i) {
    const Part& p = o.parts[i];
    bool unidentified = false;
    for (std::size_t j = 0; j < p.specs.size(); ++j, ++k)
      unidentified = unidentified || ((!forms_only || p.specs[j].form) && k < params.size() &&
                                      params[k].flag.find("not identified") != std::string::npos);
    if (!p.entry || !unidentified || (forms_only && !p.texts.empty())) continue;
    const double err = compare_error(o.parts);
    std::vector<std::vector<Part>> alts;
    std::vector<std::string> whys;
    const char* what = forms_only ? "a parameter of its form" : "a parameter of it";
    if (!forms_only) {
      alts.push_back(without_part(o.parts, i));
      whys.push_back(std::string("removed: ") + what + " is not identified and the model predicts as well without it");
    }
    Part simpler;
    if (simpler_form(p, ctx_.front().data, simpler)) {
      alts.push_back(o.parts);
      alts.back()[i] = simpler;
      whys.push_back("replaced by " + simpler_form_name(p, simpler) + ": " + what +
                     " is not identified and the simpler form predicts as well");
    }
    for (std::size_t a = 0; a < alts.size(); ++a) {
      FitOutcome fit = refit(all_, alts[a], 12, 1);
      ++structures_;
      if (!std::isfinite(fit.cost) || compare_error(fit.parts) > err * (1.0 + kAddHeldout)) continue;
      const std::string name = label(p, ctx_.size());
      progress("explain: final check: %s %s", name.c_str(), whys[a].c_str());
      removed.push_back({name, whys[a], largest(contribution(o.parts, i))});
      o = std::move(fit);
      return true;
    }
  }
  return false;
}

void Explainer::parsimony(FitOutcome& o, std::vector<RemovedEffect>& removed) {
  auto remove_part = [&](std::size_t i, const std::string& why, double c, const std::vector<Part>& rest) {
    RemovedEffect r{label(o.parts[i], ctx_.size()), why, c};
    if (!o.parts[i].entry && ctx_.size() > 1) r.effect += " (terrain " + o.parts[i].terrain + ")";
    FitOutcome again = refit(all_, rest, 12, 1);
    ++structures_;
    if (!std::isfinite(again.cost)) return false;
    progress("explain: final check: %s %s", r.effect.c_str(), why.c_str());
    o = std::move(again);
    removed.push_back(r);
    return true;
  };
  for (int round = 0; round < 8; ++round) {
    // The effects, and the paper's parameters where re-identified: a reader takes those as a
    // finding too (this terrain's sigma and D are not the paper's), and re-identified they can
    // stand in for a form the library lacks (sigma_long 0.58-0.95 N/rpm across fits of one slope
    // log of the other generator), so they pass the same checks, held at the paper's values
    // where they fail.
    std::vector<std::size_t> effects;
    for (std::size_t i = 0; i < o.parts.size(); ++i)
      if (o.parts[i].entry || paper_free(o.parts[i])) effects.push_back(i);
    if (effects.empty()) return;
    auto removal = [&](std::size_t i) { return o.parts[i].entry ? "removed" : "held at the paper's values"; };
    // 1. Physically significant: what it changes in the prediction, the rest held.
    if (drop_weakest(o, removed, "")) continue;
    // 2. Identified: a parameter the log does not identify (at the end of its range with an
    // uncertainty over half its value, or an uncertainty over its value) is kept only if neither
    // taking the effect out nor its simpler form predicts the 25 s segments within 2 % as well.
    if (simplify_unidentified(o, removed, false)) continue;
    // 3. Confirmed by cross-validation: without it, the error on segments no fit saw rises, in
    // two folds of three (the median fold): one fold whose fit went astray (the paper's
    // parameters traded against a slope on a third of the log) neither confirms nor refutes.
    // A change of terrain is also set against the same terrain from the log's start (its time
    // profile: a change near an end of the log, with little data on one side, is a
    // re-identification of the terrain in disguise; on a log of the other generator, one at 3.4 s
    // of 120 s, traction 0.62 times, stood beside a dead band and re-identified paper parameters).
    const FoldValues cv = cross_validated(o.parts);
    std::size_t worst = o.parts.size();
    double worst_gain = std::numeric_limits<double>::infinity();
    std::vector<Part> worst_alt;
    bool worst_constant = false;
    for (std::size_t i : effects) {
      std::vector<std::vector<Part>> alts{without_part(o.parts, i)};
      std::vector<Part> constant;
      if (constant_terrain(o.parts, i, constant)) alts.push_back(constant);
      for (std::size_t a = 0; a < alts.size(); ++a) {
        const FoldValues cv_alt = cross_validated(alts[a]);
        FoldValues gains{};
        bool finite = true;
        for (int f = 0; f < kFolds; ++f) {
          gains[static_cast<std::size_t>(f)] = cv_alt[static_cast<std::size_t>(f)] / cv[static_cast<std::size_t>(f)] - 1.0;
          finite = finite && std::isfinite(gains[static_cast<std::size_t>(f)]);
        }
        if (!finite) continue;
        std::sort(gains.begin(), gains.end());
        const double gain = gains[kFolds / 2];
        detail("explain: final check: %s: cross-validated %.3f / %.3f / %.3f with, %.3f / %.3f / %.3f %s",
               label(o.parts[i], ctx_.size()).c_str(), cv[0], cv[1], cv[2], cv_alt[0], cv_alt[1], cv_alt[2],
               a ? "as a terrain other than the paper's from the start" : "without");
        if (gain < worst_gain) {
          worst_gain = gain;
          worst = i;
          worst_alt = alts[a];
          worst_constant = a > 0;
        }
      }
    }
    if (worst < o.parts.size() && worst_gain < kConfirm) {
      char reason[300];
      std::string why;
      if (worst_constant) {
        std::snprintf(reason, sizeof reason,
                      "its time profile is not confirmed across the log's splits (the same terrain from the log's "
                      "start predicts as well: cross-validated error %.1f %% %s with the change in the median of "
                      "three folds, not %.0f %% lower)",
                      100 * std::fabs(worst_gain), worst_gain < 0 ? "higher" : "lower", 100 * kConfirm);
        why = std::string("replaced by paper_params: ") + reason;
      } else {
        std::snprintf(reason, sizeof reason,
                      "not confirmed across the log's splits (cross-validated error %.1f %% %s with %s in the median "
                      "of three folds, not %.0f %% lower)",
                      100 * std::fabs(worst_gain), worst_gain < 0 ? "higher" : "lower",
                      o.parts[worst].entry ? "it" : "them re-identified", 100 * kConfirm);
        why = std::string(removal(worst)) + ": " + reason;
      }
      if (remove_part(worst, why, largest(contribution(o.parts, worst)), worst_alt)) {
        removed.back().unconfirmed = !worst_constant;
        removed.back().reason = reason;
        continue;
      }
    }
    return;
  }
}

}  // namespace auger::wb::explain_internal
