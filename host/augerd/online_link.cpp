// augerd's online identification (docs/daemon.md "Online identification"): the core's
// OnlineEstimator fed each cycle after the controller's step, its change events, the parameters
// it hands the controller, its log columns and status fields. Runs only with [online] enabled.
#include <cmath>
#include <cstdio>

#include "daemon.hpp"

namespace augerd {

namespace {
// The believed terrain's row name, "undecided" or "unknown" (status all: one token).
std::string terrain_token(const std::string& believed) { return believed.substr(0, believed.find(',')); }
}  // namespace

void Daemon::online_step(const std::array<auger::ScrewTelemetry, 4>& tel) {
  // The screw speeds held over the cycle just ended (the latest telemetry; a lost module breaks
  // the estimator's window) and the EKF's body velocity now, which fuses the IMU and the camera.
  auger::Vec4 omega_rpm;
  for (int i = 0; i < 4; ++i) omega_rpm[i] = bus_.module(i).lost ? NAN : tel[std::size_t(i)].omega_rpm;
  // Or, with velocity = "kinematic", the velocity of the camera's positions and the IMU's rate
  // alone (this cycle's sensors), which owes nothing to the configured terrain; none before the
  // first camera pose.
  const auger::Vec3 zeta = cfg_.online_kinematic ? online_kin_.step(sensors_in_, loop_dt_s_) : controller_->zeta_estimate();
  // A non-finite velocity (before the first camera pose, in a camera dropout) breaks the
  // estimator's window: it must see the cycle, not miss it.
  // The pose: the online effects' forces turn with the heading (a slope's).
  online_change_ = online_->step(omega_rpm, zeta, loop_dt_s_, controller_->eta_estimate());
  if (online_change_) {
    char what[200];
    std::snprintf(what, sizeof what,
                  "the ground changed (CUSUM over %.3g): the estimator's memory restarts from sigma_long %.3g, "
                  "sigma_lat %.3g, D_x %.4g, D_y %.4g, D_psi %.3g",
                  cfg_.online.cusum_threshold, online_->estimate().value[0], online_->estimate().value[1],
                  online_->estimate().value[2], online_->estimate().value[3], online_->estimate().value[4]);
    std::fprintf(stderr, "augerd: t=%.3f s: %s\n", t_s_, what);
    event(-1, "terrain-change", what);
    online_effects_event("online-effects", "the estimator's memory restarts with");
  }
  if (!online_->fallback().empty() && !online_fallback_said_) {
    // A warning, not a fault: the robot goes on with the configured terrain.
    online_fallback_said_ = true;
    const std::string what = "online estimate diverged (" + online_->fallback() + "); the controller uses the configured "
                             "terrain '" + cfg_.terrain + "' until augerd restarts";
    std::fprintf(stderr, "augerd: t=%.3f s: warning: %s\n", t_s_, what.c_str());
    event(-1, "online-fallback", what);
  }
  if (t_s_ >= believed_next_t_s_) {
    // What the estimate says the ground is, whether or not the controller uses it (apply off):
    // once a second (the name is a string), an event when its row changes.
    believed_next_t_s_ = t_s_ + 1.0;
    // The online effects' estimates: an event when an informed one moved by more than 2 SD
    // since the last (the first once informed).
    const auger::OnlineEstimate& e = online_->estimate();
    bool moved = false;
    for (int k = 0; k < e.effects; ++k)
      moved = moved || (e.effect_informed[k] > 0 && !(std::fabs(e.effect_value[k] - effects_said_[k]) <= 2 * e.effect_sd[k]));
    if (moved) online_effects_event("online-effects", "the estimate is now");
    const std::string believed = auger::believed_terrain(online_->estimate(), terrains_);
    believed_now_ = believed;
    if (terrain_token(believed) != believed_said_) {
      believed_said_ = terrain_token(believed);
      event(-1, "terrain-believed",
            "the estimate is closest to " + believed + " (compared: " + auger::believed_basis(online_->estimate()) + ")");
    }
  }
  if (cfg_.online_apply && online_->applied_changed()) {
    // eqs. (6), (7), (22) of the controller's model (it holds a reference to model_): its EKF's
    // prediction, the allocator's (S B)^+ and the null-space allocator's weights from the next step;
    // the online effects' parameters (a slope, a drag) into the model's fixed override slots, which
    // the effects' body forces in the EKF's prediction read (no effect rebuilt, no allocation).
    auger::set_terrain_parameters(model_, online_->control_parameters());
    auger::set_effect_parameters(model_, online_->effects(), online_->control_effect_parameters());
    auger::OnlineEstimate used;
    used.value = online_->control_parameters();
    used.sd = online_->estimate().sd;
    used.held = online_->estimate().held;
    const std::string believed = auger::believed_terrain(used, terrains_);
    if (terrain_token(believed) != applied_terrain_) {
      applied_terrain_ = terrain_token(believed);
      event(-1, "terrain-applied", "the controller now uses " + believed);
    }
  }
}

void Daemon::online_effects_event(const char* what, const char* lead) {
  const auger::OnlineEstimate& e = online_->estimate();
  if (e.effects == 0) return;
  std::string text = lead;
  char buf[160];
  for (int k = 0; k < e.effects; ++k) {
    const auger::OnlineEffectParam& p = online_->effects()[std::size_t(k)];
    std::snprintf(buf, sizeof buf, "%s %s %.4g +- %.2g %s%s", k ? "," : "", p.name.c_str(), e.effect_value[k],
                  e.effect_sd[k], p.unit.c_str(), e.effect_informed[k] > 0 ? "" : " (not informed yet)");
    text += buf;
    effects_said_[k] = e.effect_value[k];
  }
  event(-1, what, text + (cfg_.online_apply ? " (the controller takes each once its SD is below apply_rel_sd of its prior's)"
                                             : " (the controller keeps the model file's values: apply is off)"));
}

void Daemon::online_values(double* out) const {
  const auger::OnlineEstimate& e = online_->estimate();
  for (int k = 0; k < 5; ++k) {
    out[k] = e.value[k];
    out[5 + k] = e.sd[k];
  }
  out[10] = online_->cusum();
  out[11] = online_change_ ? 1 : 0;
  out[12] = online_->fallback().empty() ? 0 : 1;
  // What the controller's model holds (eqs. (6), (7)).
  out[13] = model_.terrain.sigma_long;
  out[14] = model_.terrain.sigma_lat;
  out[15] = model_.terrain.D_x;
  out[16] = model_.terrain.D_y;
  out[17] = model_.terrain.D_psi;
}

void Daemon::online_status(auger::daemon::Status& s) const {
  if (!online_) return;
  const auger::OnlineEstimate& e = online_->estimate();
  s.online = true;
  s.online_terrain = terrain_token(auger::believed_terrain(e, terrains_));
  s.on_drag_held = e.held[auger::kDx] > 0;
  s.on_sigma_long = e.value[0], s.on_sigma_lat = e.value[1], s.on_D_x = e.value[2], s.on_D_y = e.value[3];
  s.on_D_psi = e.value[4];
  s.on_sd_sigma_long = e.sd[0], s.on_sd_sigma_lat = e.sd[1], s.on_sd_D_x = e.sd[2], s.on_sd_D_y = e.sd[3];
  s.on_sd_D_psi = e.sd[4];
  s.on_cusum = online_->cusum();
  s.on_changes = static_cast<long>(online_->changes());
  s.on_fallback = !online_->fallback().empty();
  s.on_effects.clear();
  for (int k = 0; k < e.effects; ++k)
    s.on_effects.push_back({online_->effects()[std::size_t(k)].name, e.effect_value[k], e.effect_sd[k]});
}

void Daemon::online_snapshot(auger::ros2::OnlineSnapshot& o) const {
  o.enabled = online_ != nullptr;
  if (!online_) return;
  // Plain copies into fixed arrays: this runs in the 100 Hz loop (the name was made once a second).
  const auger::OnlineEstimate& e = online_->estimate();
  for (int k = 0; k < 5; ++k) o.value[k] = e.value[k], o.sd[k] = e.sd[k], o.held[k] = e.held[k] > 0;
  o.cusum = online_->cusum();
  o.cusum_threshold = cfg_.online.cusum_threshold;
  o.changes = static_cast<long>(online_->changes());
  std::snprintf(o.fallback.data(), o.fallback.size(), "%s", online_->fallback().c_str());
  std::snprintf(o.believed.data(), o.believed.size(), "%s", believed_now_.c_str());
  std::snprintf(o.basis.data(), o.basis.size(), "%s", auger::believed_basis(e));
  static_assert(auger::ros2::OnlineSnapshot::kMaxEffects == auger::kMaxOnlineEffects, "one limit");
  o.effects = e.effects;
  for (int k = 0; k < e.effects; ++k) {
    const auger::OnlineEffectParam& p = online_->effects()[std::size_t(k)];
    o.effect_value[k] = e.effect_value[k], o.effect_sd[k] = e.effect_sd[k];
    std::snprintf(o.effect_name[k].data(), o.effect_name[k].size(), "%s", p.name.c_str());
    std::snprintf(o.effect_unit[k].data(), o.effect_unit[k].size(), "%s", p.unit.c_str());
  }
}

}  // namespace augerd
