// Online identification of eqs. (6)-(7)'s terrain parameters (RLS with directional forgetting)
// and the change detector on its innovation (CUSUM); online_estimator.hpp says why these.
#include "auger/online_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "auger/effect.hpp"
#include "auger/model_file.hpp"

namespace auger {

namespace {
const char* const kNames[5] = {"sigma_long", "sigma_lat", "D_x", "D_y", "D_psi"};
const char* const kUnits[5] = {"N/rpm", "N/rpm", "N/(m/s)", "N/(m/s)", "N m/(rad/s)"};
// Absolute limits for a 29 kg robot (the workbench flags fits outside them, host/wb_engine/search.cpp).
const TerrainRange kRanges[5] = {{0.02, 3}, {0.01, 2}, {10, 5000}, {5, 5000}, {0.2, 200}};
constexpr double kNisClip = 25.0;  // one wild window adds at most this much per DOF (5 SD) ...
// ... until the next window holds the level: both beyond 3 SD, of one sign, the second at least
// 3/4 of the first (a transient the regression's windows do not resolve decays faster).
constexpr double kLevelHeldSd = 3.0, kLevelHeldRatio = 0.75;
}  // namespace

const char* online_param_name(int k) { return kNames[k]; }
const char* online_param_unit(int k) { return kUnits[k]; }
const TerrainRange& terrain_range(int k) { return kRanges[k]; }

OnlineEstimator::OnlineEstimator(const Model& model, const OnlineConfig& config,
                                 const std::vector<OnlineEffectParam>& effects)
    : cfg_(config), model_(model), effects_(effects), M_(model.M_diag), B_(model.B) {
  const TerrainParams& t = model.terrain;
  if (!std::isfinite(t.D_psi) || !(t.D_psi > 0))
    throw std::invalid_argument("online estimation needs the terrain's D_psi (terrain '" + t.name + "' has none)");
  // The configured terrain is the reference, whatever the model was set to since.
  ref_ << t.sigma_long, t.sigma_lat, t.D_x, t.D_y, t.D_psi;
  if (effects_.size() > std::size_t(kMaxOnlineEffects))
    throw std::invalid_argument("online estimation: at most " + std::to_string(kMaxOnlineEffects) +
                                " effect parameters (" + std::to_string(effects_.size()) + " given)");
  n_eff_ = static_cast<int>(effects_.size());
  scale_.setOnes();
  theta0_.setZero();
  lo_rel_.setZero();
  hi_rel_.setZero();
  for (int k = 0; k < 5; ++k) {
    scale_[k] = ref_[k];
    theta0_[k] = 1;
    lo_rel_[k] = kRanges[k].lower / ref_[k];
    hi_rel_[k] = kRanges[k].upper / ref_[k];
  }
  for (int k = 0; k < n_eff_; ++k) {
    const OnlineEffectParam& e = effects_[std::size_t(k)];
    if (e.effect >= model.effects.size() || !std::isfinite(e.lower) || !std::isfinite(e.upper) || !(e.upper > e.lower) ||
        !(e.prior_sd > 0) || !std::isfinite(e.configured))
      throw std::invalid_argument("online estimation: effect parameter '" + e.name +
                                  "' is not in the model or has no finite physical range");
    scale_[5 + k] = e.prior_sd;
    theta0_[5 + k] = std::clamp(e.configured, e.lower, e.upper) / e.prior_sd;
    lo_rel_[5 + k] = e.lower / e.prior_sd;
    hi_rel_[5 + k] = e.upper / e.prior_sd;
    configured_eff_[k] = std::clamp(e.configured, e.lower, e.upper);
  }
  if (!(cfg_.window_s > 0) || !(cfg_.memory_s > 0) || !(cfg_.detect_memory_s >= 0) || !(cfg_.prior_rel_sd > 0) ||
      !(cfg_.drag_prior_rel_sd > 0) ||
      !(cfg_.cusum_ratio > 1) || !(cfg_.cusum_threshold > 0) || !(cfg_.velocity_sd.minCoeff() > 0) ||
      !(cfg_.slow_screw_guard_s >= 0))
    throw std::invalid_argument("online estimation: window_s, prior_rel_sd, drag_prior_rel_sd, velocity_sd > 0, memory_s > 0, "
                                "detect_memory_s >= 0, "
                                "cusum_ratio > 1, cusum_threshold > 0, slow_screw_guard_s >= 0");
  fallback_.reserve(64);  // latching a reason later allocates nothing
  P0_.setZero();  // an unused effect column: no prior variance, never moves
  for (int k = 0; k < 5 + n_eff_; ++k) P0_(k, k) = 1.0;  // an effect's prior SD is its unit
  for (int k = kSigmaLong; k <= kSigmaLat; ++k) P0_(k, k) = cfg_.prior_rel_sd * cfg_.prior_rel_sd;
  for (int k = kDx; k <= kDpsi; ++k) P0_(k, k) = cfg_.drag_prior_rel_sd * cfg_.drag_prior_rel_sd;
  // Noise of M_j (z_end - z_start) / W from the two end velocities.
  for (int j = 0; j < 3; ++j) {
    const double sd = M_[j] * std::sqrt(2.0) * cfg_.velocity_sd[j] / cfg_.window_s;
    noise_var0_[j] = sd * sd;
  }
  reset();
}

void OnlineEstimator::reset() {
  theta_ = theta0_;
  theta_d_ = theta0_;
  applied_ = ref_;
  applied_eff_ = configured_eff_;
  applied_changed_ = false;
  noise_var_ = noise_var0_;
  noise_var_d_ = noise_var0_;
  e_prev_.setConstant(NAN);
  e_var_.setZero();
  e_cov1_.setZero();
  clipped_.setZero();
  have_prev_ = false;
  win_.valid = false;
  last_slow_t_s_ = -1e300;
  g_ = nis_ = 0;
  rows_ = 0;
  t_s_ = 0;
  last_change_t_s_ = std::nan("");
  for (double& c : change_times_) c = -1e300;
  at_bound_s_.setZero();
  fallback_.clear();
  restart_memory();
  // The detector starts once the noise scale has been seen for a while.
  holdoff_until_s_ = std::max(2.0, cfg_.holdoff_s);
}

void OnlineEstimator::restart_memory() {
  P_ = P0_;
  P_d_ = P0_;
  g_ = 0;
  est_.informed.setZero();
  est_.effect_informed.setZero();
  est_.effects = n_eff_;
  for (int k = 0; k < 5; ++k) est_.held[k] = std::sqrt(P0_(k, k)) <= kHeldRelSd ? 1 : 0;
  publish();
}

// The estimate in physical units from theta_ and P_.
void OnlineEstimator::publish() {
  const VecN value = theta_.cwiseProduct(scale_), sd = P_.diagonal().cwiseSqrt().cwiseProduct(scale_);
  est_.value = value.head<5>();
  est_.sd = sd.head<5>();
  est_.effect_value = value.tail<kMaxOnlineEffects>();
  est_.effect_sd = sd.tail<kMaxOnlineEffects>();
}

void OnlineEstimator::enter_fallback(const char* why) {
  if (fallback_.empty()) fallback_ = why;  // latched: the first reason (no allocation: short, SSO)
  theta_ = theta0_;
  theta_d_ = theta0_;
  applied_changed_ = applied_ != ref_ || applied_eff_ != configured_eff_;
  applied_ = ref_;
  applied_eff_ = configured_eff_;
  restart_memory();
}

// One scalar RLS update with directional forgetting (Kulhavy) of (theta, P) over a memory of
// memory_s, r the row's noise variance: the information along phi is scaled by the forgetting
// factor, the rest of the covariance stays, so a parameter the data do not inform keeps its
// uncertainty instead of winding up. e and s: the innovation of the prediction before the update and the parameters'
// share of its variance (phi^T P phi); s_forgot: that share after the forgetting (the gain's).
// phi_update is phi with the columns that are not informative in this window zeroed: they stay
// in the prediction (e) but take no update.
void OnlineEstimator::rls_row(VecN& theta, MatN& P, double memory_s, double r, const VecN& phi, const VecN& phi_update,
                              double y, double& e, double& s, double& s_forgot) const {
  e = y - phi.dot(theta);
  VecN Pphi = P * phi_update;
  s = phi_update.dot(Pphi);
  s_forgot = s;
  if (s > 1e-12 * r) {
    const double lambda = std::exp(-cfg_.window_s / memory_s);
    P += ((1.0 - lambda) / (lambda * s)) * (Pphi * Pphi.transpose());
    Pphi /= lambda;  // P phi after the forgetting: phi^T P phi grew by 1 / lambda, along Pphi
    s_forgot /= lambda;
  }
  const VecN K = Pphi / (r + s_forgot);
  theta += K * e;
  P -= K * Pphi.transpose();
  P = 0.5 * (P + P.transpose());
  // Never more uncertain than the prior (the forgetting cannot wind up a direction for good).
  for (int k = 0; k < 5 + n_eff_; ++k) {
    if (P(k, k) > P0_(k, k)) {
      const double c = std::sqrt(P0_(k, k) / P(k, k));
      P.row(k) *= c;
      P.col(k) *= c;
    }
  }
}

// The estimate's update of DOF j's row, and the detector's statistic of the row: the normalised
// innovation squared of the detector's estimate (the estimate's own, or with detect_memory_s its
// faster twin), whitened.
double OnlineEstimator::update_row(int j, const VecN& phi, const VecN& phi_update, double y, bool adapt) {
  double e = 0, s0 = 0, s = 0;
  rls_row(theta_, P_, cfg_.memory_s, noise_var_[j], phi, phi_update, y, e, s0, s);
  // Each estimate's noise variance follows its own innovation (below); the detector's statistic
  // and whitening take the twin's where there is one.
  const double e_est = e, s_est = s;
  const bool twin = this->twin();
  if (twin) rls_row(theta_d_, P_d_, cfg_.detect_memory_s, noise_var_d_[j], phi, phi_update, y, e, s0, s);
  const double r = twin ? noise_var_d_[j] : noise_var_[j];
  const double nis = e * e / (r + s0);
  innov_[j] = e;
  innov_s_[j] = s0;
  // The detector's statistic: the innovation whitened by its learned lag-1 correlation rho
  // (an AR(1) model of the colour: w = e_k - rho e_(k-1), variance (1 - rho^2) of e's), in units
  // of its learned variance, never below the variance the regression predicts (r + s). On the
  // core's model (white velocity noise) rho stays near 0 and this is the plain NIS.
  double stat = nis;
  if (cfg_.whiten && e_var_[j] > 0) {
    const double rho = std::clamp(e_cov1_[j] / e_var_[j], 0.0, 0.95);
    const double var = std::max(e_var_[j], r + s);
    if (std::isnan(e_prev_[j])) {
      stat = e * e / var;
    } else {
      const double w = e - rho * e_prev_[j];
      stat = w * w / (var * (1 - rho * rho));
    }
  }
  // The detector's noise scale, and the whitening's variance and lag-1 covariance, follow the
  // innovations slowly, while no change is pending: the model's small steady mismatches and the
  // velocity's colour are noise to it, a change is not.
  if (adapt) {
    const double a = cfg_.window_s / cfg_.noise_adapt_s;
    auto follow = [&](double& var, double e1, double s1) {
      var = std::clamp((1 - a) * var + a * std::max(0.0, e1 * e1 - s1), 0.05 * noise_var0_[j], 100.0 * noise_var0_[j]);
    };
    follow(noise_var_[j], e_est, s_est);
    if (twin) follow(noise_var_d_[j], e, s);
    e_var_[j] = e_var_[j] > 0 ? (1 - a) * e_var_[j] + a * e * e : r + s;
    if (!std::isnan(e_prev_[j])) e_cov1_[j] = (1 - a) * e_cov1_[j] + a * e * e_prev_[j];
  }
  // A terrain change is a step in the innovation: whitened, its first window carries nearly all of
  // its evidence (the level after it looks like the colour), and the clip would cut a step of
  // 6 SD to what a 5 SD one gives. A wild window (one bad velocity) does not persist, a step does:
  // the clipped excess is credited when the next window holds the level.
  const double sd_raw = std::sqrt(std::max(e_var_[j], r + s));  // e_var_: 0 until learned
  const bool held = !std::isnan(e_prev_[j]) && e * e_prev_[j] > 0 && std::fabs(e_prev_[j]) >= kLevelHeldSd * sd_raw &&
                    std::fabs(e) >= std::max(kLevelHeldSd * sd_raw, kLevelHeldRatio * std::fabs(e_prev_[j]));
  const double credit = held ? clipped_[j] : 0.0;
  clipped_[j] = std::max(0.0, stat - kNisClip);
  e_prev_[j] = e;
  return std::min(stat, kNisClip) + credit;
}

// Stabilised forgetting of the held parameters: the forgetting discounts the prior's information
// along with the data's, so a parameter whose prior is all that holds it (the drag at
// drag_prior_rel_sd 0.01) would drift with whatever the data pull it to. Each window that updates
// one gives its prior back the share it lost, as a measurement at its configured value with
// variance P0 / (W / memory), so the prior's information stays about P0^-1 (only after an update:
// the forgetting is directional, a parameter the data do not inform loses nothing). Not the free
// parameters: their prior is only a start, and a pull back to the configured terrain would hold
// them off the new one after a change. Why it matters: the velocity in phi's drag column is
// measured, and its error (the camera's, coloured over 0.3 s) biases a fitted drag low (errors in
// variables), the steady-speed ratio sigma / D then dragging sigma along: sigma_long on uniform
// sand came out 0.65-0.69 instead of 0.812 on firmware-in-the-loop logs, 0.81 with this
// (docs/benchmarks.md "The drag's prior kept").
void OnlineEstimator::keep_prior(const bool* updated) {
  keep_prior(theta_, P_, cfg_.memory_s, updated);
  if (twin()) keep_prior(theta_d_, P_d_, cfg_.detect_memory_s, updated);
}

void OnlineEstimator::keep_prior(VecN& theta, MatN& P, double memory_s, const bool* updated) const {
  const double share = cfg_.window_s / memory_s;
  bool pulled = false;
  for (int k = 0; k < 5; ++k) {
    if (!updated[k] || est_.held[k] == 0) continue;
    const double s = P(k, k) + P0_(k, k) / share;
    const VecN Pk = P.col(k);
    theta += Pk * ((theta0_[k] - theta[k]) / s);
    P -= (Pk * Pk.transpose()) / s;
    pulled = true;
  }
  if (pulled) P = 0.5 * (P + P.transpose());
}

void OnlineEstimator::effect_bases(const Vec3& eta, const Vec3& zeta, Vec3* out) const {
  for (int k = 0; k < n_eff_; ++k) {
    const OnlineEffectParam& e = effects_[std::size_t(k)];
    out[k] = model_.effects[e.effect]->online_basis(model_, e.index, eta, zeta);
  }
}

bool OnlineEstimator::step(const Vec4& omega_rpm, const Vec3& zeta, double dt_s, const Vec3& eta) {
  applied_changed_ = false;
  // A stalled loop or a non-finite input breaks the window: its integral would be wrong.
  if (!(dt_s > 0) || dt_s > 5 * cfg_.window_s || !omega_rpm.allFinite() || !zeta.allFinite() ||
      (n_eff_ > 0 && !eta.allFinite())) {
    have_prev_ = false;
    win_.valid = false;  // its guard cannot be checked: left out as a slow one
    e_prev_.setConstant(NAN);  // the next window's innovation does not follow this one's
    return false;
  }
  t_s_ += dt_s;
  if (!have_prev_) {
    zeta_start_ = zeta_prev_ = zeta;
    f_sum_.setZero();
    z_sum_.setZero();
    w_s_ = 0;
    slow_ = slow_guarded();
    have_prev_ = true;
    effect_bases(eta, zeta, eff_prev_);
    for (int k = 0; k < n_eff_; ++k) eff_sum_[k].setZero();
    return false;
  }
  const bool slow_now = omega_rpm.cwiseAbs().minCoeff() < cfg_.slow_screw_rpm;
  if (slow_now) last_slow_t_s_ = t_s_;
  slow_ = slow_ || slow_now;
  const std::uint64_t before = changes_;
  if (win_.valid) {
    win_.slow = win_.slow || slow_now;
    if (t_s_ >= win_.due_s - 1e-9) close_window();
  }
  f_sum_ += (B_ * omega_rpm) * dt_s;            // eq. (7) without S: (B omega) held over the cycle
  z_sum_ += 0.5 * (zeta_prev_ + zeta) * dt_s;  // trapezoid
  zeta_prev_ = zeta;
  if (n_eff_ > 0) {
    Vec3 now[kMaxOnlineEffects];
    effect_bases(eta, zeta, now);
    for (int k = 0; k < n_eff_; ++k) {
      eff_sum_[k] += 0.5 * (eff_prev_[k] + now[k]) * dt_s;  // trapezoid, as the velocity
      eff_prev_[k] = now[k];
    }
  }
  w_s_ += dt_s;
  if (w_s_ < cfg_.window_s - 1e-9) return changes_ != before;
  if (win_.valid) close_window();  // a guard longer than a window
  win_.f_sum = f_sum_;
  win_.z_sum = z_sum_;
  win_.zeta_start = zeta_start_;
  win_.zeta_end = zeta;
  for (int k = 0; k < n_eff_; ++k) win_.eff_sum[k] = eff_sum_[k];
  win_.w_s = w_s_;
  win_.slow = slow_;
  win_.due_s = t_s_ + (cfg_.slow_screw_rpm > 0 ? cfg_.slow_screw_guard_s : 0.0);
  win_.valid = true;
  if (t_s_ >= win_.due_s - 1e-9) close_window();
  zeta_start_ = zeta;
  f_sum_.setZero();
  z_sum_.setZero();
  for (int k = 0; k < n_eff_; ++k) eff_sum_[k].setZero();
  w_s_ = 0;
  slow_ = slow_guarded();
  return changes_ != before;
}

// A window starting now begins within the guard after a slow screw.
bool OnlineEstimator::slow_guarded() const {
  return cfg_.slow_screw_guard_s > 0 && t_s_ - last_slow_t_s_ <= cfg_.slow_screw_guard_s + 1e-9;
}

void OnlineEstimator::close_window() {
  win_.valid = false;
  end_window();
}

void OnlineEstimator::end_window() {
  const double w_s = win_.w_s;
  const Vec3 fbar = win_.f_sum / w_s, zbar = win_.z_sum / w_s;
  const Vec3 y = M_.cwiseProduct(win_.zeta_end - win_.zeta_start) / w_s;
  const bool detecting = t_s_ >= holdoff_until_s_;
  const bool adapt = detecting && g_ < 0.25 * cfg_.cusum_threshold;
  const double rho = cfg_.cusum_ratio, log_rho = std::log(rho);
  double llr = 0;
  bool updated[5] = {};  // the terrain parameters this window's rows updated
  rows_ = 0;
  nis_ = 0;
  innov_.setConstant(NAN);
  ++windows_;
  for (int j = 0; j < 3; ++j) {
    const int si = online_sigma_of_dof(j), di = online_drag_of_dof(j);
    VecN phi = VecN::Zero();
    phi[si] = ref_[si] * fbar[j];
    phi[di] = -ref_[di] * zbar[j];
    // Excitation: a DOF whose drive force and drag are both within the noise says nothing about
    // them; an effect's column, when one prior SD of its parameter makes less force than that;
    // a window with a slow (blocking) screw is outside eqs. (6)-(7).
    const double level = cfg_.excitation_sd * std::sqrt(noise_var_[j]);
    VecN phi_update = phi;
    bool informative = std::max(std::fabs(phi[si] * theta_[si]), std::fabs(phi[di] * theta_[di])) >= level;
    if (!informative) phi_update[si] = phi_update[di] = 0;
    // The effects' force at the estimate minus its linear part: the residual is then exact.
    double y_j = y[j];
    for (int k = 0; k < n_eff_; ++k) {
      // The shape at the current estimate (g(p) basis; the previous DOF's update moved it).
      const OnlineEffectParam& e = effects_[std::size_t(k)];
      double dg = 0;
      const double g = model_.effects[e.effect]->online_shape(e.index, theta_[5 + k] * scale_[5 + k], &dg);
      const double basis = win_.eff_sum[k][j] / w_s;
      phi[5 + k] = dg * basis * scale_[5 + k];
      y_j -= g * basis - phi[5 + k] * theta_[5 + k];
      if (std::fabs(phi[5 + k]) >= level) {  // P0 = 1: one prior SD's force
        phi_update[5 + k] = phi[5 + k];
        informative = true;
      }
    }
    if (win_.slow || !informative) {
      e_prev_[j] = NAN;
      continue;
    }
    const double nis = update_row(j, phi, phi_update, y_j, adapt);
    for (int k = 0; k < 5; ++k) updated[k] = updated[k] || phi_update[k] != 0;
    nis_ += nis;
    ++rows_;
    // CUSUM increment: log-likelihood ratio of an innovation variance rho times the model's.
    llr += 0.5 * (nis * (1.0 - 1.0 / rho) - log_rho);
  }
  if (rows_ > 0) keep_prior(updated);
  // Clamp to the physical ranges; a terrain parameter held at a bound is a symptom of divergence.
  for (int k = 0; k < 5 + n_eff_; ++k) {
    const double c = std::clamp(theta_[k], lo_rel_[k], hi_rel_[k]);
    if (k < 5) at_bound_s_[k] = c != theta_[k] ? at_bound_s_[k] + w_s : 0.0;
    theta_[k] = c;
    if (twin()) theta_d_[k] = std::clamp(theta_d_[k], lo_rel_[k], hi_rel_[k]);
  }
  if (!theta_.allFinite() || !P_.allFinite() || (twin() && (!theta_d_.allFinite() || !P_d_.allFinite()))) {
    enter_fallback("the estimate became non-finite");
    return;
  }
  if (at_bound_s_.maxCoeff() >= cfg_.bound_hold_s) {
    at_bound_s_.setZero();
    enter_fallback("a parameter stayed at its physical bound");
    return;
  }
  publish();
  for (int k = 0; k < 5; ++k)
    if (P_(k, k) < 0.25 * P0_(k, k)) est_.informed[k] = 1;
  for (int k = 0; k < n_eff_; ++k)
    if (P_(5 + k, 5 + k) < 0.25 * P0_(5 + k, 5 + k)) est_.effect_informed[k] = 1;

  if (rows_ > 0 && detecting) g_ = std::max(0.0, g_ + llr);
  if (g_ > cfg_.cusum_threshold) {
    ++changes_;
    last_change_t_s_ = t_s_;
    change_times_[changes_ % kChangeRing] = t_s_;
    holdoff_until_s_ = t_s_ + cfg_.holdoff_s;
    restart_memory();
    const int n = std::min(cfg_.max_changes + 1, kChangeRing);
    if (changes_ >= std::uint64_t(n) &&
        t_s_ - change_times_[(changes_ - std::uint64_t(n) + 1) % kChangeRing] < cfg_.change_window_s) {
      enter_fallback("changes detected too often");
      return;
    }
  }
  if (!fallback_.empty()) return;  // the configured terrain until reset()
  for (int k = 0; k < 5; ++k) {
    const double v = est_.value[k], sd = est_.sd[k];
    if (est_.informed[k] > 0 && sd < cfg_.apply_rel_sd * v && std::fabs(v - applied_[k]) > std::max(2 * sd, 0.01 * v)) {
      applied_[k] = v;
      applied_changed_ = true;
    }
  }
  for (int k = 0; k < n_eff_; ++k) {
    const double v = est_.effect_value[k], sd = est_.effect_sd[k];
    if (est_.effect_informed[k] > 0 && sd < cfg_.apply_rel_sd * scale_[5 + k] && std::fabs(v - applied_eff_[k]) > 2 * sd) {
      applied_eff_[k] = v;
      applied_changed_ = true;
    }
  }
}

std::vector<OnlineEffectParam> online_effect_params(const ModelFile& file, const EffectRegistry& registry) {
  std::vector<OnlineEffectParam> out;
  for (std::size_t i = 0; i < file.effects.size(); ++i) {
    const EffectConfig& c = file.effects[i];
    for (const EffectParamValue& p : c.params) {
      if (!p.online) continue;
      if (!registry.has(c.id)) registry.create(c);  // throws: the unknown id, with the known ones
      const EffectRegistry::Entry& entry = registry.entries().at(c.id);
      const auto spec = std::find_if(entry.params.begin(), entry.params.end(),
                                     [&](const ParamSpec& s) { return s.name == p.name; });
      if (spec == entry.params.end() || !spec->online) {
        registry.create(c);  // throws, naming the parameters that may be online
        throw ConfigError(c.file, p.online_line, p.online_column, c.id + "." + p.name + " cannot be estimated online");
      }
      if (out.size() == std::size_t(kMaxOnlineEffects))
        throw ConfigError(c.file, p.online_line, p.online_column,
                          "at most " + std::to_string(kMaxOnlineEffects) + " effect parameters may be online (this is the " +
                              std::to_string(kMaxOnlineEffects + 1) + "th: " + c.id + "." + p.name + ")");
      OnlineEffectParam e;
      e.effect = i;
      e.index = static_cast<std::size_t>(spec - entry.params.begin());
      e.name = c.id + "." + p.name;
      e.unit = spec->unit;
      e.configured = p.value;
      e.lower = spec->physical_lower;
      e.upper = spec->physical_upper;
      // A quarter of the physical range: a prior that lets the data move the estimate anywhere
      // in it within a few windows, and an SD the clamp rarely cuts.
      e.prior_sd = 0.25 * (e.upper - e.lower);
      if (!(e.configured >= e.lower && e.configured <= e.upper)) {
        char what[160];
        std::snprintf(what, sizeof what, " = %g is outside its physical range %g..%g %s", p.value, e.lower, e.upper,
                      e.unit.c_str());
        throw ConfigError(c.file, p.line, p.column,
                          c.id + "." + p.name + what + ": an online estimate starts from it and is clamped to that range");
      }
      out.push_back(std::move(e));
    }
  }
  return out;
}

std::string online_effect_caveats(const ModelFile& file, const EffectRegistry& registry) {
  std::string out;
  for (const EffectConfig& c : file.effects) {
    const bool any = std::any_of(c.params.begin(), c.params.end(), [](const EffectParamValue& p) { return p.online; });
    if (!any || !registry.has(c.id)) continue;
    for (const ParamSpec& spec : registry.entries().at(c.id).params) {
      const auto p = std::find_if(c.params.begin(), c.params.end(), [&](const EffectParamValue& v) { return v.name == spec.name; });
      const double value = p != c.params.end() ? p->value : spec.default_value;
      if (!spec.online || (p != c.params.end() && p->online) || value == 0) continue;
      char line[320];
      std::snprintf(line, sizeof line,
                    "%s:%d: %s.%s = %g %s is not marked online: the online regression leaves its force out (mark it "
                    "online to estimate it with the rest)\n",
                    c.file.c_str(), p != c.params.end() ? p->line : c.line, c.id.c_str(), spec.name.c_str(), value,
                    spec.unit.c_str());
      out += line;
    }
  }
  return out;
}

namespace {
// Difference of a row from the estimate in units of the tolerance max(3 SD, 15 %) over the
// compared quantities (believed_terrain); -1 when nothing is compared.
double row_distance(const OnlineEstimate& e, const double (&v)[5]) {
  double worst = -1;
  const auto compare = [&](double est, double sd, double row) {
    if (!std::isfinite(row)) {
      worst = 1e300;
      return;
    }
    const double tol = std::max(3 * sd, 0.15 * std::fabs(est));
    worst = std::max(worst, std::fabs(est - row) / tol);
  };
  for (int j = 0; j < 3; ++j) {
    const int si = online_sigma_of_dof(j), di = online_drag_of_dof(j);  // the regression's rows (end_window)
    if (e.held[di] > 0 && e.held[si] == 0) {
      // The ratio's relative SD is sigma's (the held D has almost none).
      const double ratio = e.value[si] / e.value[di];
      compare(ratio, e.sd[si] / e.value[di], v[si] / v[di]);
    } else {
      if (e.held[si] == 0) compare(e.value[si], e.sd[si], v[si]);
      if (e.held[di] == 0) compare(e.value[di], e.sd[di], v[di]);
    }
  }
  return worst;
}
}  // namespace

std::string believed_terrain(const OnlineEstimate& e, const std::vector<TerrainParams>& terrains) {
  std::vector<const TerrainParams*> fit;  // rows within the tolerance, the closest first
  double best_d = 1e300;
  for (const TerrainParams& t : terrains) {
    const double v[5] = {t.sigma_long, t.sigma_lat, t.D_x, t.D_y, t.D_psi};
    const double d = row_distance(e, v);
    if (d < 0 || d > 1) continue;
    if (d < best_d) best_d = d, fit.insert(fit.begin(), &t);
    else fit.push_back(&t);
  }
  if (fit.size() == 1) return fit.front()->name;
  if (fit.size() > 1) {
    // The estimate's uncertainty spans several rows (before the data inform it): naming the
    // closest would be a guess given with confidence.
    std::string s = "undecided, " + fit.front()->name;
    for (std::size_t i = 1; i < fit.size(); ++i) s += (i + 1 == fit.size() ? " or " : ", ") + fit[i]->name;
    return s + " within the estimate's uncertainty";
  }
  std::string s = "unknown";
  char buf[80];
  for (int k = 0; k < 5; ++k) {
    std::snprintf(buf, sizeof buf, ", %s %.3g %s%s", kNames[k], e.value[k], kUnits[k], e.held[k] > 0 ? " (held)" : "");
    s += buf;
  }
  return s;
}

const char* believed_basis(const OnlineEstimate& e) {
  return e.held.segment<3>(kDx).maxCoeff() > 0 ? "sigma / D (D held)" : "sigma, D";
}

void set_effect_parameters(Model& m, const std::vector<OnlineEffectParam>& effects, const VecE& values) {
  if (effects.size() > std::size_t(kMaxOnlineEffects))
    throw std::invalid_argument("set_effect_parameters: more online parameters than the model holds");
  for (std::size_t k = 0; k < effects.size(); ++k) {
    if (!std::isfinite(values[int(k)]) || effects[k].effect >= m.effects.size())
      throw std::invalid_argument("set_effect_parameters: " + effects[k].name + " non-finite or not in the model");
    m.effect_overrides[k] = {m.effects[effects[k].effect].get(), effects[k].index, values[int(k)]};
  }
}

void set_terrain_parameters(Model& m, const Vec5& p) {
  for (int k = 0; k < 5; ++k)
    if (!(p[k] > 0) || !std::isfinite(p[k]))
      throw std::invalid_argument(std::string("terrain parameter ") + kNames[k] + " must be finite and > 0");
  m.terrain.sigma_long = p[kSigmaLong];
  m.terrain.sigma_lat = p[kSigmaLat];
  m.terrain.D_x = p[kDx];
  m.terrain.D_y = p[kDy];
  m.terrain.D_psi = p[kDpsi];
  apply_terrain(m);
}

}  // namespace auger
