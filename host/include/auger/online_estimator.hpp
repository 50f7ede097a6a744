// Online identification of the terrain parameters sigma_long, sigma_lat, D_x, D_y, D_psi of
// eqs. (6)-(7) while the robot drives, with a change detector that restarts the estimator's
// memory when the ground changes (docs/daemon.md "Online identification").
//
// Why recursive least squares on the generalized forces and not the EKF's state augmented with
// the parameters: eq. (6) is linear in the five parameters once the velocity is known,
// M zeta_dot = -D zeta + S B omega, so each cycle gives three scalar linear equations (one per DOF)
// and RLS is their exact recursive solution: no linearisation, a 5x5 covariance that means what
// it says, and every update costs a fixed few hundred flops. An augmented EKF (11 states) would
// couple the parameters to the pose filter's tuning (its process noise decides how fast sigma
// may move), make a wrong parameter drag the pose estimate, and cost an 11x11 update per
// measurement; the controller's EKF (estimation.hpp) stays as it is and feeds this module its
// velocity.
//
// The regression over a window [t_0, t_0 + W] of whole cycles (omega held over each, the modules'
// zero-order hold), eq. (6) integrated exactly on both sides per DOF j:
//   M_j (z_j(t_0 + W) - z_j(t_0)) / W = -D_j zbar_j + sigma_j fbar_j,
// with fbar_j the mean of (B omega)_j and zbar_j the mean velocity over the window (trapezoid per
// cycle: 0.3 % off in a step response with the shortest time constant, m / D_x = 0.05 s, at
// 10 ms). Only the window's end velocities enter the left side, so its noise falls as 1/W: a
// 0.1 s window carries ten times the information per second of one-cycle differences (whose
// noise, M sqrt(2) sd / 10 ms, is 8 N at 2 mm/s, as large as the transients that tell sigma from
// D), and one detector decision every 0.1 s is fine-grained enough for a 0.5 s delay.
// Parameters are estimated relative to the configured terrain (theta_rel = 1: as configured), so
// the five are of one scale in the covariance.
//
// The effects' parameters a model file marks `online = true` (docs/model.md) join the same
// regression as up to kMaxOnlineEffects more parameters: a fixed 8-parameter RLS (5 terrain + 3,
// the unused columns with a zero prior covariance, so they never move and cost a few flops)
// rather than a second estimator, because an effect's force and the terrain's share the same
// equations of eq. (6) and are correlated in them (a slope and sigma both explain a steady
// pull): only the joint covariance says how much of the residual each explains. An effect's
// part of the body force is g(p) * basis(state) (Effect::online_basis / online_shape); its
// regressor column is g'(p) times the basis's mean over the window, the residual takes g(p) at
// the current estimate: exact for a force linear in p (quadratic_drag's coefficients),
// a linearised RLS otherwise (terrain_slope's sin(incline), whose curvature is below 7 % of
// its slope within the physical range). Sensor-side parameters (an IMU bias) make no force:
// they are refused at load (EffectRegistry::create names the parameters that may be online).
// Each effect column updates only where it is informative: the force one prior SD of the
// parameter would make in that DOF over the window exceeds the excitation level (the terrain
// pair keeps its own rule); a DOF updates when any of its columns is informative, the others
// masked. Estimates are clamped to the parameter's physical range (ParamSpec::physical);
// unlike the terrain's, an effect parameter at its bound does not count as divergence (a drag
// coefficient's bound 0 may be the truth). With augerd's `apply` the controller's model takes
// them as it takes the terrain's (control_effect_parameters, set_effect_parameters): written
// into the model's fixed EffectOverride slots, which the effects read, so no effect is rebuilt
// (no allocation in the loop); the file's values again in fallback.
//
// No allocation after construction: fixed-size Eigen types only (a test counts allocations).
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "auger/model.hpp"

namespace auger {

using Vec5 = Eigen::Matrix<double, 5, 1>;
using Mat5 = Eigen::Matrix<double, 5, 5>;
// The effects' online parameters: at most this many (a fixed-size regression, no allocation).
constexpr int kMaxOnlineEffects = 3;
static_assert(kMaxOnlineEffects <= kMaxEffectOverrides, "the controller's model holds every online parameter");
using VecE = Eigen::Matrix<double, kMaxOnlineEffects, 1>;
constexpr int kOnlineParams = 5 + kMaxOnlineEffects;
using VecN = Eigen::Matrix<double, kOnlineParams, 1>;
using MatN = Eigen::Matrix<double, kOnlineParams, kOnlineParams>;

// An effect's parameter marked `online = true` in the model file (online_effect_params).
struct OnlineEffectParam {
  std::size_t effect = 0;  // into Model::effects (the model file's order)
  std::size_t index = 0;   // into that effect's params()
  std::string name;        // "terrain_slope.incline_x_rad"
  std::string unit;        // "rad"
  double configured = 0;   // the file's value: the prior's mean, the fallback
  double lower = 0, upper = 0;  // the physical range (ParamSpec::physical): the clamp
  double prior_sd = 1;     // a quarter of the physical range
};
struct ModelFile;
class EffectRegistry;
// The parameters the file marks online, in its order. Throws ConfigError (file, line, column of
// the `online` key) beyond kMaxOnlineEffects; a parameter that cannot be online was refused when
// the file's effects were created (EffectRegistry::create), as it is here.
std::vector<OnlineEffectParam> online_effect_params(const ModelFile& file, const EffectRegistry& registry);
// The regression holds the terrain and the online parameters' forces only: in an effect with a
// parameter online, another that could be but is not marked, at a non-zero value, makes a force
// the regression leaves out (a slope's other incline). One line per such parameter,
// "file:line: terrain_slope.incline_y_rad = 0.1 rad is not marked online: ...", "" none.
std::string online_effect_caveats(const ModelFile& file, const EffectRegistry& registry);

// Order of the parameter vector.
enum OnlineParam { kSigmaLong = 0, kSigmaLat = 1, kDx = 2, kDy = 3, kDpsi = 4 };
// The regression's row of DOF j (x, y, yaw) holds this sigma and D (eq. (7): S = diag(sigma_long,
// sigma_lat, sigma_lat)).
inline int online_sigma_of_dof(int j) { return j == 0 ? kSigmaLong : kSigmaLat; }
inline int online_drag_of_dof(int j) { return kDx + j; }
const char* online_param_name(int k);  // "sigma_long", ...
const char* online_param_unit(int k);  // "N/rpm", "N/(m/s)", "N m/(rad/s)"

struct OnlineConfig {
  bool enabled = false;  // augerd's `[online] enabled` (off: augerd as before, docs/daemon.md)
  // Memory of the directional forgetting (only the information along the regressor is
  // forgotten): each informative window scales it by exp(-window_s / memory_s).
  double memory_s = 5.0;
  // > 0: the detector tests the innovation of a second estimate with this shorter memory, run
  // beside the one the controller takes. A short memory follows the model's slow mismatches, so
  // the innovation's mean wanders less on uniform ground and a lower threshold holds the false
  // alarms, but the estimate it makes is too noisy to control with (docs/benchmarks.md "The
  // estimator's memory"). 0: the detector tests the estimate's own innovation.
  double detect_memory_s = 0.0;
  double window_s = 0.1;  // the regression's window (whole cycles; one RLS and detector update each)
  // SD of the fused body velocity fed in each cycle (m/s, m/s, rad/s): the noise of the
  // regression's left side is M sqrt(2) sd / W. The detector adapts its scale (below).
  Vec3 velocity_sd = Vec3(0.002, 0.002, 0.005);
  // A window in which any screw turned slower than this (rpm) is left out: a slow screw blocks in
  // sand (the library's screw_blocking effect: up to 36 N of dry resistance at its contact, fully
  // from 1.2 rpm, fading out by 1.8 rpm), which eqs. (6)-(7) lack. Measured on the firmware-in-the-
  // loop chain with the true velocity: sigma_long on uniform sand came out 0.51-0.64 for 0.812
  // N/rpm with every window in, 0.806-0.809 with 2 rpm (exact, 0.400, on frozen grass, which does
  // not block either way; docs/benchmarks.md). 0: all in (the core's model has no blocking).
  double slow_screw_rpm = 0.0;
  // ... and every window with such a cycle within this long before its start or after its end.
  // The logged speed is the encoder's over the last cycle, reported a cycle or two later: a
  // screw the controller reverses or stops blocks before its speed shows it (and after). On the
  // firmware-in-the-loop chain with the true velocity every false alarm on uniform sand was such
  // a window next to a slow one (docs/benchmarks.md "Blocking next to slow windows"). A window
  // is decided this long after its end (the detector's delay grows by as much); 0: at once.
  double slow_screw_guard_s = 0.02;
  // A DOF's equation updates only when the generalized force it predicts (either term) is at
  // least this many noise SDs: standing still or one-DOF driving leaves the other DOFs' parameters
  // (and their covariance) untouched.
  double excitation_sd = 2.0;
  // Prior SD of each parameter, relative to its configured value; the covariance returns to it
  // at a detected change (the memory restart).
  double prior_rel_sd = 0.5;
  // The same for D_x, D_y, D_psi. Small (0.01) holds the drag at its configured values and lets
  // sigma alone move: slow tracking makes almost no accelerations, so its data identify the
  // steady speed per rpm, sigma / D, and not the two apart (docs/daemon.md); the feedforward
  // and the allocation need that ratio.
  double drag_prior_rel_sd = 0.5;
  // CUSUM on the normalised innovation (OnlineEstimator::step): the per-DOF log-likelihood ratio
  // of an innovation variance cusum_ratio times the model's, summed, alarm above the threshold.
  double cusum_ratio = 4.0;
  double cusum_threshold = 16.0;  // docs/benchmarks.md: 1-2 false alarms in 20 h, median delay 0.16-0.23 s
  // The detector prewhitens each DOF's innovation with its lag-1 correlation, learned on quiet
  // stretches as the noise scale is: the innovation of the firmware-in-the-loop chain is coloured
  // (lag 1 window: 0.8 in surge), and a CUSUM of coloured squares raises false alarms
  // (docs/daemon.md "Online identification"). false: the innovation as it is (the core bench).
  bool whiten = true;
  double holdoff_s = 0.5;         // after a change: the detector waits while the estimate settles
  double noise_adapt_s = 20.0;    // time constant of the detector's noise scale (no change pending)
  // Divergence (fallback to the configured terrain, latched): a parameter held at its physical
  // bound this long, or more than max_changes detections within change_window_s.
  double bound_hold_s = 2.0;
  int max_changes = 5;
  double change_window_s = 10.0;
  // The controller takes an estimated parameter once its SD is below this share of its value.
  double apply_rel_sd = 0.1;
};

// The physical range of each terrain parameter for this robot (a 29 kg robot on soil, at most
// 23 rpm): the workbench's fits outside it are flagged, the online estimate is clamped to it.
// Tables 2-3 span sigma 0.09-0.81 N/rpm and D 23-560 N/(m/s).
struct TerrainRange {
  double lower, upper;
};
const TerrainRange& terrain_range(int k);  // k: OnlineParam

struct OnlineEstimate {
  Vec5 value = Vec5::Zero();   // sigma_long, sigma_lat (N/rpm), D_x, D_y (N/(m/s)), D_psi (N m/(rad/s))
  Vec5 sd = Vec5::Zero();      // their standard deviations (same units)
  Vec5 informed = Vec5::Zero();  // 1 where the data have informed the parameter since the last restart
  // 1 where the parameter is held at its configured value (prior SD at most kHeldRelSd of it, e.g.
  // drag_prior_rel_sd = 0.01): the data then identify only the ratio sigma / D of its DOF.
  Vec5 held = Vec5::Zero();
  // The effects' online parameters (OnlineEffectParam order; entries past `effects` unused), in
  // their units, with SDs; informed as above.
  int effects = 0;
  VecE effect_value = VecE::Zero(), effect_sd = VecE::Zero(), effect_informed = VecE::Zero();
};
constexpr double kHeldRelSd = 0.05;

class OnlineEstimator {
 public:
  // The configured terrain (the prior and the fallback) and the model's mass and B are taken
  // from the model (copied), and `effects` (online_effect_params) are estimated with it; throws
  // std::invalid_argument if the terrain has no D_psi, or on more than kMaxOnlineEffects
  // effects, one not in the model or without a finite physical range.
  OnlineEstimator(const Model& model, const OnlineConfig& config, const std::vector<OnlineEffectParam>& effects = {});

  // Back to the configured terrain with the prior covariance; clears the fallback.
  void reset();

  // One cycle: the screw speeds held over the cycle just ended (rpm), the fused body velocity at
  // its end (u, v in m/s, r in rad/s), dt_s its length, and the pose at its end (x, y m, psi rad;
  // only the online effects read it: a slope's force turns with the heading; a non-finite pose
  // breaks the window when there are any). Returns true when a change was detected in this
  // cycle (the covariance has been reset). No heap allocation.
  bool step(const Vec4& omega_rpm, const Vec3& zeta, double dt_s, const Vec3& eta = Vec3::Constant(NAN));
  const std::vector<OnlineEffectParam>& effects() const { return effects_; }

  // The current estimate (physical units).
  const OnlineEstimate& estimate() const { return est_; }
  // What the controller should use: the configured terrain in fallback; else each parameter's
  // estimate once its SD is below apply_rel_sd of its value, else the value last applied.
  const Vec5& control_parameters() const { return applied_; }
  // The same for the effects' online parameters (effects() order, entries past their count
  // unused): the file's value in fallback; else each estimate once informed with its SD below
  // apply_rel_sd of its prior SD (a parameter may be 0: its value is no scale), else the value
  // last applied. Always inside the physical range (the estimate is clamped to it).
  const VecE& control_effect_parameters() const { return applied_eff_; }
  // True when control_parameters() or control_effect_parameters() changed in the last step.
  bool applied_changed() const { return applied_changed_; }
  const Vec5& configured() const { return ref_; }

  double cusum() const { return g_; }                 // the detector's statistic (alarm at threshold)
  double last_nis() const { return nis_; }            // this cycle's summed normalised innovation squared
  int last_rows() const { return rows_; }             // DOFs informative this cycle (0..3)
  // The last window's innovation per DOF (N, N, N m; NaN where the DOF was not informative) and
  // the parameters' share of its predicted variance (phi^T P phi, same units squared): for
  // measuring the innovation's real statistics (bench/online_fil.cpp).
  const Vec3& last_innovation() const { return innov_; }
  const Vec3& last_innovation_param_var() const { return innov_s_; }
  // The regression's noise variance per DOF as configured (from velocity_sd).
  const Vec3& configured_noise_var() const { return noise_var0_; }
  std::uint64_t windows() const { return windows_; }  // regression windows ended since construction
  // The regression's noise SD per DOF as adapted, over the configured one (1: as configured).
  Vec3 noise_scale() const { return noise_var_.cwiseQuotient(noise_var0_).cwiseSqrt(); }
  std::uint64_t changes() const { return changes_; }  // detections since construction
  double last_change_t_s() const { return last_change_t_s_; }  // estimator time of the last one (NaN none)
  double t_s() const { return t_s_; }                 // the estimator's clock (sum of dt_s)
  // Latched when the estimate diverged (the reason, "" none): control_parameters() are then the
  // configured terrain until reset().
  const std::string& fallback() const { return fallback_; }
  const OnlineConfig& config() const { return cfg_; }

 private:
  bool twin() const { return cfg_.detect_memory_s > 0; }  // the detector has its own estimate
  void restart_memory();
  void enter_fallback(const char* why);
  void end_window();
  void close_window();
  bool slow_guarded() const;
  void publish();
  double update_row(int dof, const VecN& phi, const VecN& phi_update, double y, bool adapt);
  void rls_row(VecN& theta, MatN& P, double memory_s, double r, const VecN& phi, const VecN& phi_update, double y,
               double& e, double& s, double& s_forgot) const;
  void keep_prior(VecN& theta, MatN& P, double memory_s, const bool* updated) const;
  void effect_bases(const Vec3& eta, const Vec3& zeta, Vec3* out) const;
  void keep_prior(const bool* updated);

  OnlineConfig cfg_;
  Model model_;                   // the effects' bases read it (a copy: no lifetime to keep)
  std::vector<OnlineEffectParam> effects_;
  int n_eff_ = 0;
  Vec3 M_;                        // eq. (8) (with the effects' inertia)
  Eigen::Matrix<double, 3, 4> B_;  // eq. (10)
  Vec5 ref_;                      // configured terrain (physical)
  // theta_ times scale_ is the physical value: the terrain's relative to ref_, an effect's in
  // units of its prior SD; theta0_ the configured values (the reset); lo_/hi_ the physical ranges.
  VecN scale_, theta0_, lo_rel_, hi_rel_;
  MatN P0_;
  VecN theta_;
  MatN P_;
  // The detector's estimate with detect_memory_s (unused at 0): the same regression, a shorter
  // memory; restarted, clamped and pulled to the held prior as the estimate is.
  VecN theta_d_;
  MatN P_d_;
  Vec3 noise_var_d_;              // its noise variance per DOF (adapted from its innovation)
  Vec3 eff_prev_[kMaxOnlineEffects], eff_sum_[kMaxOnlineEffects];  // the effects' bases: last, window sum
  Vec3 noise_var_;                // per DOF: the regression's noise variance (adapted)
  Vec3 noise_var0_;
  Vec3 innov_ = Vec3::Constant(NAN), innov_s_ = Vec3::Zero();
  // The detector's prewhitening per DOF: the last innovation (NaN: none in the last window) and
  // the innovation's variance and lag-1 covariance, both learned while no change is pending.
  Vec3 e_prev_ = Vec3::Constant(NAN), e_var_ = Vec3::Zero(), e_cov1_ = Vec3::Zero();
  Vec3 clipped_ = Vec3::Zero();  // the last window's statistic beyond the clip, per DOF (update_row)
  OnlineEstimate est_;
  Vec5 applied_;
  VecE applied_eff_ = VecE::Zero(), configured_eff_ = VecE::Zero();
  bool applied_changed_ = false;
  Vec3 zeta_start_ = Vec3::Zero();  // the window's start velocity, and its sums
  Vec3 zeta_prev_ = Vec3::Zero();
  Vec3 f_sum_ = Vec3::Zero(), z_sum_ = Vec3::Zero();
  double w_s_ = 0;
  bool have_prev_ = false;
  bool slow_ = false;  // a screw slower than slow_screw_rpm in this window (or within the guard before it)
  double last_slow_t_s_ = -1e300;  // the end of the last cycle with a slow screw
  // A window ended and waiting slow_screw_guard_s for a slow screw after it (end_window reads it).
  struct Window {
    Vec3 f_sum, z_sum, zeta_start, zeta_end;
    Vec3 eff_sum[kMaxOnlineEffects];
    double w_s = 0, due_s = 0;
    bool slow = false, valid = false;
  } win_;
  double g_ = 0, nis_ = 0;
  int rows_ = 0;
  double t_s_ = 0, holdoff_until_s_ = 0;
  double last_change_t_s_;
  std::uint64_t changes_ = 0, windows_ = 0;
  static constexpr int kChangeRing = 16;
  double change_times_[kChangeRing];
  Vec5 at_bound_s_ = Vec5::Zero();
  std::string fallback_;
};

// The terrain the estimate is closest to: the name of the one row of `terrains` whose every
// compared quantity lies within max(3 SD, 15 %) of the estimate's; "undecided, sand or
// frozen_grass within the estimate's uncertainty" when several do (the closest first, by the
// largest difference in units of that tolerance); else "unknown, sigma_long 0.41 N/rpm,
// sigma_lat ..., D_x ... (held), ...". The first word (up to a comma) is the one-token name.
// Compared: each estimated parameter; where a DOF's drag is held, the ratio sigma / D of that DOF
// instead (eq. (6): the steady speed per rpm, which is what the data then identify), x with
// sigma_long / D_x, y with sigma_lat / D_y, yaw with sigma_lat / D_psi (the yaw row of the
// regression). Nothing estimated: "unknown". Not for the 100 Hz path (builds a string).
std::string believed_terrain(const OnlineEstimate& estimate, const std::vector<TerrainParams>& terrains);
// What believed_terrain compares: "sigma, D" or "sigma / D (D held)" (status, events, diagnostics).
const char* believed_basis(const OnlineEstimate& estimate);

// Sets a model's terrain parameters in place (S, S B, (S B)^+, D of eqs. (6), (7), (22)) without
// allocating; the effects and the mass stay. Throws std::invalid_argument on non-physical values.
void set_terrain_parameters(Model& model, const Vec5& params);
// Sets the effects' online parameters of a model to `values` (effects' order) in its
// EffectOverride slots, without allocating: the effects' body forces (eq. (6)) use them from
// then on. The model must be the one `effects` were made for (online_effect_params: the same
// file's effects in its order); throws std::invalid_argument on a non-finite value.
void set_effect_parameters(Model& model, const std::vector<OnlineEffectParam>& effects, const VecE& values);

}  // namespace auger
