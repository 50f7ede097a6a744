// The bridge in a build without Cyclone DDS (AUGER_WITH_ROS2=OFF, e.g. `make board` by
// default): augerd runs as before and refuses a configuration that enables [ros2].
#include <stdexcept>

#include "ros2.hpp"

namespace auger::ros2 {

bool available() { return false; }

// [ros2] enabled is refused when the configuration is read: nothing to check here.
std::vector<std::string> check_dds_config(const Settings&) { return {}; }

std::unique_ptr<Bridge> make_bridge(const Settings&) {
  throw std::runtime_error(
      "this augerd was built without the ROS 2 interface (Cyclone DDS); build it with "
      "-DAUGER_WITH_ROS2=ON (for the board: make board ROS2=1), or set [ros2] enabled = false");
}

}  // namespace auger::ros2
