#include "common.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <utility>

#include "auger/args.hpp"
#include "protocol.h"
#include "serial_port.hpp"

namespace auger::op {

double parse_number(const std::string& option, const std::string& text) {
  double v = 0;
  if (!decimal_number(text, v)) throw UsageError(option + ": '" + text + "' is not a finite number");
  return v;
}


double now_s() { return io::monotonic_s(); }

void sleep_s(double s) {
  if (s <= 0) return;
  timespec ts{time_t(s), long((s - double(time_t(s))) * 1e9)};
  while (nanosleep(&ts, &ts) != 0 && errno == EINTR) {
  }
}

}  // namespace auger::op
