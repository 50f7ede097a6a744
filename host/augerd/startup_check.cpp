// What start-up needs from the system (config.hpp check_startup): run by `augerd --check` and
// before every start, so that a configuration certain to fail is reported once with exit 2,
// which the service does not restart, instead of failing half-way and being restarted for ever.
#include <cerrno>
#include <climits>
#include <cstdlib>
#include <cstring>

#include <grp.h>
#include <sys/stat.h>
#include <unistd.h>

#include "config.hpp"

namespace augerd {
namespace {

std::string parent_of(const std::string& p) {
  const auto slash = p.rfind('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : p.substr(0, slash);
}

// The path with its directory resolved (symbolic links, "..", "."), for telling whether two
// socket paths name the same file.
std::string canonical_in_dir(const std::string& p) {
  char buf[PATH_MAX];
  const std::string dir = parent_of(p);
  if (!::realpath(dir.c_str(), buf)) return p;
  return std::string(buf) + "/" + p.substr(p.rfind('/') == std::string::npos ? 0 : p.rfind('/') + 1);
}

bool in_group(long gid) {
  if (gid < 0 || ::geteuid() == 0 || gid_t(gid) == ::getegid()) return true;
  gid_t groups[NGROUPS_MAX];
  const int n = ::getgroups(NGROUPS_MAX, groups);
  for (int i = 0; i < n; ++i)
    if (groups[i] == gid_t(gid)) return true;
  return false;
}

}  // namespace

std::optional<long> socket_gid(const std::string& name) {
  if (name.empty()) return -1;
  const struct group* g = ::getgrnam(name.c_str());
  if (!g) return std::nullopt;
  return static_cast<long>(g->gr_gid);
}

std::vector<StartupProblem> check_startup(const DaemonConfig& c) {
  std::vector<StartupProblem> out;
  auto final = [&](const std::string& t) { out.push_back({true, t}); };

  for (const auto& port : c.ports) {
    struct stat st;
    if (::stat(port.c_str(), &st) != 0) {
      if (errno == ENOENT)
        out.push_back({false, "serial port " + port + " does not exist (module unplugged? the udev rule?)"});
      else
        final("serial port " + port + ": " + std::strerror(errno));
      continue;
    }
    if (!S_ISCHR(st.st_mode)) {
      final("serial port " + port + " is not a character device (a serial port or a pty)");
      continue;
    }
    if (::access(port.c_str(), R_OK | W_OK) != 0)
      final("serial port " + port + ": no read and write permission (is augerd's user in group dialout?)");
  }

  {
    struct stat st;
    if (::stat(c.log_dir.c_str(), &st) != 0)
      final("log directory " + c.log_dir + " does not exist");
    else if (!S_ISDIR(st.st_mode))
      final("log directory " + c.log_dir + " is not a directory");
    else if (::access(c.log_dir.c_str(), W_OK | X_OK) != 0)
      final("log directory " + c.log_dir + " is not writable by augerd's user");
  }

  struct Sock {
    const char* key;
    const std::string& path;
    const std::string& group;
    int group_line;
  };
  for (const Sock& s : {Sock{"commands", c.commands_socket, c.commands_group, c.line_commands_group},
                        Sock{"sensors", c.sensors_socket, c.sensors_group, c.line_sensors_group}}) {
    const std::string dir = parent_of(s.path);
    struct stat st;
    if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
      final(std::string(s.key) + " socket " + s.path + ": directory " + dir + " does not exist");
    else if (::access(dir.c_str(), W_OK | X_OK) != 0)
      final(std::string(s.key) + " socket " + s.path + ": directory " + dir + " is not writable by augerd's user");
    if (::lstat(s.path.c_str(), &st) == 0 && !S_ISSOCK(st.st_mode))
      final(std::string(s.key) + " socket " + s.path + " exists and is not a socket (augerd would not replace it)");
    const std::optional<long> gid = socket_gid(s.group);
    if (!gid)
      final(c.path + ":" + std::to_string(s.group_line) + ": " + s.key + "_group: no group named '" + s.group +
            "' on this system (packaging/auger.sysusers creates auger-sensors)");
    else if (!in_group(*gid))
      final(std::string(s.key) + " socket: augerd's user is not in group '" + s.group +
            "', so it cannot give the socket that group (SupplementaryGroups= in the service)");
  }
  if (canonical_in_dir(c.commands_socket) == canonical_in_dir(c.sensors_socket))
    final("the commands and sensors sockets are the same file (" + c.commands_socket + ", " + c.sensors_socket + ")");
  return out;
}

}  // namespace augerd
