// The true gantry: see true_gantry.hpp and docs/robot-sim.md.
#include "true_gantry.hpp"

#include <cmath>

#include "true_robot.hpp"

namespace auger::sim {

namespace {
GantryState add(const GantryState& s, const GantryState& d, double h) {
  GantryState o = s;
  o.x_m += h * d.x_m;
  o.u_mps += h * d.u_mps;
  for (std::size_t i = 0; i < 2; ++i) {
    o.lag_rpm[i] += h * d.lag_rpm[i];
    o.lag_rate_rpmps[i] += h * d.lag_rate_rpmps[i];
  }
  return o;
}
}  // namespace

void TrueGantry::traction(const GantryState& s, const Vec4& w, std::array<double, 2>& f) const {
  for (int i = 0; i < 2; ++i) {
    const auto ii = static_cast<std::size_t>(i);
    double wi = p_.lag.on ? s.lag_rpm[ii] : w[i];
    if (p_.dead_band.on && !p_.lag.on) wi = dead_band_rpm(wi, p_.dead_band.omega_dead_rpm, p_.dead_band.corner_rpm);
    double fi = p_.sigma * p_.b[ii] * wi;
    if (p_.saturation.on) fi = saturate_force(fi, p_.saturation.max_n, p_.saturation.sharpness);
    f[ii] = fi;
  }
}

void TrueGantry::deriv(const GantryState& s, const Vec4& w, GantryState& d) const {
  std::array<double, 2> f{};
  traction(s, w, f);
  double k_drag = 1.0;
  if (p_.soft_patch.on)
    k_drag += p_.soft_patch.extra * 0.5 *
              (1.0 - std::tanh((std::fabs(s.x_m - p_.soft_patch.centre_m) - p_.soft_patch.half_length_m) / 0.01));
  double force = f[0] + f[1] - k_drag * p_.drag * s.u_mps;
  if (p_.friction.on) {
    const auto& fr = p_.friction;
    const double level =
        fr.coulomb_n + (fr.stiction_n - fr.coulomb_n) * std::exp(-(s.u_mps / fr.stribeck_mps) * (s.u_mps / fr.stribeck_mps));
    force -= level * std::tanh(s.u_mps / fr.eps_mps);
  }
  // Smooth at rest (u sqrt(u^2 + u0^2), u0 = 5 mm/s), not the workbench's u|u|.
  if (p_.quad_drag.on) force -= p_.quad_drag.c_nspm2 * s.u_mps * std::sqrt(s.u_mps * s.u_mps + 2.5e-5);
  d.x_m = s.u_mps;
  d.u_mps = force / p_.mass_kg;
  for (int i = 0; i < 2; ++i) {
    const auto ii = static_cast<std::size_t>(i);
    double wi = w[i];
    if (p_.dead_band.on) wi = dead_band_rpm(wi, p_.dead_band.omega_dead_rpm, p_.dead_band.corner_rpm);
    d.lag_rpm[ii] = s.lag_rate_rpmps[ii];
    d.lag_rate_rpmps[ii] = p_.lag.on ? (wi - s.lag_rpm[ii] - 2.0 * p_.lag.damping * p_.lag.tau_s * s.lag_rate_rpmps[ii]) /
                                           (p_.lag.tau_s * p_.lag.tau_s)
                                     : 0.0;
  }
}

void TrueGantry::step(const Vec4& w, double h) {
  GantryState k1, k2, k3, k4;
  const GantryState& s = s_;
  deriv(s, w, k1);
  deriv(add(s, k1, h / 2), w, k2);
  deriv(add(s, k2, h / 2), w, k3);
  deriv(add(s, k3, h), w, k4);
  GantryState o = s;
  o.x_m += h / 6 * (k1.x_m + 2 * k2.x_m + 2 * k3.x_m + k4.x_m);
  o.u_mps += h / 6 * (k1.u_mps + 2 * k2.u_mps + 2 * k3.u_mps + k4.u_mps);
  for (std::size_t i = 0; i < 2; ++i) {
    o.lag_rpm[i] += h / 6 * (k1.lag_rpm[i] + 2 * k2.lag_rpm[i] + 2 * k3.lag_rpm[i] + k4.lag_rpm[i]);
    o.lag_rate_rpmps[i] +=
        h / 6 * (k1.lag_rate_rpmps[i] + 2 * k2.lag_rate_rpmps[i] + 2 * k3.lag_rate_rpmps[i] + k4.lag_rate_rpmps[i]);
  }
  s_ = o;
}

double TrueGantry::traction_n(const Vec4& omega_rpm) const {
  std::array<double, 2> f{};
  traction(s_, omega_rpm, f);
  return f[0] + f[1];
}

}  // namespace auger::sim
