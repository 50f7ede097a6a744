// Lock-step runs with the firmware in the loop: four simulated modules running the real
// firmware image, driven over the protocol by the host controller at 100 Hz of simulated time,
// the true robot on the terrain, the simulated camera and IMU (issue 4, "Tests").
#include <catch2/catch.hpp>

#include <chrono>
#include <cstdio>
#include <fstream>

#include "protocol.h"
#include "robot_fixtures.hpp"
#include "simmod.h"

using namespace auger;
using namespace auger::sim;
using namespace robot_test;

namespace {
double wall_s(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

TEST_CASE("FIL, frozen grass: a 0.5 m square tracked with RMS <= 0.05 m and <= 0.05 rad", "[fil]") {
  const auto t0 = std::chrono::steady_clock::now();
  const Model m = nominal("frozen_grass");
  ControllerConfig cc = controller_config(model_file(), "frozen_grass");
  Controller c(m, cc);
  SchedulerConfig sc;
  sc.mode = ScrewMode::fil;
  sc.elf_path = AUGER_FIRMWARE_ELF_PATH;
  sc.terrain = "frozen_grass";
  Scheduler s(m, TruthParams{}, sc);
  std::ofstream log("robot_fil_square.csv");
  s.set_log(&log);
  s.set_controller(&c);
  s.run_until(0.1);  // modules boot
  const double side_s = 20.0;
  c.set_waypoints({{0.0, Vec3(0.5, 0, 0)},
                   {side_s, Vec3(0.5, 0.5, 0)},
                   {2 * side_s, Vec3(0, 0.5, 0)},
                   {3 * side_s, Vec3(0, 0, 0)}});
  c.set_enabled(true);
  s.run_until(0.1 + 4 * side_s + 10.0);
  const Rms rms = tracking_rms(s.history(), 0.0);
  double reach_x = 0, reach_y = 0;
  for (const auto& h : s.history()) reach_x = std::max(reach_x, h.eta_true[0]), reach_y = std::max(reach_y, h.eta_true[1]);
  const double sim_s = s.t_s();
  std::printf("FIL square (frozen grass): RMS %.4f m, %.4f rad; reached x %.3f y %.3f; %.0f s simulated in %.1f s\n",
              rms.pos_m, rms.psi_rad, reach_x, reach_y, sim_s, wall_s(t0));
  for (int i = 0; i < 4; ++i) CHECK(simmod_state(s.modules(), i) == 0);
  log.close();
  std::ifstream written("robot_fil_square.csv");
  std::stringstream text;
  text << written.rdbuf();
  CHECK((status_or(text.str()) & (PROTO_F_MASK | PROTO_ST_CURRENT_LIMITED)) == 0);  // no trip, no limit
  CHECK(reach_x > 0.4);
  CHECK(reach_y > 0.4);
  CHECK(rms.pos_m <= 0.05);
  CHECK(rms.psi_rad <= 0.05);
}

TEST_CASE("FIL, sand: the helix diagonal, null space arrives, pseudo-inverse stalls (1.5 rpm)", "[fil]") {
  const auto t0 = std::chrono::steady_clock::now();
  const DiagonalRun pinv = run_diagonal(ScrewMode::fil, AllocatorKind::pseudo_inverse, 1.5, 40.0);
  const DiagonalRun ns = run_diagonal(ScrewMode::fil, AllocatorKind::null_space, 1.5, 40.0);
  std::printf("FIL diagonal (sand, omega_block 1.5 rpm): pinv miss %.3f m progress %.3f m; null-space miss %.3f m; %.1f s\n",
              pinv.miss_m, pinv.progress_m, ns.miss_m, wall_s(t0));
  CHECK(pinv.miss_m > 0.1);
  CHECK(ns.miss_m < 0.05);
  // No module latched a fault on the way (issue 16: the stall detection and the current
  // foldback must not act on sand with screws held near zero or blocked). The foldback may touch
  // the peaks of the sand's current transients (4.5 A start; peaks of 4.5-5.9 A occur in 17 to 23
  // of 60 simulator seeds, old image and new), never for long: under 1 % of the samples.
  CHECK((pinv.module_status_or & PROTO_F_MASK) == 0);
  CHECK((ns.module_status_or & PROTO_F_MASK) == 0);
  INFO("current foldback active in " << 100 * pinv.current_limited_frac << " % (pinv), "
                                     << 100 * ns.current_limited_frac << " % (null space) of the samples");
  CHECK(pinv.current_limited_frac < 0.01);
  CHECK(ns.current_limited_frac < 0.01);
}

TEST_CASE("FIL, sand: the diagonal across the blocking threshold sweep", "[fil][.full]") {
  for (double block : {0.5, 1.0, 2.0, 3.0}) {
    const DiagonalRun pinv = run_diagonal(ScrewMode::fil, AllocatorKind::pseudo_inverse, block, 40.0);
    const DiagonalRun ns = run_diagonal(ScrewMode::fil, AllocatorKind::null_space, block, 40.0);
    std::printf("FIL diagonal omega_block %.1f rpm: pinv miss %.3f m; null-space miss %.3f m\n", block, pinv.miss_m,
                ns.miss_m);
    CHECK(ns.miss_m < 0.05);
    if (block >= 1.0) CHECK(pinv.miss_m > 0.1);
    CHECK(((pinv.module_status_or | ns.module_status_or) & PROTO_F_MASK) == 0);
  }
}

// ---- auger-sim-robot (the demo program), real time, short ----
#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <sstream>

#include "auger/log.hpp"
#include "protocol.h"

TEST_CASE("auger-sim-robot: ptys, a module driven through its pty, sensor lines, truth log", "[fil][cli]") {
  char dir_tmpl[] = "/tmp/auger-sim-robot-XXXXXX";
  REQUIRE(mkdtemp(dir_tmpl) != nullptr);
  const std::string dir = dir_tmpl;
  const std::string sock_path = dir + "/sensors.sock", log_path = dir + "/truth.csv";
  // The sensors socket, as augerd would offer it.
  const int srv = socket(AF_UNIX, SOCK_STREAM, 0);
  REQUIRE(srv >= 0);
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::snprintf(a.sun_path, sizeof(a.sun_path), "%s", sock_path.c_str());
  REQUIRE(bind(srv, reinterpret_cast<sockaddr*>(&a), sizeof(a)) == 0);
  REQUIRE(listen(srv, 1) == 0);

  int out_pipe[2];
  REQUIRE(pipe(out_pipe) == 0);
  const pid_t pid = fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    dup2(out_pipe[1], 1);
    close(out_pipe[0]);
    const int devnull = open("/dev/null", O_WRONLY);
    dup2(devnull, 2);  // simavr's progress lines
    execl(AUGER_SIM_ROBOT_EXE, AUGER_SIM_ROBOT_EXE, "--pty-dir", dir.c_str(), "--terrain", "frozen_grass",
          "--seconds", "3", "--log", log_path.c_str(), "--sensor-socket", sock_path.c_str(), (char*)nullptr);
    _exit(127);
  }
  close(out_pipe[1]);
  // Four lines "index symlink pty".
  std::string printed;
  char buf[512];
  while (std::count(printed.begin(), printed.end(), '\n') < 4) {
    pollfd p{out_pipe[0], POLLIN, 0};
    REQUIRE(poll(&p, 1, 5000) == 1);
    const ssize_t n = read(out_pipe[0], buf, sizeof(buf));
    REQUIRE(n > 0);
    printed.append(buf, static_cast<std::size_t>(n));
  }
  CHECK(printed.find(dir + "/module0") != std::string::npos);
  CHECK(printed.find("3 " + dir + "/module3 /dev/pts/") != std::string::npos);

  // Drive module 0 through its pty as augerd would: 10 rpm, every 10 ms, for 2 s.
  const int tty = open((dir + "/module0").c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  REQUIRE(tty >= 0);
  termios tio;
  tcgetattr(tty, &tio);
  cfmakeraw(&tio);
  tcsetattr(tty, TCSANOW, &tio);
  int client = -1;
  std::string lines;
  std::uint16_t seq = 0;
  for (int k = 0; k < 200; ++k) {
    proto_setpoint_t sp{};
    sp.seq = ++seq;
    sp.omega_crpm = 1000;
    sp.flags = PROTO_SP_ENABLE | (k == 0 ? PROTO_SP_CLEAR_FAULTS : 0);
    std::uint8_t frame[PROTO_MAX_FRAME];
    const std::size_t n = proto_encode_setpoint(&sp, frame);
    CHECK(write(tty, frame, n) == static_cast<ssize_t>(n));
    while (read(tty, buf, sizeof(buf)) > 0) {
    }
    if (client < 0) {
      pollfd p{srv, POLLIN, 0};
      if (poll(&p, 1, 0) == 1) client = accept(srv, nullptr, nullptr);
    }
    if (client >= 0) {
      ssize_t r;
      while ((r = recv(client, buf, sizeof(buf), MSG_DONTWAIT)) > 0) lines.append(buf, static_cast<std::size_t>(r));
    }
    usleep(10000);
  }
  int status = 0;
  REQUIRE(waitpid(pid, &status, 0) == pid);
  CHECK(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 0);
  if (client >= 0) {
    ssize_t r;
    while ((r = recv(client, buf, sizeof(buf), MSG_DONTWAIT)) > 0) lines.append(buf, static_cast<std::size_t>(r));
    close(client);
  }
  close(tty);
  close(srv);
  close(out_pipe[0]);

  // Sensor lines in the protocol of docs/daemon-protocol.md.
  std::istringstream ls(lines);
  std::string line;
  int imu = 0, pose = 0;
  while (std::getline(ls, line)) {
    std::istringstream f(line);
    std::string kind;
    double t = 0, v[6];
    f >> kind >> t;
    if (kind == "imu" && (f >> v[0] >> v[1])) ++imu;
    if (kind == "pose" && (f >> v[0] >> v[1] >> v[2] >> v[3] >> v[4] >> v[5])) ++pose;
    CHECK(t > 1.6e9);  // wall-clock (unix) seconds
  }
  std::printf("auger-sim-robot: %d imu and %d pose lines\n", imu, pose);
  CHECK(imu > 100);
  CHECK(pose > 10);

  // The truth log: module 0 turned at the 10 rpm sent through its pty, the robot moved.
  auger::RobotLogReader reader(log_path);
  auger::RobotSample s, last;
  int rows = 0, at_speed = 0;
  double max_other_rpm = 0;
  while (reader.next(s)) {
    ++rows, last = s;
    if (std::fabs(s.omega_rpm[0] - 10.0) < 1.0) ++at_speed;
    max_other_rpm = std::max(max_other_rpm, std::fabs(s.omega_rpm[1]));
  }
  std::printf("auger-sim-robot: module 0 within 1 rpm of 10 rpm for %d of %d samples\n", at_speed, rows);
  CHECK(rows == 300);
  CHECK(at_speed > 100);  // sent for about 2 s; the module stops 250 ms after the last setpoint
  CHECK(max_other_rpm < 0.1);
  CHECK(std::hypot(last.x_m, last.y_m) > 1e-3);
  std::remove(log_path.c_str());
  std::remove(sock_path.c_str());
  for (int i = 0; i < 4; ++i) std::remove((dir + "/module" + std::to_string(i)).c_str());
  rmdir(dir.c_str());
}
