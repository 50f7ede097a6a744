// The motor module as the host's programs see it, in one place for augerd's module bus, the
// lock-step scheduler (sim/robot) and the field tools (host/operator, auger-module): telemetry in
// SI units (speeds in rpm, the model's unit) with its freshness, the setpoint frame with its one
// clamp to the wire's range, and the one mapping of telemetry to robot-log columns
// (docs/log-format.md). The wire's units (0.01 rpm, mA, mV, 1e-4 duty) stay inside this file.
#pragma once

#include <cstddef>
#include <cstdint>

#include "auger/controller.hpp"
#include "auger/log.hpp"
#include "protocol.h"

namespace auger::io {

// A speed field of the wire (int16 in 0.01 rpm, shared/protocol.h) in rpm.
constexpr double rpm_from_crpm(std::int32_t crpm) { return crpm / 100.0; }

// The setpoint for omega_rpm, saturated to +-32767 crpm (+-327.67 rpm). A non-finite omega_rpm
// gives 0 and returns false (lround(NaN) is undefined behaviour): the caller treats it as a
// fault (something upstream computed nonsense).
bool setpoint_crpm(double omega_rpm, int16_t& out);

// One SETPOINT frame into buf (PROTO_MAX_FRAME bytes); returns its length. ENABLE only when
// enable is asked and the speed is finite (else 0 rpm is sent disabled and *finite, if given,
// is false); CLEAR_FAULTS when asked.
std::size_t encode_setpoint(std::uint16_t seq, double omega_rpm, bool enable, bool clear_faults, std::uint8_t* buf,
                            bool* finite = nullptr);

// A module's latest telemetry.
struct ModuleTelemetry {
  proto_telemetry_t frame{};  // as the module sent it (its clock, counters, status word)
  bool received = false;      // a frame has come (since the link opened or the module restarted)
  bool fresh = false;         // a newer frame came in this control period

  // A newer frame (the caller keys on frame.time_ms): received and fresh.
  void take(const proto_telemetry_t& f) {
    frame = f;
    received = fresh = true;
  }
  double omega_rpm() const { return rpm_from_crpm(frame.omega_crpm); }          // measured speed
  double omega_cmd_rpm() const { return rpm_from_crpm(frame.omega_cmd_crpm); }  // setpoint in use
  double current_a() const { return frame.current_ma / 1000.0; }
  double voltage_v() const { return frame.voltage_mv / 1000.0; }
  double pwm() const { return frame.duty_x10000 / 10000.0; }  // duty cycle, signed fraction
  // The controller's input: the speed, valid only when fresh (else it predicts the speed).
  ScrewTelemetry controller_input() const {
    ScrewTelemetry s;
    s.omega_rpm = omega_rpm();
    s.valid = fresh;
    return s;
  }
};

// Module i's columns of a robot-log row: omega_rpm_i, current_a_i, voltage_v_i, pwm_i, status_i,
// seq_ack_i, from its latest telemetry (left as they are when none has been received).
void log_telemetry(const ModuleTelemetry& tm, std::size_t i, RobotSample& row);

// The reference pose of a robot-log row (xd_m, yd_m, psid_rad) from the controller's reference:
// the heading wrapped to (-pi, pi] like the pose's, whatever turns the reference has made. One
// convention for augerd's logs and the simulator's.
void log_reference(const Vec3& eta_d, RobotSample& row);

}  // namespace auger::io
