// A POSIX clock in seconds (augerd's loop runs on CLOCK_MONOTONIC; sensor stamps are
// CLOCK_REALTIME).
#pragma once

#include <ctime>

namespace augerd {

inline double clock_s(clockid_t id) {
  timespec ts;
  clock_gettime(id, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

}  // namespace augerd
