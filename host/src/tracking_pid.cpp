// Tracking PID, eqs. (19)-(21).
#include "auger/tracking_pid.hpp"

#include <algorithm>

namespace auger {

PidGains table5_gains(const std::string& terrain) {
  PidGains g;
  if (terrain == "frozen_grass") {
    g.kp << 160, 160, 5;
    g.kd << 90, 90, 2;
    g.ki << 1.5, 1.5, 0.05;
  } else {
    g.kp << 150, 150, 5;
    g.kd << 30, 30, 2;
    g.ki << 1.2, 1.2, 0.05;
  }
  // About the drive's reach at 23 rpm (4 sigma 23: 75 N long., 23 N lat. on sand; yaw 1.5 N m).
  g.integral_limit << 30, 15, 0.5;
  return g;
}

void tracking_pid(const PidGains& g, PidState& s, const Vec3& eta, const Vec3& zeta,
                  const ReferenceState& ref, PidTerms& out) {
  Vec3 eta_tilde = ref.eta_d - eta;                    // eq. (19)
  eta_tilde.z() = wrap_angle(eta_tilde.z());
  const Mat3 Jt = rotation_J(eta.z()).transpose();     // body frame (decision on eq. (21))
  out.error_body = Jt * eta_tilde;
  out.rate_error = Jt * ref.eta_d_dot - zeta;          // eq. (20): zeta, not zeta_dot
  s.integral += out.error_body;
  for (int k = 0; k < 3; ++k) {
    if (g.ki[k] > 0) {
      const double lim = g.integral_limit[k] / g.ki[k];
      s.integral[k] = std::clamp(s.integral[k], -lim, lim);
    } else {
      s.integral[k] = 0;
    }
  }
  out.tau_n = g.kp.cwiseProduct(out.error_body) + g.kd.cwiseProduct(out.rate_error) +
              g.ki.cwiseProduct(s.integral);           // eq. (21)
}

}  // namespace auger
