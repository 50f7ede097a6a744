// A screw speed in rpm as the setpoint frame's int16 in 0.01 rpm (shared/protocol.h): the one
// encoding for augerd, the lock-step scheduler and the field tools. It saturates at the wire's
// +-327.67 rpm and never converts a NaN (lround(NaN) is undefined behaviour).
#pragma once

#include <cstdint>

namespace auger::io {

// The setpoint for omega_rpm, saturated to +-32767 crpm. A non-finite omega_rpm gives 0 and
// returns false: the caller treats it as a fault (something upstream computed nonsense).
bool setpoint_crpm(double omega_rpm, int16_t& out);

}  // namespace auger::io
