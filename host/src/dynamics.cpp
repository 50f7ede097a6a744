// Dynamic model stepping, eqs. (5)-(7).
#include "auger/dynamics.hpp"

#include <algorithm>
#include <cmath>

namespace auger {

double first_order_step(double m, double d, double v, double f, double dt, double* gain) {
  return first_order_step(m, d, v, f, dt, d <= 0 ? 0.0 : std::exp(-d * dt / m), gain);
}

double first_order_step(double m, double d, double v, double f, double dt, double e, double* gain) {
  // eq. (6) per DOF: v(t) = v_inf + (v0 - v_inf) exp(-d t / m), v_inf = f / d.
  if (d <= 0) {
    if (gain) *gain = dt / m;
    return v + f * dt / m;
  }
  const double g = (1.0 - e) / d;
  if (gain) *gain = g;
  return v * e + f * g;
}

void StepDecay::update(const Vec3& m_diag, const Vec3& d_diag, double dt) {
  if (dt == dt_s && m_diag == m && d_diag == d) return;
  dt_s = dt;
  m = m_diag;
  d = d_diag;
  for (int k = 0; k < 3; ++k) e[k] = d[k] <= 0 ? 0.0 : std::exp(-d[k] * dt / m[k]);
  e_psi_displacement = d[2] <= 0 ? 0.0 : std::exp(-dt / (m[2] / d[2]));
}

namespace {
double first_order_displacement(double m, double d, double v, double f, double dt, double e) {
  if (d <= 0) return v * dt + 0.5 * f * dt * dt / m;
  const double v_inf = f / d;
  const double T = m / d;
  return v_inf * dt + (v - v_inf) * T * (1.0 - e);
}
}  // namespace

double first_order_displacement(double m, double d, double v, double f, double dt) {
  return first_order_displacement(m, d, v, f, dt, d <= 0 ? 0.0 : std::exp(-dt / (m / d)));
}

DynamicsData::DynamicsData(const Model& model) : effect_state(model.effect_state_size, 0.0) {
  reset(model);
}

void DynamicsData::reset(const Model& model) {
  std::fill(effect_state.begin(), effect_state.end(), 0.0);
  for (std::size_t k = 0; k < model.effects.size(); ++k)
    model.effects[k]->reset_state(effect_state.data() + model.effect_state_offset[k]);
}

void drive_force(const Model& model, DynamicsData& data, const Vec4& omega_rpm, double dt_s, Vec3& tau_n,
                 double t_s) {
  if (!std::isfinite(t_s)) t_s = data.t_s;
  double sigma_scale = 1.0;
  for (const auto& e : model.effects) sigma_scale *= e->traction_scale(t_s);
  tau_n = sigma_scale * (model.SB * omega_rpm);  // eq. (7), omega in rpm
  for (std::size_t k = 0; k < model.effects.size(); ++k)
    model.effects[k]->drive_force(model, omega_rpm, sigma_scale, dt_s, tau_n,
                                  data.effect_state.data() + model.effect_state_offset[k]);
}

void effect_body_force(const Model& model, DynamicsData& data, double t_s, const Vec3& eta, const Vec3& zeta,
                       const Vec4& omega_rpm, double dt_s) {
  EffectContext& c = data.ctx;
  c.t_s = t_s;
  c.eta = eta;
  c.zeta = zeta;
  c.omega_rpm = omega_rpm;
  c.tau_drive_n = data.tau_drive_n;
  c.dt_s = dt_s;
  data.step.update(model.M_diag, model.D_diag, dt_s);
  for (int k = 0; k < 3; ++k)
    c.zeta_free[k] = first_order_step(model.M_diag[k], model.D_diag[k], zeta[k], data.tau_drive_n[k], dt_s,
                                      data.step.e[k], &c.gain[k]);
  // Each effect sees the velocity the forces before it leave, so effects compose in order.
  Vec3 force = Vec3::Zero();
  data.tau_effect_n.setZero();
  for (std::size_t k = 0; k < model.effects.size(); ++k) {
    model.effects[k]->body_force(model, c, force, data.effect_state.data() + model.effect_state_offset[k]);
    data.tau_effect_n += force;
    c.zeta_free += c.gain.cwiseProduct(force);
  }
}

const Effect* effect_feedforward_force(const Model& model, const Vec3& eta, const Vec3& zeta, Vec3& force_n) {
  force_n.setZero();
  Vec3 f;
  for (const auto& e : model.effects) {
    if (!e->feedforward_force(model, eta, zeta, f)) continue;
    if (!f.allFinite()) return e.get();
    force_n += f;
  }
  return nullptr;
}

void dynamics_step(const Model& model, DynamicsData& data, Vec3& eta, Vec3& zeta,
                   const Vec4& omega_rpm, double dt_s, int n_sub) {
  if (!(dt_s > 0)) return;
  n_sub = std::max(n_sub, 1);
  const double h = dt_s / n_sub;
  EffectContext& c = data.ctx;
  for (int s = 0; s < n_sub; ++s) {
    drive_force(model, data, omega_rpm, h, data.tau_drive_n, data.t_s + s * h);
    effect_body_force(model, data, data.t_s + s * h, eta, zeta, omega_rpm, h);
    const Vec3 tau = data.tau_drive_n + data.tau_effect_n;
    // Closed-form velocity at the sub-step's middle, for the pose integration.
    data.half_step.update(model.M_diag, model.D_diag, 0.5 * h);
    auto zeta_half = [&]() {
      Vec3 z;
      for (int k = 0; k < 3; ++k)
        z[k] = first_order_step(model.M_diag[k], model.D_diag[k], zeta[k], tau[k], 0.5 * h, data.half_step.e[k], nullptr);
      return z;
    };
    // eq. (5) with RK4; psi itself is integrated exactly (r is known in closed form).
    auto f = [&](const Vec3& e, const Vec3& z) { return Vec3(rotation_J(e.z()) * z); };
    const Vec3 z0 = zeta, zm = zeta_half(), z1 = c.zeta_free;
    const Vec3 k1 = f(eta, z0);
    const Vec3 k2 = f(eta + 0.5 * h * k1, zm);
    const Vec3 k3 = f(eta + 0.5 * h * k2, zm);
    const Vec3 k4 = f(eta + h * k3, z1);
    const double psi_exact = eta.z() + first_order_displacement(model.M_diag[2], model.D_diag[2], zeta[2], tau[2], h,
                                                                data.step.e_psi_displacement);
    eta += (h / 6.0) * (k1 + 2 * k2 + 2 * k3 + k4);
    eta.z() = wrap_angle(psi_exact);
    zeta = z1;
  }
  data.t_s += dt_s;
}

Vec3 steady_velocity(const Model& model, const Vec4& omega_rpm) {
  return (model.SB * omega_rpm).cwiseQuotient(model.D_diag);  // eq. (6) with zeta_dot = 0
}

}  // namespace auger
