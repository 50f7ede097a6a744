#include "common.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <utility>

#include "protocol.h"

namespace auger::op {

double parse_number(const std::string& option, const std::string& text) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(v))
    throw UsageError(option + ": '" + text + "' is not a finite number");
  return v;
}

std::string option_value(int argc, char** argv, int& i) {
  if (i + 1 >= argc) throw UsageError(std::string(argv[i]) + " needs a value");
  return argv[++i];
}

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

double now_s() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

void sleep_s(double s) {
  if (s <= 0) return;
  timespec ts{time_t(s), long((s - double(time_t(s))) * 1e9)};
  while (nanosleep(&ts, &ts) != 0 && errno == EINTR) {
  }
}

}  // namespace auger::op
