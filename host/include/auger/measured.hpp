// "Not measured" marker shared by logs, sensors and estimators: a quiet NaN.
#pragma once

#include <limits>

namespace auger {

constexpr double kNotMeasured = std::numeric_limits<double>::quiet_NaN();
inline bool measured(double value) { return value == value; }  // NaN marks "not measured"

}  // namespace auger
