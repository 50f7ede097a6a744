// Setpoint encoding (setpoint.hpp).
#include "setpoint.hpp"

#include <cmath>

namespace auger::io {

bool setpoint_crpm(double omega_rpm, int16_t& out) {
  if (!std::isfinite(omega_rpm)) {
    out = 0;
    return false;
  }
  const double crpm = omega_rpm * 100.0;  // finite * 100 may overflow to inf: clamped next
  if (crpm >= 32767.0) out = 32767;
  else if (crpm <= -32767.0) out = -32767;
  else out = static_cast<int16_t>(std::lround(crpm));
  return true;
}

}  // namespace auger::io
