#include "status_text.hpp"

#include <utility>

#include "protocol.h"

namespace auger::io {

std::string state_bits_text(uint16_t status) {
  static const std::pair<uint16_t, const char*> names[] = {{PROTO_ST_ENABLED, "EN"},
                                                           {PROTO_ST_SETPOINT_OK, "SP"},
                                                           {PROTO_ST_DEFAULTS, "DEF"},
                                                           {PROTO_ST_DUTY_LIMITED, "SAT"},
                                                           {PROTO_ST_EEPROM_BUSY, "EE"}};
  std::string s;
  for (const auto& [bit, name] : names)
    if (status & bit) s += (s.empty() ? "" : " ") + std::string(name);
  return s.empty() ? "-" : s;
}

std::string fault_bits_text(uint16_t status) {
  static const std::pair<uint16_t, const char*> names[] = {{PROTO_F_CMD_TIMEOUT, "F_CMD_TIMEOUT"},
                                                           {PROTO_F_OVERCURRENT, "F_OVERCURRENT"},
                                                           {PROTO_F_UNDERVOLTAGE, "F_UNDERVOLTAGE"},
                                                           {PROTO_F_SENSOR, "F_SENSOR"},
                                                           {PROTO_F_WATCHDOG, "F_WATCHDOG"}};
  std::string s;
  for (const auto& [bit, name] : names)
    if (status & bit) s += (s.empty() ? "" : "+") + std::string(name);
  if (s.empty() && (status & PROTO_F_MASK)) s = "F_0x" + std::to_string(status >> 8);
  return s.empty() ? "none" : s;
}

}  // namespace auger::io
