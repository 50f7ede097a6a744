// Residual tests in the spirit of MATLAB's `resid` (workbench.hpp, docs/workbench.md "The
// stop rule"): is what a model leaves white, and independent of the inputs? For an output-error
// model such as this one (the noise is the sensors', added to a deterministic simulation) the
// simulation error is the prediction error, so it must be white when the model is right.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "workbench.hpp"

namespace auger::wb {
namespace {

// Upper alpha-quantile of chi-square with k degrees of freedom (Wilson-Hilferty; within 1 % of
// the exact value for k >= 5 at the 1 % level).
double chi2_quantile(double k, double z_alpha) {
  const double a = 2.0 / (9.0 * k);
  const double c = 1.0 - a + z_alpha * std::sqrt(a);
  return k * c * c * c;
}

// z with P(|N(0, 1)| > z) = p.
double two_sided_z(double p) {
  double lo = 0, hi = 40;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (std::erfc(mid / std::sqrt(2.0)) > p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// Box-Jenkins prewhitening: residual and input both through w_k = x_k - sum_j a_j x_{k-j}, for
// samples whose p predecessors are the frames just before them in the same run (a dropout or a
// segment's start begins a new run, p samples later).
void prewhiten(const WhiteningFilter& f, std::vector<double>& e, const std::vector<double>& t_s, std::vector<Vec3>& u,
               std::vector<std::size_t>& run_start) {
  const std::size_t p = f.ar.size();
  std::vector<double> we;
  std::vector<Vec3> wu;
  std::vector<std::size_t> starts;
  std::size_t run = 0;
  bool broken = true;
  for (std::size_t i = 0; i < e.size(); ++i) {
    while (run + 1 < run_start.size() && i >= run_start[run + 1]) ++run;
    bool ok = i >= run_start[run] + p;
    for (std::size_t j = 1; ok && j <= p; ++j) {
      const double gap = t_s[i] - t_s[i - j];
      ok = std::fabs(gap - static_cast<double>(j) * f.frame_s) < 0.5 * f.frame_s;
    }
    if (!ok) {
      broken = true;
      continue;
    }
    double x = e[i];
    Vec3 v = u[i];
    for (std::size_t j = 1; j <= p; ++j) {
      x -= f.ar[j - 1] * e[i - j];
      v -= f.ar[j - 1] * u[i - j];
    }
    if (broken) starts.push_back(we.size());
    broken = false;
    we.push_back(x);
    wu.push_back(v);
  }
  e = std::move(we);
  u = std::move(wu);
  run_start = std::move(starts);
}

}  // namespace

ResidualTests residual_tests(const Model& model, const Dataset& data, const ChannelValues& noise,
                             const WhiteningFilter& whiten, int max_lag) {
  ResidualTests t;
  t.max_lag = max_lag;
  Prediction p;
  simulate(model, data, sim_options_for(model), p);
  // The inputs: the nominal drive force of eq. (7) per DOF, tau = S B omega (what the screws ask
  // of the body), at each measured sample.
  for (int c = 0; c < kChannels; ++c) {
    const auto cc = static_cast<std::size_t>(c);
    if (!data.active[cc]) continue;
    // Residuals of each segment with the segment's mean removed (its start anchor is a mean of
    // noisy poses, a constant that would look like correlation), in order of measurement.
    std::vector<double> e, t_s;
    std::vector<Vec3> u;
    std::vector<std::size_t> run_start;
    for (std::size_t s = 0; s < p.segment_start.size(); ++s) {
      const std::size_t b = p.segment_start[s];
      const std::size_t end = s + 1 < p.segment_start.size() ? p.segment_start[s + 1] : data.size();
      const std::size_t first = e.size();
      for (std::size_t k = b; k < end; ++k) {
        const double m = data.meas[k][cc], q = p.pred[k][cc];
        if (!std::isfinite(m) || !std::isfinite(q)) continue;
        double d = q - m;
        if (c >= kPsi) d = wrap_angle(d);
        e.push_back(d / noise[cc]);
        t_s.push_back(data.t_s[k]);
        u.push_back(model.SB * data.omega_rpm[k]);
      }
      if (e.size() - first < static_cast<std::size_t>(2 * max_lag + 2)) {
        e.resize(first);
        t_s.resize(first);
        u.resize(first);
        continue;
      }
      double mean = 0;
      for (std::size_t i = first; i < e.size(); ++i) mean += e[i];
      mean /= static_cast<double>(e.size() - first);
      for (std::size_t i = first; i < e.size(); ++i) e[i] -= mean;
      run_start.push_back(first);
    }
    ChannelResidualTest ct;
    ct.channel = c;
    if (c != kImuPsi && !whiten.ar.empty()) {
      prewhiten(whiten, e, t_s, u, run_start);
      ct.whitened_order = static_cast<int>(whiten.ar.size());
    }
    ct.n = e.size();
    if (e.size() < 50) {
      t.channels.push_back(ct);
      continue;
    }
    run_start.push_back(e.size());
    auto same_run = [&](std::size_t i, std::size_t j) {
      const auto it = std::upper_bound(run_start.begin(), run_start.end(), i);
      return j < *it && j >= *(it - 1);
    };
    double var = 0;
    for (double v : e) var += v * v;
    const double n = static_cast<double>(e.size());
    // Whiteness: Ljung-Box Q = n (n + 2) sum_l rho_l^2 / (n - l), lags 1..max_lag, within runs.
    double q = 0;
    for (int l = 1; l <= max_lag; ++l) {
      double acc = 0;
      for (std::size_t i = static_cast<std::size_t>(l); i < e.size(); ++i)
        if (same_run(i - static_cast<std::size_t>(l), i)) acc += e[i] * e[i - static_cast<std::size_t>(l)];
      const double rho = acc / var;
      ct.acf.push_back(rho);
      q += rho * rho / (n - l);
    }
    ct.whiteness_q = n * (n + 2) * q;
    ct.whiteness_limit = chi2_quantile(max_lag, 2.326);  // 1 % level
    ct.white = ct.whiteness_q <= ct.whiteness_limit;
    // Independence: correlation of the residual with each input component at lags 0..max_lag
    // (input before residual), scaled by sqrt(n) (~N(0, 1) for white residuals whatever the
    // input); the largest of the 3 (max_lag + 1) values against a Bonferroni bound at 1 %.
    const int tests = 3 * (max_lag + 1);
    ct.independence_limit = two_sided_z(0.01 / tests);
    for (int k = 0; k < 3; ++k) {
      double mu = 0, su = 0;
      for (const Vec3& x : u) mu += x[k];
      mu /= n;
      for (const Vec3& x : u) su += (x[k] - mu) * (x[k] - mu);
      if (!(su > 0)) continue;
      for (int l = 0; l <= max_lag; ++l) {
        double acc = 0;
        for (std::size_t i = static_cast<std::size_t>(l); i < e.size(); ++i)
          if (same_run(i - static_cast<std::size_t>(l), i)) acc += e[i] * (u[i - static_cast<std::size_t>(l)][k] - mu);
        const double z = std::fabs(acc / std::sqrt(var * su)) * std::sqrt(n);
        if (z > ct.independence_z) {
          ct.independence_z = z;
          ct.worst_input = k;
          ct.worst_lag = l;
        }
      }
    }
    ct.independent = ct.independence_z <= ct.independence_limit;
    t.channels.push_back(ct);
  }
  t.white = t.independent = true;
  for (const auto& ct : t.channels) {
    if (ct.n < 50) continue;
    t.white = t.white && ct.white;
    t.independent = t.independent && ct.independent;
  }
  return t;
}

std::string describe_residual_tests(const ResidualTests& t) {
  static const char* inputs[3] = {"the drive force along x", "the drive force along y", "the drive torque in yaw"};
  std::string s;
  char buf[300];
  for (const auto& ct : t.channels) {
    if (ct.n < 50) continue;
    if (!ct.white) {
      std::snprintf(buf, sizeof buf, "%s%s residuals are not white (Ljung-Box Q %.0f over %d lags, 1 %% limit %.0f)",
                    s.empty() ? "" : "; ", channel_name(ct.channel), ct.whiteness_q, t.max_lag, ct.whiteness_limit);
      s += buf;
    }
    if (!ct.independent) {
      std::snprintf(buf, sizeof buf, "%s%s residuals follow %s %d samples earlier (%.1f standard errors, limit %.1f)",
                    s.empty() ? "" : "; ", channel_name(ct.channel), inputs[ct.worst_input], ct.worst_lag,
                    ct.independence_z, ct.independence_limit);
      s += buf;
    }
  }
  if (s.empty()) s = "residuals white and independent of the inputs";
  for (const auto& ct : t.channels)
    if (ct.n >= 50 && ct.whitened_order > 0) {
      std::snprintf(buf, sizeof buf, " (the camera's channels tested with the camera noise's own colour filtered out, AR(%d))",
                    ct.whitened_order);
      s += buf;
      break;
    }
  return s;
}

}  // namespace auger::wb
