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

namespace {

// The simpler form an effect reduces to when a parameter of it is not identified: stick-slip
// friction to Coulomb friction at its sliding level, an IMU drift to a bias, a force lag with a
// dead time to the plain lag. False: none.
bool simpler_form(const Part& p, const Dataset& d, Part& out) {
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

double largest(const ChannelValues& v) {
  double m = 0;
  for (double x : v)
    if (std::isfinite(x)) m = std::max(m, x);
  return m;
}

}  // namespace

ChannelValues Explainer::contribution(const std::vector<Part>& parts, std::size_t i) const {
  ChannelValues out{kNaN, kNaN, kNaN, kNaN};
  std::vector<Part> without = parts;
  without.erase(without.begin() + static_cast<std::ptrdiff_t>(i));
  Eigen::VectorXd a, b;
  Workspace w;
  if (!residuals(all_, parts, a, w) || !residuals(all_, without, b, w)) return out;
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

double Explainer::cross_validated(const std::vector<Part>& parts) {
  ChannelPool pool;
  for (int f = 0; f < kFolds; ++f) {
    FitOutcome o = refit(fit_on(f), parts, 8, 0);
    ++structures_;
    if (!std::isfinite(o.cost)) return kNaN;
    for (std::size_t i = 0; i < ctx_.size(); ++i) {
      const Model m = build(ctx_[i].base, o.parts, static_cast<int>(i));
      pool.add(segments_error(m, ctx_[i].data, judged_on(ctx_[i], f), ctx_[i].noise));
    }
  }
  ChannelValues per;
  return pool.combined(per);
}

void Explainer::parsimony(FitOutcome& o, std::vector<RemovedEffect>& removed) {
  auto remove_part = [&](std::size_t i, const std::string& why, double c, const Part* replacement) {
    RemovedEffect r{label(o.parts[i], ctx_.size()), why, c};
    std::vector<Part> rest = o.parts;
    if (replacement) rest[i] = *replacement;
    else rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(i));
    FitOutcome again = refit(all_, rest, 12, 1);
    ++structures_;
    if (!std::isfinite(again.cost)) return false;
    progress("explain: final check: %s %s", r.effect.c_str(), why.c_str());
    o = std::move(again);
    removed.push_back(r);
    return true;
  };
  for (int round = 0; round < 8; ++round) {
    std::vector<std::size_t> effects;
    for (std::size_t i = 0; i < o.parts.size(); ++i)
      if (o.parts[i].entry) effects.push_back(i);
    if (effects.empty()) return;
    // 1. Physically significant: what it changes in the prediction, the rest held.
    std::size_t weakest = effects.front();
    double weakest_c = std::numeric_limits<double>::infinity();
    for (std::size_t i : effects) {
      const double c = largest(contribution(o.parts, i));
      if (c < weakest_c) {
        weakest_c = c;
        weakest = i;
      }
    }
    if (weakest_c < kMinContribution) {
      char why[200];
      std::snprintf(why, sizeof why,
                    "removed: it changes the prediction by at most %.2f times the noise floor (less than %.1f)", weakest_c,
                    kMinContribution);
      if (remove_part(weakest, why, weakest_c, nullptr)) continue;
    }
    // 2. Identified: a parameter the log does not identify (at the end of its range with an
    // uncertainty over half its value, or an uncertainty over its value) is kept only if neither
    // taking the effect out nor its simpler form predicts the 25 s segments within 2 % as well.
    const double n = static_cast<double>(o.r.size());
    const double s2 = o.r.size() ? o.cost / std::max(1.0, n - o.n_params) * n / n_eff_of(o, all_) : 1.0;
    const std::vector<FitParam> params = fit_params(o, s2);
    bool changed = false;
    std::size_t k = 0;
    for (std::size_t i = 0; i < o.parts.size() && !changed; ++i) {
      bool unidentified = false;
      for (std::size_t j = 0; j < o.parts[i].specs.size(); ++j, ++k)
        unidentified = unidentified || params[k].flag.find("not identified") != std::string::npos;
      if (!o.parts[i].entry || !unidentified) continue;
      const double err = compare_error(o.parts);
      const double c = largest(contribution(o.parts, i));
      std::vector<Part> without = o.parts;
      without.erase(without.begin() + static_cast<std::ptrdiff_t>(i));
      FitOutcome w = refit(all_, without, 12, 1);
      ++structures_;
      if (std::isfinite(w.cost) && compare_error(w.parts) <= err * (1.0 + kAddHeldout)) {
        changed = remove_part(i, "removed: a parameter of it is not identified and the model predicts as well without it",
                              c, nullptr);
        break;
      }
      Part simpler;
      if (simpler_form(o.parts[i], ctx_.front().data, simpler)) {
        std::vector<Part> alt = o.parts;
        alt[i] = simpler;
        FitOutcome a = refit(all_, alt, 12, 1);
        ++structures_;
        if (std::isfinite(a.cost) && compare_error(a.parts) <= err * (1.0 + kAddHeldout)) {
          changed = remove_part(i, "replaced by " + simpler.id + (simpler.id == o.parts[i].id ? " without its dead time" : "") +
                                       ": a parameter of it is not identified and the simpler form predicts as well",
                                c, &simpler);
          break;
        }
      }
    }
    if (changed) continue;
    // 3. Confirmed by cross-validation: without it, the error on segments no fit saw rises.
    const double cv = cross_validated(o.parts);
    if (!std::isfinite(cv)) return;
    std::size_t worst = o.parts.size();
    double worst_gain = std::numeric_limits<double>::infinity();
    for (std::size_t i : effects) {
      std::vector<Part> without = o.parts;
      without.erase(without.begin() + static_cast<std::ptrdiff_t>(i));
      const double cv_without = cross_validated(without);
      const double gain = cv_without / cv - 1.0;
      detail("explain: final check: %s: cross-validated %.3f with, %.3f without", label(o.parts[i], ctx_.size()).c_str(),
             cv, cv_without);
      if (std::isfinite(gain) && gain < worst_gain) {
        worst_gain = gain;
        worst = i;
      }
    }
    if (worst < o.parts.size() && worst_gain < kConfirm) {
      char why[200];
      std::snprintf(why, sizeof why,
                    "removed: not confirmed across the log's splits (cross-validated error %.1f %% lower with it, less "
                    "than %.0f %%)",
                    100 * worst_gain, 100 * kConfirm);
      if (remove_part(worst, why, largest(contribution(o.parts, worst)), nullptr)) continue;
    }
    return;
  }
}

}  // namespace auger::wb::explain_internal
