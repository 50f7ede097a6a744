// Force allocation, eq. (22), pseudo-inverse and null-space allocators.
#include "auger/allocation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace auger {

bool feasible_lambda_interval(const Vec4& w, const Vec4& n, double wmax, double& lo, double& hi) {
  lo = -std::numeric_limits<double>::infinity();
  hi = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 4; ++i) {
    if (n[i] == 0) {
      if (std::fabs(w[i]) > wmax) return false;
      continue;
    }
    double a = (-wmax - w[i]) / n[i];
    double b = (wmax - w[i]) / n[i];
    if (a > b) std::swap(a, b);
    lo = std::max(lo, a);
    hi = std::min(hi, b);
  }
  return lo <= hi;
}

namespace {

constexpr double kTol = 1e-9;

// Largest s in [0, 1] such that fixed + s * part + lambda n fits the limits for some lambda.
// The feasible set is convex, so feasibility in s is an interval starting at 0: bisection.
double max_feasible_scale(const Vec4& fixed, const Vec4& part, const Vec4& n, double wmax) {
  double lo, hi;
  if (feasible_lambda_interval(fixed + part, n, wmax, lo, hi)) return 1.0;
  double s_ok = 0.0, s_bad = 1.0;
  for (int it = 0; it < 50; ++it) {
    const double s = 0.5 * (s_ok + s_bad);
    (feasible_lambda_interval(fixed + s * part, n, wmax, lo, hi) ? s_ok : s_bad) = s;
  }
  return s_ok;
}

double min_abs_speed(const Vec4& w, const Vec4& n, double lambda) {
  return (w + lambda * n).cwiseAbs().minCoeff();
}

// A screw turning one way last cycle (at least half the floor) that this lambda reverses.
bool reverses(const Vec4& w, const Vec4& n, double lambda, const Vec4& prev, double wmin) {
  for (int i = 0; i < 4; ++i)
    if (std::fabs(prev[i]) >= 0.5 * wmin && prev[i] * (w[i] + lambda * n[i]) < 0) return true;
  return false;
}

// Chooses lambda in [lo, hi]: the smallest |lambda| (closest to the minimum-norm solution) with
// every |w_i + lambda n_i| >= wmin; if none exists, the lambda maximising the slowest screw.
// Hysteresis: where meeting the floor leaves a choice of side for a screw, the side it turned
// last cycle (prev) is kept unless the other saves more than hold_rpm on every screw: a screw
// reversed passes through zero, where it blocks in sand, and a floor met alternately on either
// side reversed screws for single cycles 14-19 times per 100 on the diagonal.
double choose_lambda(const Vec4& w, const Vec4& n, double lo, double hi, double wmin, bool& met, const Vec4& prev,
                     double hold_rpm) {
  // The admissible set's boundaries are where one screw reaches +-wmin, or lo/hi; the minimum
  // |lambda| is 0 or one of those points.
  double cand[11];
  int nc = 0;
  cand[nc++] = std::clamp(0.0, lo, hi);
  cand[nc++] = lo;
  cand[nc++] = hi;
  for (int i = 0; i < 4; ++i) {
    if (n[i] == 0) continue;
    cand[nc++] = (wmin - w[i]) / n[i];
    cand[nc++] = (-wmin - w[i]) / n[i];
  }
  double best = 0, kept = 0;
  bool found = false, found_kept = false;
  for (int k = 0; k < nc; ++k) {
    const double l = cand[k];
    if (l < lo - kTol || l > hi + kTol) continue;
    if (min_abs_speed(w, n, l) < wmin - 1e-7) continue;
    if (!found || std::fabs(l) < std::fabs(best)) best = l, found = true;
    if (!reverses(w, n, l, prev, wmin) && (!found_kept || std::fabs(l) < std::fabs(kept))) kept = l, found_kept = true;
  }
  met = found;
  // A screw's speed changes by |n_i| lambda (n along [-1, 1, -1, 1] / 2).
  if (found_kept && (std::fabs(kept) - std::fabs(best)) * n.cwiseAbs().maxCoeff() <= hold_rpm) best = kept;
  if (found) return std::clamp(best, lo, hi);
  // Best effort: g(lambda) = min_i |n_i| |lambda - z_i| peaks at lo, hi or where two screws'
  // V shapes cross.
  double z[4], an[4];
  for (int i = 0; i < 4; ++i) {
    an[i] = std::fabs(n[i]);
    z[i] = n[i] == 0 ? 0 : -w[i] / n[i];
  }
  double bl = std::clamp(0.0, lo, hi), bg = min_abs_speed(w, n, bl);
  auto consider = [&](double l) {
    l = std::clamp(l, lo, hi);
    const double g = min_abs_speed(w, n, l);
    if (g > bg + 1e-12 || (std::fabs(g - bg) <= 1e-12 && std::fabs(l) < std::fabs(bl))) bl = l, bg = g;
  };
  consider(lo);
  consider(hi);
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j)
      if (an[i] + an[j] > 0) consider((an[i] * z[i] + an[j] * z[j]) / (an[i] + an[j]));
  return bl;
}

}  // namespace

void allocate(const Model& model, const AllocatorConfig& cfg, const Vec3& tau, AllocationResult& out) {
  const double wmax = cfg.omega_max_rpm;
  if (cfg.kind == AllocatorKind::pseudo_inverse) {
    out.omega_rpm = model.SB_pinv * tau;  // eq. (22)
    const double peak = out.omega_rpm.cwiseAbs().maxCoeff();
    const double s = peak > wmax ? wmax / peak : 1.0;  // keep the direction of tau
    out.omega_rpm *= s;
    out.lambda = 0;
    out.scale_primary = out.scale_secondary = s;
    out.min_speed_met = true;
    return;
  }
  const Vec4& n = model.null_space;
  const Vec4 prev = out.omega_rpm;  // last cycle's speeds (choose_lambda's hysteresis)
  Vec3 tau_yaw(0, 0, tau.z());
  Vec3 tau_trans(tau.x(), tau.y(), 0);
  const bool yaw_first = cfg.priority == AllocationPriority::yaw;
  const Vec4 w_primary = model.SB_pinv * (yaw_first ? tau_yaw : tau_trans);
  const Vec4 w_secondary = model.SB_pinv * (yaw_first ? tau_trans : tau_yaw);
  const Vec4 zero = Vec4::Zero();
  out.scale_primary = max_feasible_scale(zero, w_primary, n, wmax);
  const Vec4 fixed = out.scale_primary * w_primary;
  out.scale_secondary = max_feasible_scale(fixed, w_secondary, n, wmax);
  Vec4 base = fixed + out.scale_secondary * w_secondary;
  double lo, hi;
  if (!feasible_lambda_interval(base, n, wmax, lo, hi)) lo = hi = 0;  // only by rounding
  double lambda = std::clamp(0.0, lo, hi);
  out.min_speed_met = true;
  if (base.cwiseAbs().maxCoeff() >= cfg.engage_rpm && cfg.omega_min_rpm > 0) {
    lambda = choose_lambda(base, n, lo, hi, cfg.omega_min_rpm, out.min_speed_met, prev, cfg.sign_hold_rpm);
    if (!out.min_speed_met && out.scale_secondary > 0) {
      // Saturated so hard that no lambda keeps every screw turning: give up some of the
      // secondary share rather than let a screw stop and block (the paper's stuck diagonal).
      auto met_at = [&](double s, double& l) {
        double a, b;
        if (!feasible_lambda_interval(fixed + s * w_secondary, n, wmax, a, b)) return false;
        bool met = false;
        l = choose_lambda(fixed + s * w_secondary, n, a, b, cfg.omega_min_rpm, met, prev, cfg.sign_hold_rpm);
        return met;
      };
      double l_ok = 0;
      if (met_at(0.0, l_ok)) {
        double s_ok = 0.0, s_bad = out.scale_secondary;
        for (int it = 0; it < 40; ++it) {
          const double s = 0.5 * (s_ok + s_bad);
          double l;
          if (met_at(s, l)) s_ok = s, l_ok = l;
          else s_bad = s;
        }
        out.scale_secondary = s_ok;
        base = fixed + s_ok * w_secondary;
        lambda = l_ok;
        out.min_speed_met = true;
      }
    }
  }
  out.lambda = lambda;
  out.omega_rpm = base + lambda * n;
  // Rounding of the bisection must never exceed the motor's limit.
  out.omega_rpm = out.omega_rpm.cwiseMax(-wmax).cwiseMin(wmax);
}

}  // namespace auger
