#include "status_text.hpp"

#include "module_adapter.hpp"

#include <cstdio>
#include <stdexcept>
#include <utility>

namespace auger::io {

namespace {

struct BitName {
  unsigned bit;
  const char* name;
};

// The names of the set bits of `value` within `mask`, joined by `sep`; bits without a name as
// hex (prefix `unknown`); `none` if no bit is set.
template <std::size_t N>
std::string bits_text(unsigned value, unsigned mask, const BitName (&names)[N], const char* sep, const char* unknown,
                      const char* none) {
  std::string s;
  unsigned known = 0;
  for (const auto& [bit, name] : names) {
    known |= bit;
    if (value & bit) s += (s.empty() ? "" : sep) + std::string(name);
  }
  if (value & mask & ~known) {
    char hex[24];
    std::snprintf(hex, sizeof hex, "%s%x", unknown, value & mask & ~known);
    s += (s.empty() ? "" : sep) + std::string(hex);
  }
  return s.empty() ? none : s;
}

}  // namespace

std::string state_bits_text(uint16_t status) {
  static const BitName names[] = {{PROTO_ST_ENABLED, "EN"},           {PROTO_ST_SETPOINT_OK, "SP"},
                                  {PROTO_ST_DEFAULTS, "DEF"},         {PROTO_ST_DUTY_LIMITED, "SAT"},
                                  {PROTO_ST_EEPROM_BUSY, "EE"},       {PROTO_ST_CURRENT_LIMITED, "ILIM"}};
  return bits_text(status, 0x00FFu, names, " ", "0x", "-");
}

std::string fault_bits_text(uint16_t status) {
  static const BitName names[] = {{PROTO_F_CMD_TIMEOUT, "F_CMD_TIMEOUT"},   {PROTO_F_OVERCURRENT, "F_OVERCURRENT"},
                                  {PROTO_F_UNDERVOLTAGE, "F_UNDERVOLTAGE"}, {PROTO_F_SENSOR, "F_SENSOR"},
                                  {PROTO_F_WATCHDOG, "F_WATCHDOG"},         {PROTO_F_STALL, "F_STALL"}};
  return bits_text(status & PROTO_F_MASK, PROTO_F_MASK, names, "+", "F_0x", "none");
}

std::string reset_cause_text(uint8_t rc) {
  static const BitName names[] = {
      {PROTO_RC_POWER_ON, "power-on"},
      {PROTO_RC_EXTERNAL, "external"},
      {PROTO_RC_BROWN_OUT, "brown-out"},
      {PROTO_RC_WATCHDOG, "watchdog"},
      {PROTO_RC_WARM, "warm reset (cause cleared by the bootloader: external or brown-out)"}};
  return bits_text(rc, 0xFFu, names, "+", "0x", "none reported");
}

std::string settings_origin_text(uint8_t flags) {
  if (flags & PROTO_ID_FROM_EEPROM) return "EEPROM";
  if (flags & PROTO_ID_SETTINGS_OLD_LAYOUT) return "build defaults (the EEPROM held an older settings layout)";
  if (flags & PROTO_ID_SETTINGS_CORRUPT) return "build defaults (the EEPROM image was corrupt)";
  return "build defaults (EEPROM empty)";
}

std::string fault_snapshot_text(const proto_fault_t& f) {
  char b[256];
  std::snprintf(b, sizeof b,
                "%s at module time %.3f s: current %.3f A, battery %.3f V, speed %.2f rpm (command %.2f rpm), "
                "duty %.2f %%, status %s, faults %s",
                fault_bits_text(f.faults).c_str(), f.time_ms / 1000.0, f.current_ma / 1000.0, f.voltage_mv / 1000.0,
                rpm_from_crpm(f.omega_crpm), rpm_from_crpm(f.omega_cmd_crpm), f.duty_x10000 / 100.0,
                state_bits_text(f.status).c_str(), fault_bits_text(f.status).c_str());
  return b;
}

void require_protocol(const proto_identity_t& id, const std::string& port, const std::string& program) {
  if (id.protocol_version == PROTO_VERSION) return;
  throw std::runtime_error(
      port + ": the module (firmware " + std::to_string(id.fw_major) + "." + std::to_string(id.fw_minor) + "." +
      std::to_string(id.fw_patch) + ") speaks protocol " + std::to_string(id.protocol_version) + ", " + program +
      " protocol " + std::to_string(PROTO_VERSION) + ": refusing it. Flash the firmware of this version (make flash "
      "PORT=" + port + ") or run the " + program + " that matches the module");
}

}  // namespace auger::io
