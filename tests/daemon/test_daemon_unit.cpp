// augerd's pure parts: the socket line parsers and the configuration reader.
#include <catch2/catch.hpp>

#include <fstream>
#include <string>

#include <unistd.h>

#include "auger/effect.hpp"
#include "config.hpp"
#include "lines.hpp"
#include "status_text.hpp"

using namespace augerd;

TEST_CASE("command lines", "[daemon][unit]") {
  Command c;
  CHECK(parse_command("vel 0.1 -0.2 0.3", c).empty());
  CHECK(c.kind == CommandKind::vel);
  CHECK(c.a == 0.1);
  CHECK(c.b == -0.2);
  CHECK(c.c == 0.3);
  CHECK(parse_command("  goto\t1 2 3.5 ", c).empty());
  CHECK(c.kind == CommandKind::go_to);
  CHECK(parse_command("allocator pinv", c).empty());
  CHECK(c.text == "pinv");
  CHECK(parse_command("follow /tmp/a.csv", c).empty());
  CHECK(c.text == "/tmp/a.csv");
  CHECK(parse_command("spin 2 -7.5", c).empty());
  CHECK(c.kind == CommandKind::spin);
  CHECK(c.a == 2);
  CHECK(c.b == -7.5);
  CHECK(parse_command("status all", c).empty());
  CHECK((c.kind == CommandKind::status && c.text == "all"));
  CHECK(parse_command("status", c).empty());
  CHECK(c.text.empty());  // plain status: the short line
  for (const char* ok : {"enable", "stop", "status", "status\r"}) CHECK(parse_command(ok, c).empty());
  for (const char* bad : {"", "   ", "Enable", "vel", "vel 1 2", "vel 1 2 3 4", "vel 1 2 x", "vel 1 2 3x",
                          "vel nan 0 0", "vel inf 0 0", "vel 1e400 0 0", "goto 1 2", "allocator", "allocator qr",
                          "follow", "follow a b", "stop now", "status 1", "status all x", "spin", "spin 1",
                          "spin 4 1", "spin -1 1", "spin 1.5 2", "spin 1 x", "spin 1 nan", "spin 1 2 3"}) {
    Command before;
    before.kind = CommandKind::stop;
    Command out = before;
    const std::string err = parse_command(bad, out);
    INFO(bad);
    CHECK(!err.empty());
    CHECK(out.kind == CommandKind::stop);  // untouched
  }
  CHECK(parse_command("vel 1 2 zz", c).find("'zz'") != std::string::npos);
  CHECK(parse_command(std::string("bad\x01"), c).find('\x01') == std::string::npos);  // one printable line
}

TEST_CASE("sensor lines", "[daemon][unit]") {
  SensorMessage m;
  CHECK(parse_sensor("pose 1700000000.5 1 2 0.1 0.01 0.02 0.03", m).empty());
  CHECK(m.kind == SensorKind::pose);
  CHECK(m.t_unix_s == 1700000000.5);
  CHECK(m.spsi_rad == 0.03);
  CHECK(parse_sensor("imu 1700000000.5 0.2 -0.1", m).empty());
  CHECK(m.kind == SensorKind::imu);
  CHECK(m.imu_r_radps == -0.1);
  for (const char* bad : {"", "pose", "pose 1 2 3 4 5 6", "pose 1 2 3 4 5 6 0", "pose 1 2 3 4 -1 1 1",
                          "imu 1 2", "imu 1 2 3 4", "imu 1 x 3", "gps 1 2 3", "imu nan 0 0"}) {
    INFO(bad);
    CHECK(!parse_sensor(bad, m).empty());
  }
}

namespace {
std::string write_tmp(const std::string& text) {
  static int n = 0;
  const std::string p = "/tmp/augerd-unit-" + std::to_string(getpid()) + "-" + std::to_string(n++) + ".toml";
  std::ofstream(p) << text;
  return p;
}
const std::string kGood =
    "schema = 1\n"
    "[serial]\nports = [\"/dev/a\", \"/dev/b\", \"/dev/c\", \"/dev/d\"]\n"
    "[model]\nfile = \"" AUGER_SOURCE_DIR "/models/robot.toml\"\nterrain = \"frozen_grass\"\n"
    "[control]\nallocator = \"pinv\"\nomega_max_rpm = 20\nkp = [1, 2, 3]\n"
    "[sockets]\ncommands = \"c.sock\"\nsensors = \"/run/s.sock\"\n"
    "[log]\ndir = \"/tmp\"\n";
}  // namespace

TEST_CASE("configuration file", "[daemon][unit]") {
  const std::string p = write_tmp(kGood);
  const DaemonConfig c = load_daemon_config(p);
  CHECK(c.ports[2] == "/dev/c");
  CHECK(c.baud == 250000);
  CHECK(c.terrain == "frozen_grass");
  CHECK(c.controller.allocator.kind == auger::AllocatorKind::pseudo_inverse);
  CHECK(c.controller.allocator.omega_max_rpm == 20);
  CHECK(c.controller.gains.kp[2] == 3);
  CHECK(c.commands_socket == "/tmp/c.sock");  // relative to the file
  CHECK(c.sensors_socket == "/run/s.sock");
  unlink(p.c_str());

  struct Bad {
    std::string text, where;
  };
  auto replace = [](std::string s, const std::string& from, const std::string& to) {
    return s.replace(s.find(from), from.size(), to);
  };
  for (const Bad& b : {Bad{kGood + "extra = 1\n", ":16:"},
                       Bad{replace(kGood, "terrain = \"frozen_grass\"", "terrain = \"mud\""), "terrain 'mud'"},
                       Bad{replace(kGood, "omega_max_rpm = 20", "omega_max_rpm = -1"), ":9:17: 'omega_max_rpm' = -1 is outside 0.1..327"},
                       Bad{replace(kGood, "kp = [1, 2, 3]", "kp = [1, 2]"), ":10:"},
                       Bad{replace(kGood, "allocator = \"pinv\"", "allocator = \"qr\""), ":8:"},
                       Bad{replace(kGood, "\"/dev/d\"", "\"/dev/a\""), "listed twice"},
                       Bad{replace(kGood, "[log]\ndir = \"/tmp\"\n", ""), "missing [log] dir"},
                       Bad{replace(kGood, "schema = 1", "schema = 2"), ":1:"},
                       Bad{replace(kGood, "[serial]", "[serial]\nbaud = \"fast\""), ":3:"},
                       Bad{replace(kGood, "models/robot.toml", "models/none.toml"), "none.toml"}}) {
    const std::string q = write_tmp(b.text);
    INFO(b.text);
    try {
      load_daemon_config(q);
      FAIL("accepted");
    } catch (const std::exception& e) {
      INFO(e.what());
      CHECK(std::string(e.what()).find(b.where) != std::string::npos);
    }
    unlink(q.c_str());
  }
}

TEST_CASE("module words for augerd's messages and event log", "[daemon][unit]") {
  using namespace auger::io;
  CHECK(reset_cause_text(PROTO_RC_POWER_ON) == "power-on");
  CHECK(reset_cause_text(PROTO_RC_BROWN_OUT | PROTO_RC_EXTERNAL) == "external+brown-out");
  CHECK(reset_cause_text(PROTO_RC_WARM).rfind("warm reset (cause cleared by the bootloader", 0) == 0);
  CHECK(reset_cause_text(0) == "none reported");
  CHECK(reset_cause_text(0x48) == "watchdog+0x40");
  CHECK(settings_origin_text(PROTO_ID_FROM_EEPROM) == "EEPROM");
  CHECK(settings_origin_text(PROTO_ID_SETTINGS_OLD_LAYOUT) == "build defaults (the EEPROM held an older settings layout)");
  CHECK(settings_origin_text(PROTO_ID_SETTINGS_CORRUPT) == "build defaults (the EEPROM image was corrupt)");
  CHECK(settings_origin_text(0) == "build defaults (EEPROM empty)");
  CHECK(fault_bits_text(PROTO_F_STALL | PROTO_F_SENSOR) == "F_SENSOR+F_STALL");
  CHECK(fault_bits_text(0x4000 | PROTO_ST_ENABLED) == "F_0x4000");
  CHECK(state_bits_text(PROTO_ST_ENABLED | PROTO_ST_CURRENT_LIMITED) == "EN ILIM");
  const proto_fault_t f{61230, PROTO_F_STALL, PROTO_F_STALL | PROTO_ST_SETPOINT_OK, 4480, 17840, 0, 1000, 3890};
  CHECK(fault_snapshot_text(f) ==
        "F_STALL at module time 61.230 s: current 4.480 A, battery 17.840 V, speed 0.00 rpm (command 10.00 rpm), "
        "duty 38.90 %, status SP, faults F_STALL");
  proto_identity_t id{0, PROTO_VERSION, 0, 2, 0, PROTO_RC_POWER_ON, 0};
  CHECK_NOTHROW(require_protocol(id, "/dev/ttyUSB0", "augerd"));
  id.protocol_version = 1;
  try {
    require_protocol(id, "/dev/ttyUSB0", "augerd");
    FAIL("accepted protocol 1");
  } catch (const std::runtime_error& e) {
    CHECK(std::string(e.what()).find("/dev/ttyUSB0: the module (firmware 0.2.0) speaks protocol 1, augerd protocol 2") == 0);
    CHECK(std::string(e.what()).find("make flash PORT=/dev/ttyUSB0") != std::string::npos);
  }
}
