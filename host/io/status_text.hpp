// The module's status word, reset cause, settings origin and fault snapshot (docs/protocol.md)
// as words, for augerd's messages and event log and the field tools' displays; and the one
// check of a module's protocol version.
#pragma once

#include <cstdint>
#include <string>

#include "protocol.h"

namespace auger::io {

// State bits of the low byte: "EN SP" ("-" if none).
std::string state_bits_text(uint16_t status);
// Latched faults of the high byte: "F_OVERCURRENT+F_SENSOR" ("none" if no fault bit; an
// unknown bit as "F_0x..").
std::string fault_bits_text(uint16_t status);
// IDENTITY reset_cause: "power-on", "brown-out+external", "warm reset (cause cleared by the
// bootloader)", "none reported".
std::string reset_cause_text(uint8_t reset_cause);
// IDENTITY flags: "EEPROM", "build defaults (EEPROM empty)", "build defaults (the EEPROM held
// an older settings layout)", "build defaults (the EEPROM image was corrupt)".
std::string settings_origin_text(uint8_t identity_flags);
// A FAULT frame in a line: what latched and what the module measured at that moment.
std::string fault_snapshot_text(const proto_fault_t& f);
// Throws std::runtime_error with what to do when the module speaks another protocol version.
void require_protocol(const proto_identity_t& id, const std::string& port, const std::string& program);

}  // namespace auger::io
