// augerd's /diagnostics entries and its online estimate topic's data (docs/ros2.md), built from
// a Snapshot without any DDS type: the bridge turns them into diagnostic_msgs and std_msgs
// samples on its own thread; the unit tests read them as they are.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "ros2.hpp"

namespace auger::ros2 {

// One diagnostic_msgs/DiagnosticStatus; level OK = 0, WARN = 1, ERROR = 2, STALE = 3.
struct DiagnosticEntry {
  std::string name, message, hardware_id;
  std::vector<std::pair<std::string, std::string>> kv;
  uint8_t level = 0;
};

// One per module, one for the controller and, with [online], one for the online estimator
// (WARN while its fallback is latched). cycles_skipped: the bridge's count of cycles not handed over.
std::vector<DiagnosticEntry> diagnostics(const Snapshot& s, long cycles_skipped);

// The online estimate topic (std_msgs/Float64MultiArray): 5 parameters x (value, SD), row-major,
// dims {"parameter", 5, 10} and {"value_sd", 2, 2}; the parameters in OnlineSnapshot's order.
constexpr int kOnlineParams = 5, kOnlineColumns = 2;
void online_estimate_data(const OnlineSnapshot& o, double data[kOnlineParams * kOnlineColumns]);

}  // namespace auger::ros2
