// The module status word (docs/protocol.md "Status word") as names, for augerd's messages and
// the field tools' displays.
#pragma once

#include <cstdint>
#include <string>

namespace auger::io {

// State bits of the low byte: "EN SP" ("-" if none).
std::string state_bits_text(uint16_t status);
// Latched faults of the high byte: "F_OVERCURRENT+F_SENSOR" ("none" if no fault bit; an
// unknown bit as "F_0x..").
std::string fault_bits_text(uint16_t status);

}  // namespace auger::io
