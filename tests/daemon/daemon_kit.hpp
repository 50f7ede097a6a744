// What the tests of the real augerd against simulated modules share (test_daemon*.cpp): augerd
// as a child process, its sockets, its logs, and the modules' state as the rig sees it.
#pragma once

#include <array>
#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <sys/types.h>

#include "sim_rig.hpp"

namespace daemon_kit {

// A fresh /tmp/auger-daemon-test-<pid>-<name> with a log/ folder.
std::string make_dir(const std::string& name);

// Removes a test directory at the end of the test case (declared before what uses it).
struct RemoveDir {
  std::string dir;
  ~RemoveDir();
};

std::string slurp(const std::string& path);
void sleep_s(double s);
// augerd's CSV logs in a directory, in name order (a run's files sort by their start).
std::vector<std::string> csv_logs(const std::string& log_dir);
// The text of every event log (`*-events.log`) in a directory.
std::string events_log(const std::string& log_dir);
bool wait_until(const std::function<bool()>& pred, double timeout_s);

// augerd's configuration with these module ports, sockets and log under dir; `extra` goes
// into [serial].
// model: the model file (default the repository's models/robot.toml); control: more [control] keys.
std::string config_text(const std::string& dir, const std::vector<std::string>& ports, const std::string& extra = "",
                        const std::string& model = "", const std::string& control = "");

// augerd as a child process; killed (SIGKILL) when still running at the end.
struct Daemon {
  pid_t pid = -1;
  std::string err_path;
  int status = 0;
  // prefix: a command that runs augerd (e.g. prlimit to limit the log's size).
  Daemon(const std::string& config, const std::string& err, std::vector<std::string> more = {},
         std::vector<std::string> prefix = {});
  // Exit code, or -1 if it still runs after timeout_s.
  int wait_exit(double timeout_s);
  std::string stderr_text() const { return slurp(err_path); }
  ~Daemon();
};

// augerd against four simulated modules wired to ports 0..3 in order, its commands socket up:
// the setup most tests share. `extra` goes into [serial] (config_text), `tail` after the
// configuration (a table of its own), `prefix` runs augerd under a command.
struct Run {
  struct Options {
    std::string extra, tail, control;  // control: more [control] keys
    std::string model;  // the model file's path ("": models/robot.toml)
    std::vector<std::string> prefix;
    std::array<int, 4> telemetry_ms{10, 10, 10, 10};
  };
  std::string dir;
  RemoveDir cleanup;
  SimRig rig;
  std::string cfg, cmd, sens;
  std::unique_ptr<Daemon> d;
  explicit Run(const std::string& name) : Run(name, Options{}) {}
  Run(const std::string& name, const Options& o);
};

int connect_to(const std::string& path);
// Sends lines; reads until `answers` lines came back or (answers < 0) the daemon closed.
std::string talk(const std::string& sock, const std::string& lines, int answers);
// A number of a status line ("key=value"); NaN if absent.
double status_value(const std::string& st, const std::string& key);
std::string now_unix();

// The module reports its motor enabled (driven).
bool enabled(const proto_telemetry_t& tm);
// Every module stopped: not driven and duty zero in its latest telemetry (fresh).
bool all_stopped(SimRig& rig);
// Every module's last report has its motor disabled at duty 0 (however old: a closed port's
// module stops by its own timeout and reports nothing more).
bool motors_off(SimRig& rig);
bool all_driven(SimRig& rig);

// Keeps a velocity command alive (the dead-man) while the test looks elsewhere.
struct VelFeeder {
  std::atomic<bool> run{true};
  std::thread t;
  VelFeeder(const std::string& sock, const std::string& line);
  ~VelFeeder();
};

}  // namespace daemon_kit
