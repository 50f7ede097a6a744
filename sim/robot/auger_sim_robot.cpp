// auger-sim-robot: the demo's simulated robot (docs/robot-sim.md). Four firmware-in-the-loop
// modules on ptys (augerd opens them as it would /dev/ttyUSB*), the true robot on a terrain,
// paced to real time; the simulated camera and IMU are fed to augerd's sensors socket in the
// line protocol of docs/daemon-protocol.md; the true trajectory is written as a robot log.
#include <fcntl.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include "auger/args.hpp"
#include "auger/model_file.hpp"
#include "daemon_lines.hpp"
#include "scheduler.hpp"
#include "simmod.h"

namespace {

volatile sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

const auger::CommandLine kCli{
    "auger-sim-robot",
    "--pty-dir DIR [OPTIONS]",
    "Four simulated modules running the firmware on ptys DIR/module0..3 (reset when a\n"
    "host opens one), the true robot paced to real time, camera and IMU lines sent to\n"
    "augerd's sensors socket (reconnecting until it exists), the true trajectory logged.\n",
    {{"--pty-dir", "DIR", "where the modules' ptys module0..3 are made"},
     {"--terrain", "sand|frozen_grass", "the (log's) terrain (default sand; the field's background)"},
     {"--field", "FILE", "terrain patches in the world frame (e.g. sim/fields/sand-grass.toml)"},
     {"--model", "PATH", "the true robot's model file (default " AUGER_DEFAULT_MODEL ")"},
     {"--elf", "PATH", "the firmware image (default " AUGER_DEFAULT_ELF ")"},
     {"--sensor-socket", "PATH", "augerd's sensors socket (default: none)"},
     {"--log", "PATH", "log the true trajectory there"},
     {"--seconds", "S", "stop after S s of simulated time (default: run until a signal)"},
     {"--seed", "N", "the simulation's random seed (default 1)"},
     {"--blocking-rpm", "X", "screw blocking speed (default 1.5 rpm on sand, 0 = off elsewhere)"}},
    "Runs until SIGINT/SIGTERM or --seconds of simulated time. Exit 2: bad usage.\n"};

void usage() { kCli.print_usage(stderr); }

double unix_now_s() {
  timespec ts;
  clock_gettime(CLOCK_REALTIME, &ts);
  return ts.tv_sec + ts.tv_nsec * 1e-9;
}

// The sensors socket client: connects when the socket exists, drops lines it cannot send
// without blocking (sensor data is perishable), prints what augerd answers (errors only).
class SensorLink {
 public:
  explicit SensorLink(std::string path) : path_(std::move(path)) {}
  ~SensorLink() {
    if (fd_ >= 0) close(fd_);
  }
  void send(const std::string& line, double now_s) {
    if (path_.empty()) return;
    if (fd_ < 0 && now_s >= next_try_s_) try_connect(now_s);
    if (fd_ < 0) return;
    const ssize_t n = ::send(fd_, line.data(), line.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK) {
      std::fprintf(stderr, "auger-sim-robot: sensors socket %s: %s; reconnecting\n", path_.c_str(), std::strerror(errno));
      close(fd_);
      fd_ = -1;
      next_try_s_ = now_s + 0.5;
      return;
    }
    char buf[512];
    const ssize_t r = recv(fd_, buf, sizeof(buf) - 1, MSG_DONTWAIT);
    if (r > 0) {
      buf[r] = 0;
      std::fprintf(stderr, "auger-sim-robot: augerd says: %s", buf);
    } else if (r == 0) {
      close(fd_);
      fd_ = -1;
      next_try_s_ = now_s + 0.5;
    }
  }

 private:
  void try_connect(double now_s) {
    next_try_s_ = now_s + 0.5;
    const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) return;
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::snprintf(a.sun_path, sizeof(a.sun_path), "%s", path_.c_str());
    if (connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)) != 0) {
      close(fd);
      return;
    }
    fd_ = fd;
    std::fprintf(stderr, "auger-sim-robot: connected to the sensors socket %s\n", path_.c_str());
  }
  std::string path_;
  int fd_ = -1;
  double next_try_s_ = 0;
};

}  // namespace

int main(int argc, char** argv) {
  std::string pty_dir, terrain, field_path, model_path = AUGER_DEFAULT_MODEL, elf = AUGER_DEFAULT_ELF;
  std::string socket_path, log_path;
  double seconds = -1, blocking_rpm = -1;
  unsigned long long seed = 1;
  auger::Args args;
  if (const int rc = kCli.parse_or_answer(argc, argv, args); rc >= 0) return rc;
  if (!args.positional.empty()) {
    std::fprintf(stderr, "auger-sim-robot: unknown argument '%s'\n", args.positional[0].c_str());
    usage();
    return 2;
  }
  for (const auto& [a, value] : args.options) {  // in order: the last of a repeated option wins
    if (a == "--pty-dir") pty_dir = value;
    else if (a == "--terrain") terrain = value;
    else if (a == "--field") field_path = value;
    else if (a == "--model") model_path = value;
    else if (a == "--elf") elf = value;
    else if (a == "--sensor-socket") socket_path = value;
    else if (a == "--log") log_path = value;
    else if (a == "--seconds") seconds = std::atof(value.c_str());
    else if (a == "--seed") seed = std::strtoull(value.c_str(), nullptr, 10);
    else if (a == "--blocking-rpm") blocking_rpm = std::atof(value.c_str());
  }
  if (pty_dir.empty()) {
    usage();
    return 2;
  }
  try {
    const auger::ModelFile file = auger::load_model_file(model_path);
    std::shared_ptr<const auger::sim::Field> field;
    if (!field_path.empty()) field = auger::sim::load_field_for_run(field_path, file, blocking_rpm, terrain);
    if (terrain.empty()) terrain = "sand";
    const auger::Model model = auger::build_model(file, terrain);
    auger::sim::TruthParams truth;
    if (blocking_rpm < 0) blocking_rpm = terrain == "sand" ? 1.5 : 0.0;
    truth.blocking.on = blocking_rpm > 0;
    truth.blocking.omega_block_rpm = blocking_rpm;
    truth.field = field;  // the truth log (--log) then also records the ground under the robot
    auger::sim::SchedulerConfig sc;
    sc.mode = auger::sim::ScrewMode::fil;
    sc.elf_path = elf;
    sc.realtime = true;
    sc.pty_dir = pty_dir;
    sc.reset_on_open = true;
    sc.seed = seed;
    sc.terrain = terrain;
    sc.log_truth = true;
    sc.threads = 1;
    auger::sim::Scheduler sched(model, truth, sc);
    sched.set_keep_history(false);
    const double t0_unix_s = unix_now_s();  // simulated t = 0 (simmod paces from creation)
    for (int i = 0; i < 4; ++i)
      std::printf("%d %s %s\n", i, simmod_pty_link(sched.modules(), i), simmod_pty_path(sched.modules(), i));
    std::fflush(stdout);
    // The truth log's clock against augerd's (its log's t0_unix_s): scripts/demo.sh pairs them.
    std::fprintf(stderr, "auger-sim-robot: simulated t = 0 s at unix time %.6f s\n", t0_unix_s);

    std::ofstream log;
    if (!log_path.empty()) {
      log.open(log_path);
      if (!log) throw std::runtime_error("cannot write " + log_path);
      sched.set_log(&log);
    }
    SensorLink link(socket_path);
    sched.set_sensor_sink([&](double t_s, const auger::sim::ImuReading* imu, const auger::sim::PoseReading* pose) {
      const double now = t0_unix_s + t_s;
      // The lines as daemon_lines.hpp writes them; the IMU's with the accelerometer's fields.
      using auger::daemon::SensorKind;
      using auger::daemon::SensorMessage;
      if (pose) {
        SensorMessage m;
        m.kind = SensorKind::pose;
        m.t_unix_s = t0_unix_s + pose->t_capture_s;
        m.x_m = pose->pose[0], m.y_m = pose->pose[1], m.psi_rad = pose->pose[2];
        m.sx_m = pose->std_dev[0], m.sy_m = pose->std_dev[1], m.spsi_rad = pose->std_dev[2];
        link.send(auger::daemon::sensor_line(m) + "\n", now);
      }
      if (imu) {
        SensorMessage m;
        m.kind = SensorKind::imu;
        m.t_unix_s = t0_unix_s + imu->t_s;
        m.imu_psi_rad = imu->psi_rad;
        m.imu_r_radps = imu->r_radps;
        m.has_acc = true;
        m.ax_mps2 = imu->ax_mps2;
        m.ay_mps2 = imu->ay_mps2;
        link.send(auger::daemon::sensor_line(m) + "\n", now);
      }
    });

    struct sigaction sa{};
    sa.sa_handler = on_signal;
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
    signal(SIGPIPE, SIG_IGN);
    int flush_count = 0;
    while (!g_stop && (seconds < 0 || sched.t_s() < seconds - 1e-9)) {
      sched.tick();
      if (log.is_open() && ++flush_count % 100 == 0) log.flush();  // lose at most 1 s on a crash
    }
    if (log.is_open()) log.flush();
    std::fprintf(stderr, "auger-sim-robot: stopped at t = %.2f s, pose %.3f %.3f %.3f\n", sched.t_s(),
                 sched.robot().state().eta[0], sched.robot().state().eta[1], sched.robot().state().eta[2]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger-sim-robot: %s\n", e.what());
    return 1;
  }
  return 0;
}
