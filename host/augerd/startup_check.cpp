// What start-up needs from the system (config.hpp check_startup): run by `augerd --check` and
// before every start, so that a configuration certain to fail is reported once with exit 2,
// which the service does not restart, instead of failing half-way and being restarted for ever.
#include <cerrno>
#include <climits>
#include <cstdlib>
#include <cstring>

#include <grp.h>
#include <linux/magic.h>
#include <sys/stat.h>
#include <sys/statfs.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <fstream>
#include <sstream>

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

std::string dev_text(dev_t d) { return std::to_string(major(d)) + ":" + std::to_string(minor(d)); }

// Whether a character device is a serial port or a pty's slave side, from the kernel's table of
// tty drivers (/proc/tty/drivers: driver, node, major, minors, type): not /dev/tty, a console,
// a pty master, nor any other device (/dev/zero, /dev/null). nullopt: no such table.
std::optional<bool> is_serial_tty(dev_t d) {
  std::ifstream f("/proc/tty/drivers");
  if (!f) return std::nullopt;
  std::string line;
  while (std::getline(f, line)) {
    std::istringstream in(line);
    std::string driver, node, minors, type;
    unsigned maj = 0;
    if (!(in >> driver >> node >> maj >> minors >> type) || maj != major(d)) continue;
    unsigned lo = 0, hi = 0;
    const auto dash = minors.find('-');
    lo = unsigned(std::strtoul(minors.c_str(), nullptr, 10));
    hi = dash == std::string::npos ? lo : unsigned(std::strtoul(minors.c_str() + dash + 1, nullptr, 10));
    if (minor(d) < lo || minor(d) > hi) continue;
    return type.rfind("serial", 0) == 0 || type == "pty:slave";
  }
  return false;
}

// Filesystems that are no storage: a log written there is lost or refused.
const char* pseudo_filesystem(const std::string& dir) {
  struct statfs fs;
  if (::statfs(dir.c_str(), &fs) != 0) return nullptr;
  switch (static_cast<unsigned long>(fs.f_type)) {
    case PROC_SUPER_MAGIC: return "proc";
    case SYSFS_MAGIC: return "sysfs";
    case DEVPTS_SUPER_MAGIC: return "devpts";
    case CGROUP_SUPER_MAGIC: case CGROUP2_SUPER_MAGIC: return "cgroup";
    case DEBUGFS_MAGIC: return "debugfs";
    case TRACEFS_MAGIC: return "tracefs";
    case SECURITYFS_MAGIC: return "securityfs";
    default: return nullptr;
  }
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

  std::vector<std::pair<std::string, dev_t>> devices;  // the ports found, for aliases
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
    // Never opened here: opening a port resets the module on it (DTR).
    if (is_serial_tty(st.st_rdev) == false) {
      final("serial port " + port + " is not a serial port or a pty (character device " + dev_text(st.st_rdev) +
            ", no tty driver's in /proc/tty/drivers)");
      continue;
    }
    for (const auto& [other, dev] : devices)
      if (dev == st.st_rdev)
        final("serial ports " + other + " and " + port + " are the same device (" + dev_text(dev) +
              "): four ports, one per module");
    devices.push_back({port, st.st_rdev});
    if (::access(port.c_str(), R_OK | W_OK) != 0)
      final("serial port " + port + ": no read and write permission (is augerd's user in group dialout?)");
  }

  {
    struct stat st;
    if (::stat(c.log_dir.c_str(), &st) != 0)
      final("log directory " + c.log_dir + " does not exist");
    else if (!S_ISDIR(st.st_mode))
      final("log directory " + c.log_dir + " is not a directory");
    else if (const char* fs = pseudo_filesystem(c.log_dir))
      final("log directory " + c.log_dir + " is on the " + fs + " pseudo filesystem, not storage");
    else if (::access(c.log_dir.c_str(), W_OK | X_OK) != 0)
      final("log directory " + c.log_dir + " is not writable by augerd's user");
    else {
      // The permission bits are not the whole answer (a read-only mount; root passes access()).
      std::string probe = c.log_dir + "/.augerd-check-XXXXXX";
      const int fd = ::mkstemp(probe.data());
      if (fd < 0) {
        final("log directory " + c.log_dir + ": cannot create a file there (" + std::strerror(errno) + ")");
      } else {
        ::close(fd);
        ::unlink(probe.c_str());
      }
    }
  }

  if (c.ros2.enabled) {
    // augerd's DDS Security identity (auger ros2-keys), as the bridge will give it to Cyclone DDS.
    const auto files = auger::ros2::security_files(c.ros2);
    struct stat dir_st;
    if (!files.empty() && ::stat(files[0].path.substr(0, files[0].path.rfind('/')).c_str(), &dir_st) != 0)
      final("[ros2] keystore " + c.ros2.keystore + " has no enclave " + auger::ros2::kEnclave +
            " (make it with `auger ros2-keys create " + c.ros2.keystore + " --config " + c.path + "`)");
    else for (const auto& f : files) {
      struct stat st;
      if (::stat(f.path.c_str(), &st) != 0)
        final("[ros2] keystore: " + f.path + ": " + std::strerror(errno) + " (made by `auger ros2-keys create`)");
      else if (!S_ISREG(st.st_mode))
        final("[ros2] keystore: " + f.path + " is not a regular file");
      else if (::access(f.path.c_str(), R_OK) != 0)
        final("[ros2] keystore: " + f.path + " is not readable by augerd's user");
      else if (f.path.size() >= 8 && f.path.compare(f.path.size() - 8, 8, "/key.pem") == 0 && (st.st_mode & S_IROTH))
        final("[ros2] keystore: " + f.path + " is readable by every user, who could then pose as augerd (chmod o-r)");
    }
    for (const std::string& p : auger::ros2::check_dds_config(c.ros2)) final(p);
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
