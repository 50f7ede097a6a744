// The effect library's registration list (docs/workbench.md "Adding an effect"): each file of
// host/src/effects/ defines its effects and one register_* function; register_builtin_effects
// (effect.cpp) calls every function listed here. To add an effect: a new file here, one line
// below, one line in host/CMakeLists.txt's auger_core list.
#pragma once

#include <cmath>
#include <string>

#include "auger/effect.hpp"

namespace auger::effects {

void register_friction(EffectRegistry& r);      // friction.cpp: coulomb_friction, stick_slip_friction, quadratic_drag
void register_drive(EffectRegistry& r);         // drive.cpp: screw_dead_band, screw_traction_loss, traction_saturation, force_lag
void register_terrain(EffectRegistry& r);       // terrain.cpp: terrain_slope, resistance_offset, terrain_change
void register_sensors(EffectRegistry& r);       // sensors.cpp: imu_heading_bias, imu_heading_drift, pose_time_offset
void register_body(EffectRegistry& r);          // body.cpp: rigid_body_coupling, yaw_time_constant, screw_blocking
void register_term(EffectRegistry& r);          // term.cpp: term (a discovered term, auger/term_form.hpp)

// Number formatting for describe() texts: "15", "0.12", "3.4e-05".
std::string fmt(double value);

// How fast the screws' contacts slide per unit of DOF k's speed (eq. (1)'s mounts): 1 along x and
// y (m/s per m/s), r hypot(l_x, l_y) in yaw (m/s per rad/s); the dry frictions' sliding speeds
// are speeds at the contacts.
inline double contact_speed_per_unit(const Model& m, int k) {
  if (k != 2) return 1.0;
  const double r_m = std::hypot(m.robot.l_x_m, m.robot.l_y_m);
  return r_m > 0 ? r_m : 1.0;
}

}  // namespace auger::effects
