// augerd's configuration (read by auger_contract: host/contract/daemon_config.hpp) and what start-up needs from
// the system (startup_check.cpp).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "daemon_config.hpp"
#include "ros2.hpp"

namespace augerd {

using auger::DaemonConfig;

// The file as this augerd reads it (the [ros2] section needs the bridge this build has).
inline DaemonConfig load_daemon_config(const std::string& path) {
  return auger::read_daemon_config(path, auger::ros2::available());
}

// What start-up will need from the system, checked before anything is opened (`augerd --check`
// and every start): the ports exist and are character devices we may read and write, the log
// directory exists and is writable, the socket paths are usable and distinct, the sockets'
// groups can be given. Each problem is one line naming the path.
struct StartupProblem {
  bool final;  // a configuration error (exit 2: the service is not restarted); else it may pass later
  std::string text;
};
std::vector<StartupProblem> check_startup(const DaemonConfig& config);

// A socket's group id: -1 for none given (augerd's own), nullopt for a name this system lacks.
std::optional<long> socket_gid(const std::string& group_name);

}  // namespace augerd
