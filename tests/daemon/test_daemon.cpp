// The real augerd in real time over ptys against four simulated modules running the real
// firmware (issue 4, "Real time, short"): identification in any port order, the dead-man, a
// module that stops answering / sends only corrupt frames / loses its port stops every screw
// and is named, a module that returns stays stopped until `enable`, kill -9 stops every motor
// through the modules' own timeout, and malformed commands, sensor lines and configuration
// files get clear errors. test_daemon_runs.cpp: [online], a full disk, a module's trip;
// test_daemon_load.cpp: the sockets under load.
#include <catch2/catch.hpp>

#include <fcntl.h>
#include <grp.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "auger/log.hpp"
#include "auger/model_file.hpp"
#include "daemon_kit.hpp"
#include "daemon_log.hpp"
#include "ptys.hpp"

using namespace daemon_kit;

TEST_CASE("augerd runs four simulated modules in real time and stops safely", "[daemon]") {
  const std::string dir = make_dir("run");
  RemoveDir cleanup{dir};
  // Module m has id m; rig port k is wired to module perm[k]; the configuration lists the
  // ports in yet another order: augerd must map them by id.
  SimRig rig(dir, {0, 1, 2, 3}, {2, 0, 3, 1});
  const std::string cfg = dir + "/augerd.toml";
  // The sensors socket given this process's group explicitly (on the robot: the sensor
  // producers' group), the commands socket augerd's own.
  const struct group* own = getgrgid(getegid());
  REQUIRE(own);
  std::string text = config_text(dir, {rig.port(3), rig.port(1), rig.port(0), rig.port(2)});
  text.replace(text.find("[log]"), 5, "sensors_group = \"" + std::string(own->gr_name) + "\"\n[log]");
  std::ofstream(cfg) << text;
  // Started with the most permissive umask: the sockets' modes must not come from it.
  const mode_t old_umask = umask(0);
  Daemon d(cfg, dir + "/augerd.err");
  umask(old_umask);
  const std::string cmd = dir + "/cmd.sock", sens = dir + "/sensors.sock";
  REQUIRE(wait_until([&] { return access(cmd.c_str(), F_OK) == 0 && access(sens.c_str(), F_OK) == 0; }, 5.0));
  INFO(d.stderr_text());
  for (const std::string& path : {cmd, sens}) {
    struct stat st {};
    REQUIRE(stat(path.c_str(), &st) == 0);
    INFO(path);
    CHECK((st.st_mode & 07777) == 0660);
    CHECK(st.st_gid == getegid());
  }
  const std::string st0 = talk(cmd, "status\n", 1);
  CHECK(st0.rfind("status t_s=", 0) == 0);
  CHECK(st0.find("enabled=0") != std::string::npos);
  CHECK(st0.find("fault=none") != std::string::npos);

  SECTION("every camera pose of a burst reaches the estimator, one per cycle, in arrival order") {
    // Three frames in one write (a burst after a stall): before, only the last reached the
    // estimator and the log. Each one's row holds it with its own capture time.
    const double t_unix = std::stod(now_unix());
    std::string burst;
    for (int k = 1; k <= 3; ++k) {
      char line[160];
      std::snprintf(line, sizeof line, "pose %.6f %.4f 0 0 0.01 0.01 0.01\n", t_unix - 0.03 * (4 - k), 0.0011 * k);
      burst += line;
    }
    REQUIRE(talk(sens, burst, -1) == "");
    sleep_s(0.2);
    // Twenty at once, faster than the loop takes them: the queue's 8 places overflow, the oldest
    // are dropped and counted; every other one reaches the log.
    std::string flood;
    for (int k = 1; k <= 20; ++k) {
      char line[160];
      std::snprintf(line, sizeof line, "pose %.6f %.4f 0 0 0.01 0.01 0.01\n", t_unix + 0.001 * k, 0.0011 * (3 + k));
      flood += line;
    }
    REQUIRE(talk(sens, flood, -1) == "");
    sleep_s(0.3);
    const double dropped = status_value(talk(cmd, "status all\n", 1), "poses_dropped");
    CHECK(dropped >= 1);
    CHECK(dropped <= 12);
    CHECK(events_log(dir + "/log").find("event=poses-dropped") != std::string::npos);
    kill(d.pid, SIGTERM);
    REQUIRE(d.wait_exit(2.0) == 0);
    const auto logs = csv_logs(dir + "/log");
    REQUIRE(!logs.empty());
    auger::RobotLogReader reader(logs.front());
    const int capture_col = reader.csv().column_index("pose_capture_t_s");
    REQUIRE(capture_col >= 0);
    auger::RobotSample s;
    std::vector<double> x_m, capture_t_s;
    std::vector<long> row_of;
    long row = 0;
    while (reader.next(s)) {
      ++row;
      if (std::isnan(s.x_m)) continue;
      x_m.push_back(s.x_m), capture_t_s.push_back(reader.csv().value(capture_col)), row_of.push_back(row);
    }
    REQUIRE(x_m.size() == 3 + 20 - std::size_t(dropped));
    for (std::size_t k = 0; k < 3; ++k) CHECK(x_m[k] == Approx(0.0011 * double(k + 1)));
    CHECK(x_m.back() == Approx(0.0011 * 23));  // the newest is never the one dropped
    CHECK(capture_t_s[1] - capture_t_s[0] == Approx(0.03).margin(1e-4));
    CHECK(capture_t_s[2] - capture_t_s[1] == Approx(0.03).margin(1e-4));
    CHECK(row_of[1] == row_of[0] + 1);
    CHECK(row_of[2] == row_of[1] + 1);
  }

  SECTION("malformed commands and sensor lines get errors and change nothing") {
    for (const char* bad : {"bogus", "vel 1 2", "vel a b c", "goto 1 2 nan", "allocator foo", "enable now",
                            "follow /nonexistent/trajectory.csv", "vel 0.05 0 0", "goto 0 0 0", "",
                            "status extra", "vel 1e999 0 0"}) {
      const std::string a = talk(cmd, std::string(bad) + "\n", 1);
      INFO(bad << " -> " << a);
      CHECK(a.rfind("error: ", 0) == 0);
    }
    const std::string t = now_unix();
    for (const std::string& bad : std::vector<std::string>{"pose 1 2 3", "imu x 1 2", "pose " + t + " 0 0 0 0 0 0", "imu 1000 0 0",
                                  "imu " + t + " 0", "gps " + t + " 1 2", "imu 99999999999 0 0"}) {
      const std::string a = talk(sens, bad + "\n", -1);
      INFO(bad << " -> " << a);
      CHECK(a.rfind("error: ", 0) == 0);
    }
    // Issue 13: absurd but finite values, a NUL inside a number; enabled, so that nothing but the
    // bounds refuses them. Each answer is one printable line.
    REQUIRE(talk(cmd, "enable\n", 1) == "ok");
    for (const std::string& bad : std::vector<std::string>{"vel 1e308 1e308 1e308", "goto 1e308 0 0",
                                                           std::string("vel 0.01\0garbage 0 0", 20), "spin 1 1e308"}) {
      const std::string a = talk(cmd, bad + "\n", 1);
      INFO(bad << " -> " << a);
      CHECK(a.rfind("error: ", 0) == 0);
      CHECK(a.find('\0') == std::string::npos);
    }
    for (const std::string& bad : std::vector<std::string>{"pose " + now_unix() + " 0 0 0 1e300 1e300 1e300",
                                                           "imu " + now_unix() + " 0 1e100", "imu " + now_unix() + " 0 1e20",
                                                           "pose " + now_unix() + " 0 0 0 0.01 0.01 1e300"}) {
      const std::string a = talk(sens, bad + "\n", -1);
      INFO(bad << " -> " << a);
      CHECK(a.find("is outside") != std::string::npos);
    }
    {
      const std::string st = talk(cmd, "status\n", 1);
      INFO(st);
      CHECK(st.find("x_m=nan") == std::string::npos);
      CHECK(st.find("fault=none") != std::string::npos);
      CHECK(st.find("mode=idle") != std::string::npos);
    }
    // follow of a FIFO nobody writes: refused at once, the loop keeps its period.
    {
      const std::string fifo = dir + "/traj.fifo";
      REQUIRE(mkfifo(fifo.c_str(), 0600) == 0);
      const double t0 = SimRig::wall_s();
      const std::string a = talk(cmd, "follow " + fifo + "\nstatus\n", 2);
      INFO(a);
      CHECK(a.rfind("error: '" + fifo + "': not a regular file", 0) == 0);
      CHECK(a.find("\nstatus t_s=") != std::string::npos);
      CHECK(SimRig::wall_s() - t0 < 0.2);
    }
    // A camera pose within every bound that the estimate cannot follow: a jump of 1000 km at a
    // micrometre's confidence (a camera switching frames). The EKF's speed would leap to 1e5 m/s;
    // the controller latches its fault, augerd stops every screw and says so, never arrived;
    // the estimate stays the last good one; enable clears the fault.
    {
      REQUIRE(talk(cmd, "goto 0.1 0 0\n", 1) == "ok");
      // Sent until the fault shows: the simulated camera's own poses keep arriving, and of two
      // poses read in one cycle the loop takes the later (under load they often share a cycle).
      std::string st;
      CHECK(wait_until(
          [&] {
            CHECK(talk(sens, "pose " + now_unix() + " 1000000 0 0 0.000001 0.000001 0.000001\n", -1) == "");
            return (st = talk(cmd, "status\n", 1)).find("fault=estimator") != std::string::npos;
          },
          1.0));
      INFO(st << "\n" << d.stderr_text());
      CHECK(st.find("enabled=0") != std::string::npos);
      CHECK(st.find("mode=stopped") != std::string::npos);
      CHECK(st.find("arrived=0") != std::string::npos);
      CHECK(std::fabs(status_value(st, "x_m")) < 0.05);  // the last good estimate, near the start
      CHECK(wait_until([&] { return all_stopped(rig); }, 0.5));
      CHECK(d.stderr_text().find("estimator diverged: estimated u_mps") != std::string::npos);
      CHECK(talk(cmd, "vel 0.01 0 0\n", 1).rfind("error: not enabled", 0) == 0);
      REQUIRE(talk(cmd, "enable\n", 1) == "ok");
      CHECK(talk(cmd, "status\n", 1).find("fault=none") != std::string::npos);
    }
    REQUIRE(talk(cmd, "stop\n", 1) == "ok");
    CHECK(talk(sens, "imu " + now_unix() + " 0.1 0.0\npose " + now_unix() + " 0 0 0 0.01 0.01 0.01\n", -1) == "");
    const std::string st = talk(cmd, "status\n", 1);
    CHECK(st.find("enabled=0") != std::string::npos);
    CHECK(st.find("mode=stopped") != std::string::npos);
    // The modules' reports of the stop follow within a few cycles (a loaded test machine lags the
    // simulated modules: an immediate check failed there at load 9-17; daemon_load times stops).
    CHECK(wait_until([&] { return all_stopped(rig); }, 0.5));
    // the auger client
    const std::string client = std::string(AUGER_CLIENT_PATH) + " cmd --socket " + cmd + " status bogus >/dev/null";
    CHECK(WEXITSTATUS(std::system(client.c_str())) == 1);
    const std::string ok = std::string(AUGER_CLIENT_PATH) + " cmd --socket " + cmd + " status >/dev/null";
    CHECK(WEXITSTATUS(std::system(ok.c_str())) == 0);

    // SIGTERM: a clean stop (setpoints 0 without ENABLE), the period statistics, exit 0.
    REQUIRE(talk(cmd, "enable\n", 1) == "ok");
    kill(d.pid, SIGTERM);
    CHECK(d.wait_exit(2.0) == 0);
    CHECK(d.stderr_text().find("loop period mean") != std::string::npos);
    CHECK(access(cmd.c_str(), F_OK) != 0);  // the socket files are removed
    WARN(d.stderr_text().substr(d.stderr_text().find("cycles;")));
  }

  SECTION("one wild camera pose is rejected and counted; a stream of shifted poses faults after 1 s") {
    // Issue 28 point 7: one pose 10 m away at 3 mm latched fault=estimator and stopped the robot.
    auto pose = [&](double x_m) {
      return talk(sens, "pose " + now_unix() + " " + std::to_string(x_m) + " 0 0 0.003 0.003 0.003\n", -1);
    };
    REQUIRE(talk(cmd, "enable\n", 1) == "ok");
    REQUIRE(talk(cmd, "goto 0 0 0\n", 1) == "ok");
    for (int k = 0; k < 5; ++k) {  // the estimator's fix
      CHECK(pose(0.0).empty());
      sleep_s(0.1);
    }
    CHECK(pose(10.0).empty());
    sleep_s(0.1);
    for (int k = 0; k < 3; ++k) {
      CHECK(pose(0.0).empty());
      sleep_s(0.1);
    }
    std::string st = talk(cmd, "status\n", 1);
    INFO(st << "\n" << d.stderr_text());
    CHECK(st.find("fault=none") != std::string::npos);
    CHECK(st.find("enabled=1") != std::string::npos);
    CHECK(status_value(st, "poses_rejected") == 1);
    CHECK(std::fabs(status_value(st, "x_m")) < 0.05);
    // A stream 10 m off, every 0.1 s: rejected, then the fault 1 s after the first.
    const double t0 = SimRig::wall_s();
    double fault_s = -1;
    while (SimRig::wall_s() - t0 < 3.0 && fault_s < 0) {
      CHECK(pose(10.0).empty());
      if (talk(cmd, "status\n", 1).find("fault=estimator") != std::string::npos) fault_s = SimRig::wall_s() - t0;
      sleep_s(0.1);
    }
    st = talk(cmd, "status\n", 1);
    CHECK(fault_s >= 0.95);
    CHECK(fault_s < 1.6);
    CHECK(st.find("enabled=0") != std::string::npos);
    CHECK(status_value(st, "poses_rejected") >= 11);
    CHECK(wait_until([&] { return all_stopped(rig); }, 0.5));
    CHECK(d.stderr_text().find("camera poses disagree with the estimate") != std::string::npos);
    const std::string events = events_log(dir + "/log");
    CHECK(events.find("event=pose-rejected action=\"camera pose 10.000 m 0.000 m 0.000 rad rejected") !=
          std::string::npos);
    CHECK(events.find("event=pose-accepted action=\"camera poses agree with the estimate again after 1 rejected") !=
          std::string::npos);
    CHECK(events.find("event=estimator") != std::string::npos);
  }

  SECTION("velocity, dead-man, silent / corrupt / closed module, re-enable, kill -9") {
    REQUIRE(talk(cmd, "enable\n", 1) == "ok");
    // Each module turns as eq. (4) asks of its screw index: the id mapping is right.
    const auger::ModelFile mf = auger::load_model_file(AUGER_SOURCE_DIR "/models/robot.toml");
    const auger::Model model = auger::build_model(mf, "sand");
    const auger::Vec4 want = auger::kinematic_screw_speeds_rpm(model, auger::Vec3(0.03, 0.0, 0.05));
    {
      VelFeeder feed(cmd, "vel 0.03 0 0.05");
      REQUIRE(wait_until([&] { return all_driven(rig); }, 1.0));
      for (int m = 0; m < 4; ++m) CHECK(rig.module(m).tm.omega_cmd_crpm / 100.0 == Approx(want[m]).margin(0.011));
    }
    // Dead-man: 0.5 s after the last vel, setpoints 0 (still enabled, mode idle).
    const double t_last = SimRig::wall_s();
    REQUIRE(wait_until([&] { return rig.module(0).tm.omega_cmd_crpm == 0; }, 1.0));
    const double deadman_s = SimRig::wall_s() - t_last;
    CHECK(deadman_s > 0.3);
    CHECK(deadman_s < 0.75);
    CHECK(talk(cmd, "status\n", 1).find("mode=idle") != std::string::npos);

    // spin (auger step, auger calib): one module alone, the others at 0; it expires like vel.
    {
      CHECK(talk(cmd, "spin 1 5\n", 1) == "ok");
      REQUIRE(wait_until([&] { return rig.module(1).tm.omega_cmd_crpm == 500; }, 0.5));
      for (int m : {0, 2, 3}) CHECK(rig.module(m).tm.omega_cmd_crpm == 0);
      CHECK(talk(cmd, "status\n", 1).find("mode=spin") != std::string::npos);
      CHECK(wait_until([&] { return rig.module(1).tm.omega_cmd_crpm == 0; }, 1.0));
      CHECK(talk(cmd, "status\n", 1).find("mode=idle") != std::string::npos);
    }

    struct LineFault {
      const char* name;
      int port;          // rig port k, wired to module perm[k]
      int module;
      const char* reason;
    };
    for (const LineFault f : {LineFault{"mute", 0, 2, "fault=2:no-telemetry"},
                              LineFault{"corrupt", 1, 0, "fault=0:corrupt-frames"},
                              LineFault{"close", 2, 3, "fault=3:port-error"}}) {
      INFO(f.name);
      VelFeeder feed(cmd, "vel 0.03 0 0");
      REQUIRE(wait_until([&] { return all_driven(rig); }, 1.0));
      const double t_fault = SimRig::wall_s();
      if (std::string(f.name) == "mute") rig.set_mute(f.port, true);
      if (std::string(f.name) == "corrupt") rig.set_corrupt(f.port, true);
      if (std::string(f.name) == "close") rig.close_port(f.port);
      // Every screw stops: the healthy modules get setpoints without ENABLE; the silent one
      // still receives them too (muting cuts only its answers), a closed one times out.
      const bool stopped = wait_until(
          [&] { return motors_off(rig); },
          0.6);
      const double stop_s = SimRig::wall_s() - t_fault;
      CHECK(stopped);
      WARN(f.name << ": every screw stopped " << stop_s * 1000 << " ms after the line fault");
      if (std::string(f.name) != "close") CHECK(stop_s < 0.3);
      const std::string st = talk(cmd, "status\n", 1);
      INFO(st << "\n" << d.stderr_text());
      CHECK(st.find(f.reason) != std::string::npos);
      CHECK(st.find("enabled=0") != std::string::npos);
      CHECK(d.stderr_text().find("module " + std::to_string(f.module)) != std::string::npos);
      // The module returns: still stopped until `enable`.
      rig.set_mute(f.port, false);
      rig.set_corrupt(f.port, false);
      if (std::string(f.name) == "close") rig.reopen_port(f.port);
      sleep_s(std::string(f.name) == "close" ? 1.6 : 0.4);
      CHECK(all_stopped(rig));
      // Issue 28 point 8: status kept naming the fault while the module answered again.
      std::string back;
      CHECK(wait_until([&] { return (back = talk(cmd, "status\n", 1)).find("fault=none") != std::string::npos; }, 1.5));
      INFO(back);
      CHECK(back.find("enabled=0") != std::string::npos);
      CHECK(talk(cmd, "vel 0.03 0 0\n", 1).rfind("error:", 0) == 0);
      std::string en;
      wait_until([&] { return (en = talk(cmd, "enable\n", 1)) == "ok"; }, 3.0);
      REQUIRE(en == "ok");
      CHECK(talk(cmd, "status\n", 1).find("fault=none") != std::string::npos);
    }

    // A module reporting a fault (under-voltage) stops every screw and is named.
    {
      VelFeeder feed(cmd, "vel 0.03 0 0");
      REQUIRE(wait_until([&] { return all_driven(rig); }, 1.0));
      rig.set_battery_v(1, 14.0);
      CHECK(wait_until([&] { return all_stopped(rig); }, 0.5));
      const std::string st = talk(cmd, "status\n", 1);
      INFO(st);
      CHECK(st.find("fault=1:F_UNDERVOLTAGE") != std::string::npos);
      // status all names the bit per module (auger monitor shows it).
      const std::string all = talk(cmd, "status all\n", 1);
      CHECK(all.find(" m1_faults=F_UNDERVOLTAGE ") != std::string::npos);
      CHECK(all.find(" m0_faults=none ") != std::string::npos);
      rig.set_battery_v(1, 0.0);
      sleep_s(0.2);
      std::string en;
      wait_until([&] { return (en = talk(cmd, "enable\n", 1)) == "ok"; }, 2.0);
      REQUIRE(en == "ok");
      sleep_s(0.1);
      CHECK(talk(cmd, "status\n", 1).find("fault=none") != std::string::npos);
    }

    // The fault event log beside the data log: each fault with its module, port and what
    // augerd did, and who enabled again, flushed at once (read while augerd runs).
    {
      const std::string events = events_log(dir + "/log");
      INFO(events);
      for (const char* want : {" module=2 port=", "event=no-telemetry action=\"no telemetry for",
                               " module=0 port=", "event=corrupt-frames", " module=3 port=", "event=port-error",
                               "event=F_UNDERVOLTAGE action=\"reports F_UNDERVOLTAGE; stopped all screws (was vel), "
                               "waiting for enable\"",
                               "event=re-enabled action=\"fault F_UNDERVOLTAGE cleared by enable from pid "})
        CHECK(events.find(want) != std::string::npos);
    }

    // kill -9: nothing stops the motors but their own 250 ms command timeout.
    {
      VelFeeder feed(cmd, "vel 0.03 0 0");
      REQUIRE(wait_until([&] { return all_driven(rig); }, 1.0));
      sleep_s(0.2);
      REQUIRE(kill(d.pid, SIGKILL) == 0);
      const double t_kill = SimRig::wall_s();
      const bool stopped = wait_until([&] { return motors_off(rig); }, 1.0);
      REQUIRE(stopped);
      sleep_s(0.02);
      // When each motor's PWM pin went quiet, against the kill and against the last setpoint
      // the module received.
      double pins_off_s = 0, since_setpoint_s = 0;
      for (int m = 0; m < 4; ++m) {
        const auto v = rig.module(m);
        REQUIRE(v.pwm_off_wall_s > 0);
        pins_off_s = std::max(pins_off_s, v.pwm_off_wall_s - t_kill);
        since_setpoint_s = std::max(since_setpoint_s, v.pwm_off_wall_s - v.last_setpoint_wall_s);
      }
      WARN("kill -9: every motor's PWM pin off " << pins_off_s * 1000 << " ms after the kill, at most "
                                                 << since_setpoint_s * 1000 << " ms after its last setpoint");
      // The module stops on the 1 ms tick at which its last setpoint is 250 ms old (the frame's
      // arrival is known to that tick: +-1 ms); that setpoint left augerd before the kill and
      // spent 0.35 ms on the wire (8 bytes at 250000 baud).
      CHECK(pins_off_s <= 0.2515);
      CHECK(since_setpoint_s <= 0.2515);
      // The command timeout, not something else, stopped them.
      for (int m = 0; m < 4; ++m) CHECK((rig.module(m).tm.status & PROTO_F_CMD_TIMEOUT) != 0);
    }
    CHECK(d.wait_exit(1.0) == 128 + SIGKILL);

    // The log: robot-log format, every cycle, loop period measured.
    const auto logs = csv_logs(dir + "/log");
    REQUIRE(!logs.empty());
    auger::RobotLogReader reader(logs.front());
    auger::RobotSample s;
    int rows = 0, with_dt = 0, stalls = 0;
    double max_dev_s = 0, sum = 0, sum2 = 0;
    while (reader.next(s)) {
      ++rows;
      if (std::isfinite(s.loop_dt_s) && rows > 1) {
        ++with_dt;
        max_dev_s = std::max(max_dev_s, std::fabs(s.loop_dt_s - 0.01));
        if (std::fabs(s.loop_dt_s - 0.01) > 0.02) ++stalls;
        sum += s.loop_dt_s;
        sum2 += s.loop_dt_s * s.loop_dt_s;
      }
    }
    const double mean_s = sum / with_dt, std_s = std::sqrt(std::max(0.0, sum2 / with_dt - mean_s * mean_s));
    CHECK(mean_s == Approx(0.01).margin(0.0002));
    CHECK(reader.csv().meta("format").value_or("") == auger::kRobotLogFormat);
    CHECK(rows > 300);  // flushed at least once a second, so kill -9 lost at most the last one
    WARN("log: " << rows << " rows; loop period mean " << mean_s * 1000 << " ms, std " << std_s * 1000
                  << " ms, largest deviation " << max_dev_s * 1000 << " ms, " << stalls << " cycles off by over 20 ms");
    // Generous: the test machine runs other tests on both cores (measured there: std up to 1 ms,
    // single stalls up to 11 ms, once one of 58 ms: the scheduler, not augerd, as nothing
    // repeated it). Work in the loop that blocks (a write or a flush that waits on the disk)
    // stalls it again and again: more than 3 cycles off by over 20 ms, or one of over 25
    // periods (the modules' 250 ms command timeout), is a bug.
    CHECK(std_s < 0.003);
    CHECK(stalls <= 3);
    CHECK(max_dev_s < 0.25);
  }
}

TEST_CASE("augerd start-up errors", "[daemon]") {
  const std::string dir = make_dir("config");
  RemoveDir cleanup{dir};
  auto run = [&](const std::string& text, std::vector<std::string> more = {}) {
    std::ofstream(dir + "/bad.toml") << text;
    Daemon d(dir + "/bad.toml", dir + "/bad.err", more);
    const int code = d.wait_exit(5.0);
    return std::make_pair(code, d.stderr_text());
  };
  const std::vector<std::string> ports{dir + "/p0", dir + "/p1", dir + "/p2", dir + "/p3"};
  const std::string good = config_text(dir, ports);
  {
    // Ports that do not exist (yet: a module unplugged): --check says so, exit 1, retried.
    auto c = run(good, {"--check"});
    CHECK(c.first == 1);
    CHECK(c.second.find(ports[0] + " does not exist") != std::string::npos);
  }
  // Configurations certain to fail (issue 13): --check and start-up exit 2, which the service
  // does not restart; each names what is wrong. The ports are character devices here.
  {
    const Ptys ptys(4);  // ttys, as serial ports must be
    const std::vector<std::string> dev = ptys.names;
    const std::string base = config_text(dir, dev);
    REQUIRE(symlink(dev[0].c_str(), (dir + "/ttyAlias").c_str()) == 0);
    auto replace = [](std::string t, const std::string& from, const std::string& to) {
      return t.replace(t.find(from), from.size(), to);
    };
    std::ofstream(dir + "/regular") << "x\n";
    auto q = [](const std::string& path) { return "\"" + path + "\""; };  // a whole port in the list
    struct Case {
      std::string text, message;
    };
    for (const Case& k : {Case{replace(base, dir + "/log\"", dir + "/nolog\""), "log directory " + dir + "/nolog does not exist"},
                          Case{replace(base, dir + "/log\"", dir + "/regular\""), "is not a directory"},
                          Case{replace(base, dir + "/cmd.sock", dir + "/regular"), "exists and is not a socket"},
                          Case{replace(base, dir + "/sensors.sock", dir + "/log/../cmd.sock"), "are the same file"},
                          Case{replace(base, q(dev[3]), q(dir + "/regular")), "is not a character device"},
                          // issue 28: no tty, two names of one device, a pseudo filesystem
                          Case{replace(base, q(dev[3]), q("/dev/zero")), "serial port /dev/zero is not a serial port or a pty"},
                          Case{replace(base, q(dev[3]), q(dir + "/ttyAlias")), "are the same device"},
                          Case{replace(base, dir + "/log\"", "/proc\""), "is on the proc pseudo filesystem"},
                          Case{base + "", ""}}) {
      if (k.message.empty()) {
        CHECK(run(k.text, {"--check"}).first == 0);  // the same with every path in place
        continue;
      }
      for (const auto& args : {std::vector<std::string>{"--check"}, std::vector<std::string>{}}) {
        auto c = run(k.text, args);
        INFO(k.message << (args.empty() ? " (start)" : " (--check)") << ": " << c.second);
        CHECK(c.first == 2);
        CHECK(c.second.find(k.message) != std::string::npos);
      }
    }
    auto c = run(replace(base, "allocator = \"nullspace\"\n", "allocator = \"nullspace\"\nomega_max_rpm = 5\nomega_min_rpm = 6\n"),
                 {"--check"});
    CHECK(c.first == 2);
    CHECK(c.second.find("omega_min_rpm = 6") != std::string::npos);
    // The service treats exactly that code as final, and the missing port's as worth a retry.
    const std::string unit = slurp(AUGER_SOURCE_DIR "/packaging/augerd.service.in");
    const auto k = unit.find("\nRestartPreventExitStatus=");
    REQUIRE(k != std::string::npos);
    const std::string codes = unit.substr(k + 26, unit.find('\n', k + 1) - (k + 26));
    CHECK(codes == std::to_string(c.first));
    CHECK(unit.find("\nRestart=on-failure\n") != std::string::npos);
  }

  auto r = run(good + "speed = 3\n");
  CHECK(r.first == 2);
  CHECK(r.second.find("bad.toml:") != std::string::npos);
  CHECK(r.second.find("unknown key 'speed'") != std::string::npos);

  r = run(config_text(dir, ports, "baudrate = 9600\n"));
  CHECK(r.first == 2);
  CHECK(r.second.find("bad.toml:5:") != std::string::npos);

  r = run(config_text(dir, ports, "telemetry_timeout_s = 5\n"));
  CHECK(r.first == 2);
  CHECK(r.second.find("telemetry_timeout_s") != std::string::npos);

  r = run(config_text(dir, {ports[0], ports[1], ports[2]}));
  CHECK(r.first == 2);
  CHECK(r.second.find("array of 4") != std::string::npos);

  r = run("schema = 1\n[serial\n");
  CHECK(r.first == 2);
  CHECK(r.second.find("bad.toml:2:") != std::string::npos);

  r = run(good);  // the ports do not exist: not final, the service retries
  CHECK(r.first == 1);
  CHECK(r.second.find(ports[0]) != std::string::npos);

  // A busy port (locked by another process) and duplicate ids, on live simulated modules.
  SimRig rig(dir, {0, 1, 1, 3}, {0, 1, 2, 3});
  const std::vector<std::string> live{rig.port(0), rig.port(1), rig.port(2), rig.port(3)};
  r = run(config_text(dir, live));
  CHECK(r.first == 1);
  CHECK(r.second.find("duplicate module id 1") != std::string::npos);
  {
    int fd = open(live[2].c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
    REQUIRE(fd >= 0);
    REQUIRE(flock(fd, LOCK_EX | LOCK_NB) == 0);
    r = run(config_text(dir, live));
    close(fd);
  }
  CHECK(r.first == 1);
  CHECK(r.second.find(live[2]) != std::string::npos);
  CHECK(r.second.find("in use") != std::string::npos);

  // A module of another protocol version (a pty this test answers on, as a module with the
  // previous firmware would: IDENTITY's layout is the same in every version) is refused with
  // what to do.
  {
    int master = posix_openpt(O_RDWR | O_NOCTTY);
    REQUIRE(master >= 0);
    REQUIRE(grantpt(master) == 0);
    REQUIRE(unlockpt(master) == 0);
    const std::string old_module = ptsname(master);
    std::atomic<bool> answering{true};
    std::thread answer([&] {
      proto_identity_t id{3, 1, 0, 1, 0, PROTO_RC_EXTERNAL, PROTO_ID_FROM_EEPROM};
      uint8_t frame[PROTO_MAX_FRAME];
      const size_t n = proto_encode_identity(&id, frame);
      while (answering) {
        [[maybe_unused]] ssize_t w = write(master, frame, n);
        sleep_s(0.05);
      }
    });
    r = run(config_text(dir, {live[0], live[1], old_module, live[3]}));
    answering = false;
    answer.join();
    close(master);
    CHECK(r.first == 1);
    INFO(r.second);
    CHECK(r.second.find(old_module + ": the module (firmware 0.1.0) speaks protocol 1, augerd protocol 2: refusing "
                        "it. Flash the firmware of this version") != std::string::npos);
  }
}

// Issue 29 point 6: [online] off writes exactly today's columns and status; on adds the
// estimate's columns (auger::daemon::online_columns()) and status all's online fields.
