// daemon_kit.hpp's helpers.
#include "daemon_kit.hpp"

#include <catch2/catch.hpp>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

extern char** environ;

namespace daemon_kit {

std::string make_dir(const std::string& name) {
  std::string d = "/tmp/auger-daemon-test-" + std::to_string(getpid()) + "-" + name;
  std::string cmd = "rm -rf '" + d + "' && mkdir -p '" + d + "/log'";
  REQUIRE(std::system(cmd.c_str()) == 0);
  return d;
}

RemoveDir::~RemoveDir() {
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
}

std::string slurp(const std::string& path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

void sleep_s(double s) { std::this_thread::sleep_for(std::chrono::duration<double>(s)); }

std::vector<std::string> csv_logs(const std::string& log_dir) {
  std::vector<std::string> v;
  for (const auto& e : std::filesystem::directory_iterator(log_dir))
    if (e.path().extension() == ".csv") v.push_back(e.path().string());
  std::sort(v.begin(), v.end());
  return v;
}

std::string events_log(const std::string& log_dir) {
  std::vector<std::string> v;
  for (const auto& e : std::filesystem::directory_iterator(log_dir)) {
    const std::string name = e.path().filename().string();
    if (name.size() > 11 && name.compare(name.size() - 11, 11, "-events.log") == 0) v.push_back(e.path().string());
  }
  std::sort(v.begin(), v.end());
  std::string text;
  for (const auto& f : v) text += slurp(f);
  return text;
}

bool wait_until(const std::function<bool()>& pred, double timeout_s) {
  const double end = SimRig::wall_s() + timeout_s;
  while (SimRig::wall_s() < end) {
    if (pred()) return true;
    sleep_s(0.005);
  }
  return pred();
}

std::string config_text(const std::string& dir, const std::vector<std::string>& ports, const std::string& extra,
                        const std::string& model, const std::string& control) {
  std::string p;
  for (const auto& s : ports) p += (p.empty() ? "\"" : ", \"") + s + "\"";
  return "schema = 1\n[serial]\nports = [" + p + "]\nbaud = 250000\n" + extra + "[model]\nfile = \"" +
         (model.empty() ? std::string(AUGER_SOURCE_DIR "/models/robot.toml") : model) + "\"\nterrain = \"sand\"\n[control]\nallocator = \"nullspace\"\n" +
         control + "[sockets]\ncommands = \"" + dir + "/cmd.sock\"\nsensors = \"" + dir + "/sensors.sock\"\n"
         "[log]\ndir = \"" + dir + "/log\"\nrotate_bytes = 10000000\n";
}

Daemon::Daemon(const std::string& config, const std::string& err, std::vector<std::string> more,
               std::vector<std::string> prefix)
    : err_path(err) {
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
  std::vector<std::string> args = prefix;
  for (const char* a : {AUGERD_PATH, "--config"}) args.push_back(a);
  args.push_back(config);
  for (auto& m : more) args.push_back(m);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  REQUIRE(posix_spawnp(&pid, args[0].c_str(), &fa, nullptr, argv.data(), environ) == 0);
  posix_spawn_file_actions_destroy(&fa);
}

int Daemon::wait_exit(double timeout_s) {
  const double end = SimRig::wall_s() + timeout_s;
  while (SimRig::wall_s() < end) {
    if (waitpid(pid, &status, WNOHANG) == pid) {
      pid = -1;
      return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    }
    sleep_s(0.01);
  }
  return -1;
}

Daemon::~Daemon() {
  if (pid > 0) {
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
  }
}

Run::Run(const std::string& name, const Options& o)
    : dir(make_dir(name)), cleanup{dir}, rig(dir, {0, 1, 2, 3}, {0, 1, 2, 3}, o.telemetry_ms), cfg(dir + "/augerd.toml"),
      cmd(dir + "/cmd.sock"), sens(dir + "/sensors.sock") {
  std::ofstream(cfg) << config_text(dir, {rig.port(0), rig.port(1), rig.port(2), rig.port(3)}, o.extra, o.model, o.control) + o.tail;
  d = std::make_unique<Daemon>(cfg, dir + "/augerd.err", std::vector<std::string>{}, o.prefix);
  const bool up = wait_until([&] { return access(cmd.c_str(), F_OK) == 0; }, 5.0);
  INFO(d->stderr_text());
  REQUIRE(up);
}

int connect_to(const std::string& path) {
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::strncpy(a.sun_path, path.c_str(), sizeof a.sun_path - 1);
  int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

std::string talk(const std::string& sock, const std::string& lines, int answers) {
  int fd = connect_to(sock);
  if (fd < 0) return "<no connection>";
  send(fd, lines.data(), lines.size(), MSG_NOSIGNAL);
  if (answers < 0) shutdown(fd, SHUT_WR);
  std::string got;
  char buf[1024];
  const double end = SimRig::wall_s() + 3.0;
  while (SimRig::wall_s() < end) {
    if (answers >= 0 && std::count(got.begin(), got.end(), '\n') >= answers) break;
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 50) <= 0) continue;
    ssize_t n = recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    got.append(buf, size_t(n));
  }
  close(fd);
  if (!got.empty() && got.back() == '\n') got.pop_back();
  return got;
}

double status_value(const std::string& st, const std::string& key) {
  const auto k = st.find(" " + key + "=");
  return k == std::string::npos ? NAN : std::atof(st.c_str() + k + key.size() + 2);
}

std::string now_unix() {
  timespec ts;
  clock_gettime(CLOCK_REALTIME, &ts);
  char b[64];
  std::snprintf(b, sizeof b, "%.6f", double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec));
  return b;
}

bool enabled(const proto_telemetry_t& tm) { return tm.status & PROTO_ST_ENABLED; }

bool all_stopped(SimRig& rig) {
  for (int m = 0; m < 4; ++m) {
    auto v = rig.module(m);
    if (SimRig::wall_s() - v.tm_wall_s > 0.05) return false;
    if (enabled(v.tm) || v.tm.duty_x10000 != 0 || v.tm.omega_cmd_crpm != 0) return false;
  }
  return true;
}
bool motors_off(SimRig& rig) {
  for (int m = 0; m < 4; ++m) {
    auto v = rig.module(m);
    if (enabled(v.tm) || v.tm.duty_x10000 != 0) return false;
  }
  return true;
}

bool all_driven(SimRig& rig) {
  for (int m = 0; m < 4; ++m) {
    auto v = rig.module(m);
    if (!enabled(v.tm) || std::abs(v.tm.omega_cmd_crpm) < 50) return false;
  }
  return true;
}

VelFeeder::VelFeeder(const std::string& sock, const std::string& line) {
  t = std::thread([this, sock, line] {
    while (run) {
      talk(sock, line + "\n", 1);
      sleep_s(0.1);
    }
  });
}

VelFeeder::~VelFeeder() {
  run = false;
  t.join();
}

}  // namespace daemon_kit
