// The module adapter (module_adapter.hpp).
#include "module_adapter.hpp"

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

std::size_t encode_setpoint(std::uint16_t seq, double omega_rpm, bool enable, bool clear_faults, std::uint8_t* buf,
                            bool* finite) {
  proto_setpoint_t sp{};
  sp.seq = seq;
  const bool ok = setpoint_crpm(omega_rpm, sp.omega_crpm);
  sp.flags = std::uint8_t((enable && ok ? PROTO_SP_ENABLE : 0) | (clear_faults ? PROTO_SP_CLEAR_FAULTS : 0));
  if (finite) *finite = ok;
  return proto_encode_setpoint(&sp, buf);
}

void log_telemetry(const ModuleTelemetry& tm, std::size_t i, RobotSample& row) {
  if (!tm.received) return;
  row.omega_rpm[i] = tm.omega_rpm();
  row.current_a[i] = tm.current_a();
  row.voltage_v[i] = tm.voltage_v();
  row.pwm[i] = tm.pwm();
  row.status[i] = tm.frame.status;
  row.seq_ack[i] = tm.frame.seq_ack;
}

void log_reference(const Vec3& eta_d, RobotSample& row) {
  row.xd_m = eta_d[0];
  row.yd_m = eta_d[1];
  row.psid_rad = wrap_angle(eta_d[2]);
}

}  // namespace auger::io
