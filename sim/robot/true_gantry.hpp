// The simulated "true" gantry (docs/robot-sim.md "auger-sim-log"): one screw module on the
// identification rail, eqs. (11)-(14) m x'' = -D u + sigma B omega along one axis, with the
// effects in the module's own forms (the true robot's shapes, true_robot.hpp, along one DOF):
// smooth Stribeck friction, smooth quadratic drag, smooth traction saturation, a second-order
// force lag, a smooth dead band, a soft stretch of rail. Deliberately not the workbench's forms
// (docs/design.md "Hidden-effect honesty").
#pragma once

#include <array>

#include "auger/model.hpp"

namespace auger::sim {

struct GantryTruthParams {
  double mass_kg = 16.0;               // module plus load (Table 2)
  double sigma = 0.0, drag = 0.0;      // along the rail: sigma_long, D_x or sigma_lat, D_y
  std::array<double, 2> b{-1.0, -1.0};  // B_x = [-1, -1]; lateral B_y = [-1, 1]
  struct {  // level(u) = f_c + (f_s - f_c) exp(-(u / v_s)^2), times tanh(u / eps)
    bool on = false;
    double coulomb_n = 0.0, stiction_n = 0.0, stribeck_mps = 1.0, eps_mps = 1e-4;
  } friction;
  struct {  // -c u sqrt(u^2 + u0^2), u0 = 5 mm/s
    bool on = false;
    double c_nspm2 = 0.0;
  } quad_drag;
  struct {  // per screw, saturate_force's forms
    bool on = false;
    double max_n = 0.0, sharpness = 0.0;
  } saturation;
  struct {  // traction follows a second-order filter of each screw speed
    bool on = false;
    double tau_s = 0.15, damping = 0.8;
  } lag;
  struct {  // dead_band_rpm's forms
    bool on = false;
    double omega_dead_rpm = 0.0, corner_rpm = 0.0;
  } dead_band;
  struct {  // drag x (1 + extra) on the stretch |x - centre| < half_length (10 mm tanh edges)
    bool on = false;
    double centre_m = 0.0, half_length_m = 0.0, extra = 0.0;
  } soft_patch;
};

// Position and speed along the rail, and the force-lag filter (value, rate) per screw.
struct GantryState {
  double x_m = 0.0, u_mps = 0.0;
  std::array<double, 2> lag_rpm{}, lag_rate_rpmps{};
};

class TrueGantry {
 public:
  explicit TrueGantry(const GantryTruthParams& params) : p_(params) {}
  // One RK4 step of dt_s with the screw speeds (0 and 1 used) held.
  void step(const Vec4& omega_rpm, double dt_s);
  // Both screws' traction along the rail at the state (what the load cell measures).
  double traction_n(const Vec4& omega_rpm) const;
  GantryState& state() { return s_; }
  const GantryState& state() const { return s_; }
  const GantryTruthParams& params() const { return p_; }

 private:
  void traction(const GantryState& s, const Vec4& w, std::array<double, 2>& f) const;
  void deriv(const GantryState& s, const Vec4& w, GantryState& d) const;
  GantryTruthParams p_;
  GantryState s_;
};

}  // namespace auger::sim
