// The real augerd against four simulated modules, runs with one thing each: [online] off and on,
// a log that cannot be written, a module's trip and reset (daemon_kit.hpp's Run).
#include <catch2/catch.hpp>

#include <signal.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "auger/log.hpp"
#include "auger/dynamics.hpp"
#include "auger/model_file.hpp"
#include "auger/online_estimator.hpp"
#include "daemon_kit.hpp"
#include "daemon_log.hpp"
#include "status.hpp"
#include "simmod.h"

using namespace daemon_kit;

TEST_CASE("augerd's [online]: off leaves the log as it was, on logs the estimate", "[daemon]") {
  for (const bool online : {false, true}) {
    Run::Options o;
    o.tail = online ? "[online]\nenabled = true\n" : "[online]\nenabled = false\n";
    Run r(online ? "online_on" : "online_off", o);
    const std::string &dir = r.dir, &cmd = r.cmd;
    Daemon& d = *r.d;
    INFO("online " << online << ": " << d.stderr_text());
    REQUIRE(talk(cmd, "enable\n", 1) == "ok");
    {
      VelFeeder feed(cmd, "vel 0.03 0 0");
      sleep_s(1.0);
    }
    const std::string all = talk(cmd, "status all\n", 1);
    INFO(all);
    CHECK((all.find(" online_terrain=") != std::string::npos) == online);
    if (online) {
      CHECK(std::isfinite(status_value(all, "on_sigma_long")));
      CHECK(status_value(all, "on_fallback") == 0);
    }
    kill(d.pid, SIGTERM);
    CHECK(d.wait_exit(2.0) == 0);
    const auto logs = csv_logs(dir + "/log");
    REQUIRE(!logs.empty());
    auger::RobotLogReader reader(logs.front());
    std::vector<std::string> expected = auger::robot_log_columns();
    for (const auto& c : auger::daemon::replay_columns()) expected.push_back(c);
    if (online)
      for (const auto& c : auger::daemon::online_columns()) expected.push_back(c);
    CHECK(reader.csv().columns() == expected);
    auger::RobotSample s;
    int rows = 0;
    double sigma = NAN, ctl_D_x = NAN;  // of the last row
    while (reader.next(s)) {
      ++rows;
      if (online) {
        sigma = reader.csv().value(reader.csv().column_index("on_sigma_long"));
        ctl_D_x = reader.csv().value(reader.csv().column_index("ctl_D_x"));
      }
    }
    CHECK(rows > 50);
    if (online) {
      // The estimate within the physical range; the controller's model has a drag.
      CHECK(sigma >= auger::terrain_range(auger::kSigmaLong).lower);
      CHECK(sigma <= auger::terrain_range(auger::kSigmaLong).upper);
      CHECK(ctl_D_x > 0);
    }
  }
}

TEST_CASE("augerd keeps control when the log cannot be written", "[daemon]") {
  // A 40 kB file-size limit stands in for a full disk: the log fails after about 2.5 s.
  Run::Options o;
  o.prefix = {"prlimit", "--fsize=40000"};
  Run r("fulldisk", o);
  const std::string &dir = r.dir, &cmd = r.cmd;
  SimRig& rig = r.rig;
  Daemon& d = *r.d;
  REQUIRE(talk(cmd, "enable\n", 1) == "ok");
  REQUIRE(wait_until([&] { return d.stderr_text().find("failed") != std::string::npos; }, 6.0));
  INFO(d.stderr_text());
  // Control goes on: commands are served and the modules follow them.
  {
    VelFeeder feed(cmd, "vel 0.03 0 0");
    CHECK(wait_until([&] { return all_driven(rig); }, 1.0));
    sleep_s(0.5);
    CHECK(all_driven(rig));
  }
  const std::string err = d.stderr_text();
  std::size_t reports = 0;
  for (auto p = err.find("failed"); p != std::string::npos; p = err.find("failed", p + 1)) ++reports;
  CHECK(reports == 1);
  const std::string st = talk(cmd, "status\n", 1);
  CHECK(st.find("enabled=1") != std::string::npos);
  CHECK(st.find("log_ok=0") != std::string::npos);
  kill(d.pid, SIGTERM);
  CHECK(d.wait_exit(2.0) == 0);
  // The file the limit stopped ends at a row boundary: every reader takes it whole, with no
  // warning; no empty file was left (issue 13: the last row was cut mid-field).
  int files = 0;
  for (const std::string& path : csv_logs(dir + "/log")) {
    ++files;
    const std::string text = slurp(path);
    INFO(path);
    REQUIRE(!text.empty());
    CHECK(text.back() == '\n');
    auger::RobotLogReader reader(path);
    auger::RobotSample smp;
    int rows = 0;
    while (reader.next(smp)) ++rows;
    CHECK_FALSE(reader.csv().last_row_cut());
    CHECK(rows > 100);
  }
  CHECK(files == 1);
}

TEST_CASE("augerd logs a module's trip with its snapshot and a reset with its cause; follows its telemetry period",
          "[daemon]") {
  // Module 2 sends telemetry every 100 ms, the others every 10 ms, and augerd takes 70 ms
  // without telemetry for a lost module: it must follow module 2's period, not fault at its gaps.
  Run::Options o;
  o.telemetry_ms = {10, 10, 100, 10};
  o.extra = "telemetry_timeout_s = 0.07\n";
  Run r("protect", o);
  const std::string &dir = r.dir, &cmd = r.cmd;
  SimRig& rig = r.rig;
  Daemon& d = *r.d;
  INFO(d.stderr_text());
  CHECK(d.stderr_text().find("module 2 on " + rig.port(2) + " (firmware") != std::string::npos);
  CHECK(d.stderr_text().find("telemetry every 100 ms") != std::string::npos);
  CHECK(d.stderr_text().find("last reset: external") != std::string::npos);  // its port's open
  auto events = [&] { return events_log(dir + "/log"); };

  REQUIRE(talk(cmd, "enable\n", 1) == "ok");
  {
    VelFeeder feed(cmd, "vel 0.03 0 0.05");
    REQUIRE(wait_until([&] { return all_driven(rig); }, 1.0));
    sleep_s(0.25);  // module 2's 100 ms gaps: no no-telemetry fault
    CHECK(talk(cmd, "status\n", 1).find("fault=none") != std::string::npos);

    // A locked rotor on module 1: the module latches STALL and sends its snapshot; augerd
    // stops every screw and logs both.
    rig.in_sim([](simmod_t* s) { simmod_lock_shaft(s, 1, 1); });
    REQUIRE(wait_until([&] { return all_stopped(rig); }, 1.0));
    CHECK(talk(cmd, "status\n", 1).find("fault=1:F_STALL") != std::string::npos);
    CHECK(wait_until([&] { return events().find("module=1") != std::string::npos &&
                                  events().find("event=fault-snapshot action=\"F_STALL at module time") !=
                                      std::string::npos; },
                     1.0));
  }
  const std::string ev = events();
  INFO(ev);
  CHECK(ev.find(" rpm (command ") != std::string::npos);
  CHECK(ev.find("event=F_STALL action=\"reports F_STALL; stopped all screws") != std::string::npos);

  rig.in_sim([](simmod_t* s) { simmod_lock_shaft(s, 1, 0); });
  REQUIRE(talk(cmd, "enable\n", 1) == "ok");
  {
    VelFeeder feed(cmd, "vel 0.03 0 0.05");
    REQUIRE(wait_until([&] { return all_driven(rig); }, 1.0));
    // Module 3 loses its supply and comes back (power-on, RAM gone): an unexpected reset of a
    // running module, logged with its cause; every screw stops and module 3 stays stopped
    // while the velocity commands go on, until `enable`.
    rig.in_sim([](simmod_t* s) { simmod_reset_as(s, 3, PROTO_RC_POWER_ON, 1); });
    REQUIRE(wait_until([&] { return all_stopped(rig); }, 1.0));
    CHECK(talk(cmd, "status\n", 1).find("fault=3:reset") != std::string::npos);
    sleep_s(0.2);
    CHECK_FALSE(enabled(rig.module(3).tm));
    CHECK(rig.module(3).tm.duty_x10000 == 0);
  }
  CHECK(wait_until([&] { return events().find("event=reset action=\"the module reset; last reset: power-on") !=
                                std::string::npos; },
                   1.0));
  REQUIRE(talk(cmd, "enable\n", 1) == "ok");
  {
    VelFeeder feed(cmd, "vel 0.03 0 0.05");
    CHECK(wait_until([&] { return all_driven(rig); }, 1.0));
  }
  kill(d.pid, SIGTERM);
  CHECK(d.wait_exit(2.0) == 0);
}


// Issue 29 point 1: the effects' parameters a model file marks `online = true` are estimated with
// the terrain and shown in `status all` (on_eff_..., on_sd_eff_...); one that cannot be is a
// configuration error naming the model file's line and column, before anything is opened.
TEST_CASE("augerd's [online] estimates the effects the model file marks online", "[daemon]") {
  const std::string dir = make_dir("online_effects");
  RemoveDir cleanup{dir};
  const std::string robot = slurp(AUGER_SOURCE_DIR "/models/robot.toml") + "\n";
  const int base = static_cast<int>(std::count(robot.begin(), robot.end(), '\n'));
  std::ofstream(dir + "/slope.toml") << robot << "[[effect]]\nid = \"terrain_slope\"\n"
                                     << "incline_x_rad = { value = 0.02, online = true }\n"
                                     << "incline_y_rad = { value = 0, online = true }\n";
  {
    Run::Options o;
    o.model = dir + "/slope.toml";
    o.tail = "[online]\nenabled = true\n";
    Run r("online_effects_run", o);
    INFO(r.d->stderr_text());
    REQUIRE(talk(r.cmd, "enable\n", 1) == "ok");
    {
      VelFeeder feed(r.cmd, "vel 0.03 0 0.1");
      sleep_s(1.0);
    }
    const std::string all = talk(r.cmd, "status all\n", 1);
    INFO(all);
    auger::daemon::Status st;
    REQUIRE(auger::daemon::parse_status(all, st) == "");
    REQUIRE(st.on_effects.size() == 2);
    CHECK(st.on_effects[0].name == "terrain_slope.incline_x_rad");
    CHECK(st.on_effects[1].name == "terrain_slope.incline_y_rad");
    for (const auto& e : st.on_effects) {
      CHECK(std::fabs(e.value) <= 0.35);  // the library's physical range
      CHECK(e.sd > 0);
      CHECK(e.sd <= 0.175 + 1e-3);         // at most the prior: a quarter of that range
    }
    // The same status written again reads back to the same fields.
    auger::daemon::Status again;
    REQUIRE(auger::daemon::parse_status(auger::daemon::format_status(st), again) == "");
    CHECK(again.on_effects.size() == 2);
    kill(r.d->pid, SIGTERM);
    CHECK(r.d->wait_exit(2.0) == 0);
    // The event with the estimates (once informed, looked at once a second; the slope's column
    // is informative in every window).
    const std::string events = events_log(r.dir + "/log");
    INFO(events);
    CHECK(events.find("event=online-effects action=\"the estimate is now terrain_slope.incline_x_rad ") != std::string::npos);
    CHECK(events.find("(the controller keeps the model file's values: apply is off)") != std::string::npos);
  }
  // A sensor's offset marked online: exit 2 at --check, naming the file, line and column.
  std::ofstream(dir + "/bias.toml") << robot << "[[effect]]\nid = \"imu_heading_bias\"\n"
                                    << "bias_rad = { value = 0.01, online = true }\n";
  std::ofstream(dir + "/bias-augerd.toml") << config_text(dir, {dir + "/p0", dir + "/p1", dir + "/p2", dir + "/p3"}, "",
                                                          dir + "/bias.toml");
  Daemon d(dir + "/bias-augerd.toml", dir + "/bias.err", {"--check"});
  CHECK(d.wait_exit(5.0) == 2);
  const std::string err = d.stderr_text();
  INFO(err);
  CHECK(err.find(dir + "/bias.toml:" + std::to_string(base + 3) +
                 ":37: effect 'imu_heading_bias': 'bias_rad' cannot be estimated online") != std::string::npos);
}

// Issue 29: with [control] effect_feedforward the force fed forward is in `status all` and in the
// log's last columns, as the model's effects make it at the estimate (a slope: no velocity in it).
TEST_CASE("augerd shows and logs the force it feeds forward", "[daemon]") {
  const std::string dir = make_dir("feedforward");
  RemoveDir cleanup{dir};
  std::ofstream(dir + "/slope.toml") << slurp(AUGER_SOURCE_DIR "/models/robot.toml")
                                     << "\n[[effect]]\nid = \"terrain_slope\"\nincline_x_rad = 0.05\nincline_y_rad = -0.03\n";
  const auger::Model model = auger::build_model(auger::load_model_file(dir + "/slope.toml"), "sand");
  auto expected_n = [&](double x_m, double y_m, double psi_rad) {
    auger::Vec3 f;
    REQUIRE(auger::effect_feedforward_force(model, auger::Vec3(x_m, y_m, psi_rad), auger::Vec3::Zero(), f) == nullptr);
    return f;
  };
  Run::Options o;
  o.model = dir + "/slope.toml";
  o.control = "effect_feedforward = true\n";
  Run r("feedforward_run", o);
  INFO(r.d->stderr_text());
  REQUIRE(talk(r.cmd, "enable\n", 1) == "ok");
  REQUIRE(talk(r.cmd, "goto 0.05 0 0.3\n", 1) == "ok");
  sleep_s(1.0);
  const std::string all = talk(r.cmd, "status all\n", 1);
  INFO(all);
  auger::daemon::Status st;
  REQUIRE(auger::daemon::parse_status(all, st) == "");
  REQUIRE(st.feedforward);
  const auger::Vec3 f_n = expected_n(st.x_m, st.y_m, st.psi_rad);
  CHECK(f_n.norm() > 1.0);  // a slope the screws feel
  // The status's fields are the controller's last cycle; the estimate moves a little between.
  CHECK(st.ff_force_x_n == Approx(f_n[0]).margin(0.02 * f_n.norm()));
  CHECK(st.ff_force_y_n == Approx(f_n[1]).margin(0.02 * f_n.norm()));
  CHECK(st.ff_torque_psi_nm == Approx(f_n[2]).margin(0.02 * f_n.norm()));
  kill(r.d->pid, SIGTERM);
  CHECK(r.d->wait_exit(2.0) == 0);
  const auto logs = csv_logs(r.dir + "/log");
  REQUIRE(!logs.empty());
  auger::RobotLogReader reader(logs.front());
  const auto& cols = reader.csv().columns();
  const auto& ff_cols = auger::daemon::feedforward_columns();
  REQUIRE(cols.size() > ff_cols.size());
  CHECK(std::vector<std::string>(cols.end() - 3, cols.end()) == ff_cols);
  // Each goto row: the force at that row's estimate (the columns after the step), to the clamp.
  int rows = 0, checked = 0;
  const auto index = [&](const std::string& c) { return reader.csv().column_index(c); };
  auger::RobotSample s;
  while (reader.next(s)) {
    ++rows;
    if (reader.csv().value(index("mode")) != double(auger::daemon::mode_code(auger::daemon::Mode::go_to))) continue;
    const auger::Vec3 e_n = expected_n(reader.csv().value(index("xe_m")), reader.csv().value(index("ye_m")),
                                       reader.csv().value(index("psie_rad")));
    for (int k = 0; k < 3; ++k) CHECK(reader.csv().value(index(ff_cols[std::size_t(k)])) == Approx(e_n[k]).margin(1e-6 * e_n.norm() + 1e-9));
    ++checked;
  }
  CHECK(rows > 50);
  CHECK(checked > 50);
}
