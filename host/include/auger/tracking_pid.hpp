// Tracking PID, eqs. (19)-(21), in the body frame (docs/model-notes.md decision): the pose error is
// rotated by J(psi)^T before the gains, the heading error wrapped to (-pi, pi], the integral
// accumulated per control step (as the group's controllers.py does) and clamped.
#pragma once

#include <string>

#include "auger/model.hpp"
#include "auger/trajectory.hpp"

namespace auger {

struct PidGains {
  Vec3 kp, kd, ki;            // per DOF: x, y (N per m, N per m/s, N per m-step), yaw (N m ...)
  Vec3 integral_limit;        // |ki * integral| clamp per DOF, in N, N, N m
};

// Table 5 gains for x and y on "sand" or "frozen_grass" (other names: sand's). Yaw has its own
// gains (decision): Table 5's 150 would saturate the screws at about 0.01 rad of heading error
// with the paper's small yaw row of B.
PidGains table5_gains(const std::string& terrain);

struct PidState {
  Vec3 integral = Vec3::Zero();  // sum over control steps of the body-frame pose error
};

struct PidTerms {
  Vec3 error_body;  // J(psi)^T eta_tilde, heading wrapped, eq. (19)
  Vec3 rate_error;  // J(psi)^T eta_d_dot - zeta, eq. (20)
  Vec3 tau_n;       // eq. (21)
};

// eqs. (19)-(21); eta is the estimated pose, zeta the estimated body velocity.
void tracking_pid(const PidGains& gains, PidState& state, const Vec3& eta, const Vec3& zeta,
                  const ReferenceState& ref, PidTerms& out);

}  // namespace auger
