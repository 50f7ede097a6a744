// Gantry identification, eqs. (11)-(17): sigma by least squares on the measured force, D from
// the steady-state velocity, with confidence intervals (identify.hpp, docs/workbench-tools.md).
#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

#include "auger/log.hpp"
#include "auger/measured.hpp"
#include "identify.hpp"

namespace auger::wb {
namespace {

constexpr double kPiNumber = 3.14159265358979323846;

// Density of Student's t (the normalising constant through lgamma, stable for large dof).
double t_density(double x, double dof) {
  const double log_c = std::lgamma((dof + 1) / 2) - std::lgamma(dof / 2) - 0.5 * std::log(dof * kPiNumber);
  return std::exp(log_c - (dof + 1) / 2 * std::log1p(x * x / dof));
}

// P(0 < T < t) by Simpson's rule: the density is smooth, 400 panels give 1e-9.
double t_central_mass(double t, double dof) {
  const int n = 400;
  const double h = t / n;
  double s = t_density(0, dof) + t_density(t, dof);
  for (int i = 1; i < n; ++i) s += (i % 2 ? 4 : 2) * t_density(i * h, dof);
  return s * h / 3;
}

double mean_of(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / static_cast<double>(v.size());
}

// Pieces of constant drive: a piece ends when 5 samples in a row leave its band
// max(tol, 5 %) around its mean, so single noisy telemetry samples do not split it.
struct Piece {
  std::size_t begin = 0, end = 0;  // [begin, end) sample indices
  double drive_rpm = 0;
};

std::vector<Piece> constant_drive_pieces(const GantryData& g, double tol_rpm) {
  std::vector<Piece> pieces;
  const std::size_t n = g.t_s.size();
  constexpr int kLeave = 5;
  std::size_t begin = 0;
  double sum = 0;
  std::size_t count = 0;
  int misfits = 0;
  std::size_t first_misfit = 0;
  auto close = [&](std::size_t end) {
    if (count > 0 && end > begin) pieces.push_back({begin, end, sum / static_cast<double>(count)});
  };
  for (std::size_t i = 0; i < n; ++i) {
    const double s = g.drive_rpm[i];
    if (!measured(s)) {  // no telemetry: the piece cannot be trusted across the gap
      close(i);
      begin = i + 1, sum = 0, count = 0, misfits = 0;
      continue;
    }
    if (count == 0) {
      begin = i, sum = s, count = 1, misfits = 0;
      continue;
    }
    const double mean = sum / static_cast<double>(count);
    if (std::fabs(s - mean) <= std::max(tol_rpm, 0.05 * std::fabs(mean))) {
      sum += s, ++count, misfits = 0;
      continue;
    }
    if (misfits++ == 0) first_misfit = i;
    if (misfits == kLeave) {
      close(first_misfit);
      begin = first_misfit, sum = 0, count = 0, misfits = 0;
      for (std::size_t k = first_misfit; k <= i; ++k) sum += g.drive_rpm[k], ++count;
    }
  }
  close(n);
  return pieces;
}

// Straight line through (t, x) by least squares: slope and its standard error, the latter
// with the effective sample size of the residuals (position noise is not white: vibrations).
bool fit_slope(const std::vector<double>& t, const std::vector<double>& x, double& slope, double& se) {
  const std::size_t n = t.size();
  if (n < 10) return false;
  const double tm = mean_of(t), xm = mean_of(x);
  double stt = 0, stx = 0;
  for (std::size_t i = 0; i < n; ++i) stt += (t[i] - tm) * (t[i] - tm), stx += (t[i] - tm) * (x[i] - xm);
  if (!(stt > 0)) return false;
  slope = stx / stt;
  std::vector<double> r(n);
  double ss = 0;
  for (std::size_t i = 0; i < n; ++i) {
    r[i] = x[i] - xm - slope * (t[i] - tm);
    ss += r[i] * r[i];
  }
  const double n_eff = effective_sample_size({r});
  const double var_white = ss / static_cast<double>(n - 2) / stt;
  se = std::sqrt(var_white * static_cast<double>(n) / std::max(2.0, n_eff));
  return true;
}

void set_interval(Estimate& e, double confidence, double dof) {
  const double q = t_quantile(confidence, std::max(1.0, dof));
  e.lo = e.value - q * e.se;
  e.hi = e.value + q * e.se;
}

// Steady pieces of one group: each piece from settle_s after its start (or, with settle_s < 0,
// from that fraction of its length, before any D is known); tau of eq. (12)/(14) from sigma.
std::vector<SteadyPiece> steady_pieces(const std::vector<const GantryData*>& logs, double sigma,
                                       double settle_s, double settle_fraction,
                                       const IdentifyOptions& o) {
  std::vector<SteadyPiece> out;
  std::vector<double> t, x;
  for (const GantryData* g : logs) {
    for (const Piece& p : constant_drive_pieces(*g, o.drive_tol_rpm)) {
      if (std::fabs(p.drive_rpm) < std::max(1.0, 2 * o.drive_tol_rpm)) continue;  // stopped
      const double t0 = g->t_s[p.begin], t1 = g->t_s[p.end - 1];
      const double start = settle_s >= 0 ? t0 + settle_s : t0 + settle_fraction * (t1 - t0);
      if (t1 - start < o.min_steady_s) continue;
      t.clear(), x.clear();
      double drive_sum = 0;
      std::size_t drive_n = 0;
      for (std::size_t i = p.begin; i < p.end; ++i) {
        if (g->t_s[i] < start) continue;
        drive_sum += g->drive_rpm[i], ++drive_n;
        if (measured(g->position_m[i])) t.push_back(g->t_s[i]), x.push_back(g->position_m[i]);
      }
      SteadyPiece sp;
      if (!fit_slope(t, x, sp.velocity_mps, sp.velocity_se_mps)) continue;
      sp.file = g->file;
      sp.t_start_s = start;
      sp.t_end_s = t1;
      sp.drive_rpm = drive_sum / static_cast<double>(drive_n);
      sp.tau_n = sigma * sp.drive_rpm;  // eq. (12)/(14)
      out.push_back(sp);
    }
  }
  return out;
}

// eq. (17) written as u = tau / D: the regression is done on g = 1/D with the velocity as the
// dependent variable, because the velocity carries the measurement noise and tau (computed from
// the screw speeds) does not; regressing tau on a noisy u would bias D low.
struct DragFit {
  double g = 0, g_se = 0, dof = 0;
  std::string method;
};

DragFit fit_inverse_drag(const std::vector<SteadyPiece>& pieces) {
  DragFit f;
  double swtt = 0, swut = 0;
  for (const auto& p : pieces) {
    const double w = p.t_end_s - p.t_start_s;
    swtt += w * p.tau_n * p.tau_n;
    swut += w * p.velocity_mps * p.tau_n;
  }
  if (!(swtt > 0)) return f;
  f.g = swut / swtt;
  const std::size_t k = pieces.size();
  if (k >= 3) {
    // The scatter of the pieces about the line holds every error (noise, run-to-run terrain).
    double swrr = 0;
    for (const auto& p : pieces) {
      const double w = p.t_end_s - p.t_start_s;
      const double r = p.velocity_mps - f.g * p.tau_n;
      swrr += w * r * r;
    }
    f.g_se = std::sqrt(swrr / static_cast<double>(k - 1) / swtt);
    f.dof = static_cast<double>(k - 1);
    f.method = "weighted least squares of the steady velocities of " + std::to_string(k) +
               " pieces on tau, standard error from their scatter, t with " + std::to_string(k - 1) +
               " dof; sigma's uncertainty added";
  } else {
    double var = 0;
    for (const auto& p : pieces) {
      const double w = p.t_end_s - p.t_start_s;
      var += w * w * p.tau_n * p.tau_n * p.velocity_se_mps * p.velocity_se_mps;
    }
    f.g_se = std::sqrt(var) / swtt;
    f.dof = 1e9;
    f.method = "fewer than 3 steady pieces: standard error propagated from each piece's velocity "
               "fit (effective sample size of its residuals), normal quantile; sigma's uncertainty added";
  }
  return f;
}

GantryIdentification identify_group(const std::vector<const GantryData*>& logs, const IdentifyOptions& o) {
  GantryIdentification r;
  r.terrain = logs.front()->terrain;
  r.axis = logs.front()->axis;
  r.mass_kg = logs.front()->mass_kg;
  const std::string group = "terrain '" + r.terrain + "', axis '" + r.axis + "'";
  for (const GantryData* g : logs) {
    r.files.push_back(g->file);
    if (g->mass_kg != r.mass_kg)
      r.warnings.push_back(g->file + ": mass_kg " + std::to_string(g->mass_kg) + " differs from " +
                           std::to_string(r.mass_kg) + " (used only for the settle time)");
    if (!g->mass_from_log)
      r.warnings.push_back(g->file + ": no '# mass_kg:' metadata, the paper's 16 kg assumed");
  }

  // eqs. (15)-(16): the two axes' columns of X_sigma are disjoint, so each sigma is the scalar
  // least squares sum(s F) / sum(s^2) over its axis's samples. Only samples inside pieces of
  // constant screw speed, away from their ends, are used: the speed telemetry is an average over
  // the last sample period while the load cell reads the force now, so on a speed ramp the two
  // disagree (measured: +0.2-0.5 % bias in sigma on the simulated rig with all samples).
  std::vector<std::vector<std::size_t>> used;  // per piece: sample indices (one series each)
  std::vector<const GantryData*> used_log;
  for (const GantryData* g : logs) {
    for (const Piece& p : constant_drive_pieces(*g, o.drive_tol_rpm)) {
      std::vector<std::size_t> idx;
      const double t0 = g->t_s[p.begin] + o.sigma_edge_s, t1 = g->t_s[p.end - 1] - o.sigma_edge_s;
      for (std::size_t i = p.begin; i < p.end; ++i)
        if (g->t_s[i] >= t0 && g->t_s[i] <= t1 && measured(g->force_n[i])) idx.push_back(i);
      if (idx.empty()) continue;
      used.push_back(std::move(idx));
      used_log.push_back(g);
    }
  }
  double sss = 0, ssf = 0;
  for (std::size_t k = 0; k < used.size(); ++k)
    for (std::size_t i : used[k]) {
      const double s = used_log[k]->drive_rpm[i], f = used_log[k]->force_n[i];
      sss += s * s, ssf += s * f, ++r.n_samples;
    }
  if (!(sss > 0))
    throw std::runtime_error(group + ": the screws never turn steadily (B omega is zero), sigma cannot be identified");
  r.sigma.value = ssf / sss;

  // Its standard error: sigma_hat - sigma = sum(s e) / sum(s^2). The terms s e may be strongly
  // autocorrelated (rig vibration), so Var(sum s e) = n gamma0 * n / n_eff with n_eff from their
  // autocorrelation, per piece (no correlation assumed across pieces).
  std::vector<std::vector<double>> z(used.size());
  double szz = 0, srr = 0;
  for (std::size_t k = 0; k < used.size(); ++k) {
    for (std::size_t i : used[k]) {
      const double s = used_log[k]->drive_rpm[i];
      const double e = used_log[k]->force_n[i] - r.sigma.value * s;
      z[k].push_back(s * e);
      szz += z[k].back() * z[k].back();
      srr += e * e;
    }
  }
  const double n = static_cast<double>(r.n_samples);
  r.force_residual_rms_n = std::sqrt(srr / n);
  r.sigma.n_eff = effective_sample_size(z);
  r.sigma.se = std::sqrt(szz * n / r.sigma.n_eff) / sss;
  set_interval(r.sigma, o.confidence, r.sigma.n_eff - 1);
  r.sigma.ci_method = "least-squares standard error with the effective sample size of the "
                      "autocorrelated force residuals (Geyer's initial positive sequence), t quantile";

  // eq. (17), steady state: first with the second half of each piece, then with the settle
  // time 5 m/D of eq. (11) from the previous estimate, until the pieces stop changing.
  std::vector<SteadyPiece> pieces = steady_pieces(logs, r.sigma.value, -1, 0.5, o);
  DragFit fit = fit_inverse_drag(pieces);
  for (int it = 0; it < 4 && fit.g > 0; ++it) {
    const double settle_s = o.settle_time_constants * r.mass_kg * fit.g;  // 5 m / D
    auto next = steady_pieces(logs, r.sigma.value, settle_s, 0, o);
    if (next.empty()) {
      r.warnings.push_back("no piece of constant screw speed lasts " + std::to_string(settle_s + o.min_steady_s) +
                           " s (5 m/D to settle + " + std::to_string(o.min_steady_s) +
                           " s): D from the second half of each piece, may be biased");
      break;
    }
    const bool same = next.size() == pieces.size();
    pieces = std::move(next);
    fit = fit_inverse_drag(pieces);
    if (same && it > 0) break;
  }
  if (pieces.empty() || !(fit.g > 0)) {
    throw std::runtime_error(group + ": no steady piece of constant screw speed with the module moving "
                             "in the direction of its force (need >= " +
                             std::to_string(o.min_steady_s) + " s of steady motion and 10 positions)");
  }
  r.pieces = pieces;
  r.D.value = 1 / fit.g;
  if (pieces.size() < 3)
    r.warnings.push_back("D rests on " + std::to_string(pieces.size()) +
                         " steady piece(s) only; its interval is the within-piece noise, not run-to-run scatter");
  // eq. (17) says the steady velocity is proportional to tau. If the pieces scatter about that
  // line far beyond their own velocity noise, something the model lacks (dry friction, a dead
  // band, a change of ground) acts, and D absorbs it: say so rather than pass it on silently.
  double chi2 = 0;
  for (const auto& p : pieces) {
    const double r_mps = p.velocity_mps - fit.g * p.tau_n;
    chi2 += r_mps * r_mps / std::max(p.velocity_se_mps * p.velocity_se_mps, 1e-12);
  }
  if (pieces.size() >= 3 && chi2 / static_cast<double>(pieces.size() - 1) > 25)
    r.warnings.push_back("the steady velocities do not follow u = tau / D of eq. (17) within their noise (scatter " +
                         std::to_string(static_cast<int>(std::sqrt(chi2 / static_cast<double>(pieces.size() - 1)))) +
                         "x their standard errors): an effect the model lacks may act; try auger diagnose");
  const double rel_g = fit.g_se / fit.g, rel_sigma = r.sigma.se / r.sigma.value;
  // tau = sigma_hat * drive: D is proportional to sigma_hat, so their relative errors add.
  const double rel = std::sqrt(rel_g * rel_g + rel_sigma * rel_sigma);
  r.D.se = r.D.value * rel;
  r.D.n_eff = static_cast<double>(pieces.size());
  const double q = t_quantile(o.confidence, fit.dof);
  // The interval of g = 1/D mapped through 1/g: asymmetric in D, as the data are in 1/D.
  r.D.lo = r.D.value / (1 + q * rel);
  r.D.hi = q * rel < 1 ? r.D.value / (1 - q * rel) : std::numeric_limits<double>::infinity();
  r.D.ci_method = fit.method;
  return r;
}

}  // namespace

double t_quantile(double confidence, double dof) {
  // Normal quantile by bisection on erf (dof large), else on the t distribution.
  const double target = confidence / 2;
  double lo = 0, hi = 1;
  auto mass = [&](double t) {
    return dof > 1e6 ? 0.5 * std::erf(t / std::sqrt(2.0)) : t_central_mass(t, dof);
  };
  while (mass(hi) < target) hi *= 2;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (mass(mid) < target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

double effective_sample_size(const std::vector<std::vector<double>>& series) {
  double n = 0, sum = 0;
  for (const auto& s : series)
    for (double x : s) sum += x, ++n;
  if (n < 2) return n;
  const double m = sum / n;
  auto autocov = [&](std::size_t lag) {
    double c = 0;
    for (const auto& s : series)
      for (std::size_t i = 0; i + lag < s.size(); ++i) c += (s[i] - m) * (s[i + lag] - m);
    return c / n;
  };
  const double c0 = autocov(0);
  if (!(c0 > 0)) return n;
  // Geyer: tau = -1 + 2 sum_m (rho_2m + rho_2m+1) over the initial positive pairs.
  double tau = -1;
  const std::size_t max_lag = std::min<std::size_t>(static_cast<std::size_t>(n / 2), 4000);
  for (std::size_t lag = 0; lag + 1 < max_lag; lag += 2) {
    const double pair = (autocov(lag) + autocov(lag + 1)) / c0;
    if (pair <= 0) break;
    tau += 2 * pair;
  }
  return std::clamp(n / std::max(tau, 1e-9), 1.0, n);
}

GantryData read_gantry_data(const std::string& path) {
  GantryLogReader reader(path);
  const CsvLogReader& csv = reader.csv();
  GantryData g;
  g.file = path;
  // The reader has checked the metadata (docs/log-format.md "Gantry log").
  g.axis = reader.axis();
  g.terrain = reader.metadata().terrain.empty() ? "unknown" : reader.metadata().terrain;
  g.mass_from_log = reader.metadata().mass_kg.has_value();
  g.mass_kg = reader.metadata().mass_kg.value_or(g.mass_kg);
  // eqs. (12), (14): B_x = [-1, -1], B_y = [-1, 1].
  const double b1 = g.axis == "longitudinal" ? -1 : 1;
  GantrySample s;
  while (reader.next(s)) {
    g.t_s.push_back(s.t_s);
    g.drive_rpm.push_back(-s.omega_rpm[0] + b1 * s.omega_rpm[1]);
    g.force_n.push_back(s.force_n);
    g.position_m.push_back(s.position_m);
  }
  if (g.t_s.empty()) throw LogError(path, csv.header_line() + 1, 1, "no samples after the header");
  return g;
}

std::vector<GantryIdentification> identify_gantry(const std::vector<GantryData>& logs,
                                                  const IdentifyOptions& options) {
  std::map<std::pair<std::string, std::string>, std::vector<const GantryData*>> groups;
  for (const auto& g : logs) groups[{g.terrain, g.axis}].push_back(&g);
  std::vector<GantryIdentification> out;
  for (const auto& [key, members] : groups) out.push_back(identify_group(members, options));
  return out;
}

}  // namespace auger::wb
