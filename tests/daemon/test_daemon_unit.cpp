// augerd's parts without modules: the socket line parsers and their bounds, the configuration
// reader and start-up checks, setpoint encoding. The sockets, the log writer and the waypoint
// loader have their own files (test_line_server.cpp, test_data_log.cpp).
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <vector>
#include <string>

#include <grp.h>
#include <sys/stat.h>
#include <unistd.h>

#include "auger/effect.hpp"
#include "config.hpp"
#include "daemon_lines.hpp"
#include "module_adapter.hpp"
#include "ptys.hpp"
#include "status_text.hpp"

using namespace augerd;
using namespace auger::io;
using namespace auger::daemon;

namespace {
// A string literal with its embedded NUL bytes (without the terminating one).
template <std::size_t N>
std::string raw(const char (&s)[N]) {
  return std::string(s, N - 1);
}
}  // namespace

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

TEST_CASE("command and sensor values are whole numbers within physical bounds", "[daemon][unit]") {
  // Issue 13: these were accepted and became NaN setpoints or a NaN estimate for good.
  Command c;
  for (const std::string& bad : std::vector<std::string>
       {"vel 1e308 1e308 1e308", "vel 0 0 1e308", "vel 11 0 0", "goto 1e308 0 0", "goto 0 0 1e308", "goto 2e7 0 0",
        "spin 1 1e308", "spin 1 400", raw("vel 0.01\0garbage 0 0"), raw("vel 0.01\0 0 0"),
        "vel 0.01garbage 0 0", "vel 0x 0 0"}) {
    Command out;
    out.kind = CommandKind::stop;
    const std::string err = parse_command(bad, out);
    INFO(quote_line(bad) << " -> " << err);
    CHECK(!err.empty());
    CHECK(out.kind == CommandKind::stop);
    CHECK(err.find('\0') == std::string::npos);  // never echoes a raw control byte
  }
  CHECK(parse_command("vel 1e308 0 0", c).find("u_mps = 1e+308 m/s is outside -10..10 m/s") != std::string::npos);
  CHECK(parse_command(raw("vel 0.01\0garbage 0 0"), c).find("control byte 0x00 at byte 9") !=
        std::string::npos);
  // Issue 28 point 8: hexadecimal floats were numbers (`spin 0x1 1` drove module 1).
  for (const char* hex : {"spin 0x1 1", "spin 1 0x10", "vel 0x1p-3 0 0", "goto 0X1 0 0", "vel inf 0 0",
                                 "vel nan 0 0"}) {
    INFO(hex);
    CHECK(parse_command(hex, c).find("must be a finite decimal number") != std::string::npos);
  }
  SensorMessage hm;
  CHECK(parse_sensor("imu 0x1 0 0", hm).find("t_unix_s must be a finite decimal number") != std::string::npos);
  CHECK(parse_command("goto 1e6 -1e6 3", c).empty());  // a projected frame's coordinates are places
  CHECK(parse_command("vel 0.2 0 -0.5", c).empty());
  CHECK(parse_command("spin 3 -327.67", c).empty());

  SensorMessage m;
  for (const std::string& bad : std::vector<std::string>
       {"pose 1 0 0 0 1e300 0.01 0.01", "pose 1 0 0 0 0.01 1e300 0.01", "pose 1 0 0 0 0.01 0.01 1e300",
        "pose 1 0 0 0 1e-300 0.01 0.01", "pose 1 0 0 0 0 0.01 0.01", "pose 1 1e308 0 0 0.01 0.01 0.01",
        "imu 1 0 1e100", "imu 1 0 1e20", "imu 1 1e300 0", "imu 1 0 -36", raw("imu 1 0\0 0.1"),
        "imu 1 0 0.1\x7f"}) {
    INFO(quote_line(bad));
    CHECK(!parse_sensor(bad, m).empty());
  }
  CHECK(parse_sensor("pose 1 0 0 0 1e300 0.01 0.01", m).find("sx_m = 1e+300 m is outside") != std::string::npos);
  CHECK(parse_sensor("imu 1 0 1e20", m).find("r_radps = 1e+20 rad/s is outside -35..35") != std::string::npos);
  CHECK(parse_sensor("imu 1 100 34.9", m).empty());  // an unwrapped heading, a fast gyro
  CHECK(parse_sensor("pose 1 500000 5000000 0.1 0.02 0.02 0.01", m).empty());  // UTM
}

TEST_CASE("error answers quote the input as one printable, bounded line", "[daemon][unit]") {
  CHECK(quote_line("ab") == "'ab'");
  CHECK(quote_line(raw("a\0b\n")) == "'a\\x00b\\x0a'");
  const std::string huge(10u << 20, 'x');
  const std::string q = quote_line(huge);
  CHECK(q.size() < 260);
  CHECK(q.find("(10485760 bytes)") != std::string::npos);
  Command c;
  CHECK(parse_command("vel " + huge + " 0 0", c).size() < 400);
  // Issue 28 point 8: bytes that are not UTF-8 were echoed raw; UTF-8 text stays as it is,
  // a sequence cut by the 200-byte bound too is escaped.
  CHECK(quote_line("stop \xff\xfe") == "'stop \\xff\\xfe'");
  CHECK(quote_line("caf\xc3\xa9") == "'caf\xc3\xa9'");
  CHECK(quote_line("a\xc3") == "'a\\xc3'");                 // a sequence cut short
  CHECK(quote_line("\xed\xa0\x80") == "'\\xed\\xa0\\x80'");  // a UTF-16 surrogate
  CHECK(quote_line("\xc0\xaf") == "'\\xc0\\xaf'");          // an overlong '/'
  CHECK(quote_line(std::string(199, 'x') + "\xc3\xa9").find("x\\xc3'") != std::string::npos);
  const std::string answer = parse_command("st\x80op", c);
  INFO(answer);
  CHECK(answer.find("\\x80") != std::string::npos);
  for (unsigned char ch : answer) CHECK(ch < 0x80);
}

TEST_CASE("setpoint encoding saturates and never converts a NaN", "[daemon][unit]") {
  int16_t v = 123;
  CHECK_FALSE(auger::io::setpoint_crpm(std::nan(""), v));
  CHECK(v == 0);
  v = 123;
  CHECK_FALSE(auger::io::setpoint_crpm(HUGE_VAL, v));
  CHECK(v == 0);
  CHECK_FALSE(auger::io::setpoint_crpm(-HUGE_VAL, v));
  CHECK(v == 0);
  CHECK(auger::io::setpoint_crpm(1e308, v));  // * 100 overflows to inf: still the wire's maximum
  CHECK(v == 32767);
  CHECK(auger::io::setpoint_crpm(-1e308, v));
  CHECK(v == -32767);
  CHECK(auger::io::setpoint_crpm(400, v));
  CHECK(v == 32767);
  CHECK(auger::io::setpoint_crpm(12.345, v));
  CHECK(v == 1235);  // lround: half away from zero
  CHECK(auger::io::setpoint_crpm(-0.004, v));
  CHECK(v == 0);
  CHECK(auger::io::setpoint_crpm(-327.67, v));
  CHECK(v == -32767);
}

TEST_CASE("setpoint frames: ENABLE only for a finite speed, CLEAR_FAULTS when asked", "[daemon][unit]") {
  auto decode = [](const uint8_t* buf, std::size_t n) {
    proto_parser_t p;
    proto_parser_init(&p);
    for (std::size_t i = 0; i < n; ++i) proto_parser_push(&p, buf[i]);
    proto_frame_t f;
    REQUIRE(proto_parser_pop(&p, &f));
    proto_setpoint_t sp;
    REQUIRE(proto_decode_setpoint(&f, &sp));
    return sp;
  };
  uint8_t buf[PROTO_MAX_FRAME];
  bool finite = false;
  proto_setpoint_t sp = decode(buf, auger::io::encode_setpoint(7, 400.0, true, false, buf, &finite));
  CHECK(finite);
  CHECK(sp.seq == 7);
  CHECK(sp.omega_crpm == 32767);  // the one clamp: setpoint_crpm
  CHECK(sp.flags == PROTO_SP_ENABLE);
  sp = decode(buf, auger::io::encode_setpoint(8, std::nan(""), true, true, buf, &finite));
  CHECK_FALSE(finite);
  CHECK(sp.omega_crpm == 0);
  CHECK(sp.flags == PROTO_SP_CLEAR_FAULTS);  // never ENABLE with a speed that was not finite
  sp = decode(buf, auger::io::encode_setpoint(9, -12.345, false, false, buf));
  CHECK(sp.omega_crpm == -1235);
  CHECK(sp.flags == 0);
}

TEST_CASE("module telemetry in SI units, its freshness and its log columns", "[daemon][unit]") {
  auger::io::ModuleTelemetry tm;
  auger::RobotSample row;
  auger::io::log_telemetry(tm, 2, row);  // nothing received: the row stays "not measured"
  CHECK(std::isnan(row.omega_rpm[2]));
  CHECK_FALSE(row.status[2].has_value());
  CHECK_FALSE(tm.controller_input().valid);
  proto_telemetry_t f{};
  f.omega_crpm = -12345;
  f.omega_cmd_crpm = 5000;
  f.current_ma = 1250;
  f.voltage_mv = 18500;
  f.duty_x10000 = -2500;
  f.status = 0x0102;
  f.seq_ack = 77;
  tm.take(f);
  CHECK(tm.omega_rpm() == -123.45);
  CHECK(tm.omega_cmd_rpm() == 50.0);
  CHECK(tm.controller_input().valid);
  CHECK(tm.controller_input().omega_rpm == -123.45);
  tm.fresh = false;  // the next control period without a frame: the controller predicts instead
  CHECK_FALSE(tm.controller_input().valid);
  auger::io::log_telemetry(tm, 2, row);  // the latest frame is logged, fresh or not
  CHECK(row.omega_rpm[2] == -123.45);
  CHECK(row.current_a[2] == 1.25);
  CHECK(row.voltage_v[2] == 18.5);
  CHECK(row.pwm[2] == -0.25);
  CHECK(row.status[2] == 0x0102);
  CHECK(row.seq_ack[2] == 77);
  CHECK(std::isnan(row.omega_rpm[1]));  // other modules' columns untouched
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

// The imu line's optional accelerometer fields: without them the line is what it was (no
// acceleration), with them they reach the controller's input; a bad one is refused by its name,
// and sensor_line writes what parse_sensor reads back exactly.
TEST_CASE("sensor lines: the imu's acceleration", "[daemon][unit]") {
  SensorMessage m;
  REQUIRE(parse_sensor("imu 1700000000.5 0.2 -0.1", m).empty());
  CHECK_FALSE(m.has_acc);
  auger::SensorInput in;
  to_sensor_input(m, 0, in);
  CHECK((in.has_imu_r && !in.has_imu_acc));
  REQUIRE(parse_sensor("imu 1700000000.5 0.2 -0.1 0.031 -1.5e-2", m).empty());
  CHECK(m.has_acc);
  CHECK(m.ax_mps2 == 0.031);
  CHECK(m.ay_mps2 == -0.015);
  to_sensor_input(m, 0, in);
  CHECK((in.has_imu_acc && in.imu_ax_mps2 == 0.031 && in.imu_ay_mps2 == -0.015));
  SensorMessage back;
  REQUIRE(parse_sensor(sensor_line(m), back).empty());
  CHECK((back.has_acc && back.ax_mps2 == m.ax_mps2 && back.ay_mps2 == m.ay_mps2 && back.t_unix_s == m.t_unix_s));
  m.has_acc = false;
  CHECK(sensor_line(m).find("0.031") == std::string::npos);
  const std::pair<const char*, const char*> bad[] = {
      {"imu 1 0.2 -0.1 x 0", "ax_mps2 must be a finite decimal number, got 'x'"},
      {"imu 1 0.2 -0.1 0 nan", "ay_mps2 must be a finite decimal number"},
      {"imu 1 0.2 -0.1 200 0", "ax_mps2 = 200 m/s^2 is outside -157..157"},
      {"imu 1 0.2 -0.1 0 -1e9", "ay_mps2 = -1e+09 m/s^2 is outside"},
      {"imu 1 0.2 -0.1 0", "imu takes 3 or 5 fields"},
      {"imu 1 0.2 -0.1 0 0 0", "imu takes 3 or 5 fields"}};
  for (const auto& [line, says] : bad) {
    const std::string err = parse_sensor(line, m);
    INFO(line << ": " << err);
    CHECK(err.find(says) != std::string::npos);
  }
  // An input that never was a line (ROS 2) meets the same bounds.
  SensorMessage ros;
  ros.kind = SensorKind::imu;
  ros.has_acc = true;
  ros.ax_mps2 = NAN;
  CHECK(check_sensor(ros).find("ax_mps2 must be a finite number") != std::string::npos);
}

namespace {
std::string write_tmp(const std::string& text) {
  static int n = 0;
  const std::string p = "/tmp/augerd-unit-" + std::to_string(getpid()) + "-" + std::to_string(n++) + ".toml";
  std::ofstream(p) << text;
  return p;
}
// The configuration text must be refused with a message containing `where`.
void expect_config_error(const std::string& text, const std::string& where) {
  const std::string q = write_tmp(text);
  INFO(text);
  try {
    load_daemon_config(q);
    FAIL("accepted");
  } catch (const std::exception& e) {
    INFO(e.what());
    CHECK(std::string(e.what()).find(where) != std::string::npos);
  }
  unlink(q.c_str());
}
const std::string kGood =
    "schema = 1\n"
    "[serial]\nports = [\"/dev/a\", \"/dev/b\", \"/dev/c\", \"/dev/d\"]\n"
    "[model]\nfile = \"" AUGER_SOURCE_DIR "/models/robot.toml\"\nterrain = \"frozen_grass\"\n"
    "[control]\nallocator = \"pinv\"\nomega_max_rpm = 20\nkp = [1, 2, 3]\n"
    "[sockets]\ncommands = \"c.sock\"\nsensors = \"/run/s.sock\"\n"
    "[log]\ndir = \"/tmp\"\n";
// text with its first `from` replaced by `to`
std::string replace(std::string text, const std::string& from, const std::string& to) {
  return text.replace(text.find(from), from.size(), to);
}
}  // namespace

TEST_CASE("configuration errors never quote megabytes of the file", "[daemon][unit]") {
  // Issue 28 point 8: a 5 MB key or string came back whole in the error message.
  const std::string big(5u << 20, 'k');
  for (const std::string& text : {kGood + big + " = 1\n", kGood + "[ros2]\ncmd_vel_topic = \"/" + big + "\"\n",
                                  kGood + "extra\xff\xfe = 1\n"}) {
    const std::string p = write_tmp(text);
    try {
      load_daemon_config(p);
      FAIL("accepted");
    } catch (const auger::ConfigError& e) {
      const std::string what = e.what();
      INFO(what.substr(0, 600));
      CHECK(what.size() < 600);
      CHECK(what.rfind(p + ":1", 0) == 0);
      for (unsigned char ch : what) CHECK((ch >= 0x20 && ch < 0x7f));
      if (text.size() > big.size()) CHECK(what.find("bytes, cut: see the file at line") != std::string::npos);
    }
    unlink(p.c_str());
  }
}

TEST_CASE("configuration file", "[daemon][unit]") {
  const std::string p = write_tmp(kGood);
  const DaemonConfig c = load_daemon_config(p);
  CHECK(c.ports[2] == "/dev/c");
  CHECK(c.baud == 250000);
  CHECK(c.terrain == "frozen_grass");
  // The model file's contents as read for the controller's settings: augerd builds from these.
  REQUIRE(c.model.find_terrain("frozen_grass") != nullptr);
  CHECK(c.model.find_terrain("frozen_grass")->params.sigma_long == 0.4);
  CHECK(c.controller.allocator.kind == auger::AllocatorKind::pseudo_inverse);
  CHECK(c.controller.allocator.omega_max_rpm == 20);
  CHECK(c.controller.gains.kp[2] == 3);
  CHECK(c.commands_socket == "/tmp/c.sock");  // relative to the file
  CHECK(c.sensors_socket == "/run/s.sock");
  CHECK_FALSE(c.log_mcap);
  CHECK_FALSE(c.controller.effect_feedforward);  // off unless asked for: today's controller
  unlink(p.c_str());
  {
    const std::string ff = write_tmp(replace(kGood, "kp = [1, 2, 3]\n", "kp = [1, 2, 3]\neffect_feedforward = true\n"));
    CHECK(load_daemon_config(ff).controller.effect_feedforward);
    unlink(ff.c_str());
  }
  {
    const std::string with_mcap = write_tmp(kGood + "mcap = true\n");  // the last table is [log]
    CHECK(load_daemon_config(with_mcap).log_mcap);
    unlink(with_mcap.c_str());
  }

  struct Bad {
    std::string text, where;
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
                       Bad{kGood + "mcap = 1\n", ":16:8: 'mcap' must be true or false"},
                       Bad{replace(kGood, "kp = [1, 2, 3]", "effect_feedforward = \"on\""), ":10:22: 'effect_feedforward' must be true or false"},
                       Bad{replace(kGood, "models/robot.toml", "models/none.toml"), "none.toml"}}) {
    expect_config_error(b.text, b.where);
  }
}

TEST_CASE("configuration: [online] is off by default; its keys and errors", "[daemon][unit]") {
  const std::string p = write_tmp(kGood);
  CHECK_FALSE(load_daemon_config(p).online.enabled);
  CHECK_FALSE(load_daemon_config(p).online_apply);
  unlink(p.c_str());
  const std::string on = write_tmp(kGood + "[online]\nenabled = true\nvelocity_sd = [0.001, 0.001, 0.003]\n"
                                           "cusum_threshold = 20\napply = true\n");
  const DaemonConfig c = load_daemon_config(on);
  unlink(on.c_str());
  CHECK(c.online.enabled);
  CHECK(c.online.velocity_sd[2] == 0.003);
  CHECK(c.online.cusum_threshold == 20);
  CHECK(c.online_apply);
  expect_config_error(kGood + "[online]\nenabled = 1\n", ":17:11: 'enabled' must be true or false");
  expect_config_error(kGood + "[online]\nforgetting = 0.9\n", ":17:");
  expect_config_error(kGood + "[online]\nvelocity_sd = [0, 0.1, 0.1]\n", ":17:");
  // The model-free velocity and the held drag (docs/daemon.md "Online identification").
  CHECK_FALSE(c.online_kinematic);
  const std::string kin = write_tmp(kGood + "[online]\nenabled = true\nvelocity = \"kinematic\"\ndrag_prior_rel_sd = 0.01\n"
                                                 "slow_screw_rpm = 2\nslow_screw_guard_s = 0.05\ndetect_memory_s = 1\n");
  const DaemonConfig k = load_daemon_config(kin);
  unlink(kin.c_str());
  CHECK(k.online_kinematic);
  CHECK(k.online.drag_prior_rel_sd == 0.01);
  CHECK(k.online.slow_screw_rpm == 2.0);
  CHECK(k.online.slow_screw_guard_s == 0.05);
  CHECK(k.online.detect_memory_s == 1.0);
  CHECK(c.online.detect_memory_s == 0.0);  // off unless asked for
  // The kinematic filter's accelerometer: on with the sample's values unless the keys say otherwise.
  CHECK(k.online_kin.use_accelerometer);
  CHECK(k.online_kin.acc_noise_mps2_per_sqrt_hz == 1.5e-3);
  const std::string acc = write_tmp(kGood + "[online]\naccelerometer = false\nacc_noise_mps2_per_sqrt_hz = 0.003\n"
                                            "acc_bias_walk_mps2_per_sqrt_s = 0.001\nacc_bias_sd_mps2 = 0.2\n"
                                            "camera_noise_corr_s = 0.3\nacc_gravity_walk_mps2_per_sqrt_s = 0.002\n");
  const DaemonConfig a = load_daemon_config(acc);
  unlink(acc.c_str());
  CHECK_FALSE(a.online_kin.use_accelerometer);
  CHECK(a.online_kin.acc_noise_mps2_per_sqrt_hz == 0.003);
  CHECK(a.online_kin.acc_bias_walk_mps2_per_sqrt_s == 0.001);
  CHECK(a.online_kin.acc_bias_sd_mps2 == 0.2);
  CHECK(a.online_kin.pose_noise_corr_s == 0.3);
  CHECK(a.online_kin.acc_gravity_walk_mps2_per_sqrt_s == 0.002);
  expect_config_error(kGood + "[online]\nacc_noise_mps2_per_sqrt_hz = 0\n", ":17:");
  expect_config_error(kGood + "[online]\naccelerometer = \"yes\"\n", ":17:");
  expect_config_error(kGood + "[online]\nvelocity = \"camera\"\n", ":17:12: velocity must be \"ekf\" or \"kinematic\"");
  expect_config_error(kGood + "[online]\ndrag_prior_rel_sd = 0\n", ":17:");
  expect_config_error(kGood + "[online]\nslow_screw_rpm = -1\n", ":17:");
  expect_config_error(kGood + "[online]\nslow_screw_guard_s = 1\n", ":17:");
  expect_config_error(kGood + "[online]\ndetect_memory_s = -1\n", ":17:");
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

TEST_CASE("configuration: related values are ordered, socket modes and groups explicit", "[daemon][unit]") {
  struct Bad {
    std::string text, where;
  };
  const char* group_name = nullptr;
  if (const struct group* g = getgrgid(getegid())) group_name = g->gr_name;
  REQUIRE(group_name);
  {
    const std::string p = write_tmp(replace(kGood, "sensors = \"/run/s.sock\"\n",
                                            "sensors = \"/run/s.sock\"\nsensors_mode = 0o620\nsensors_group = \"" +
                                                std::string(group_name) + "\"\nidle_timeout_s = 2\n"));
    const DaemonConfig c = load_daemon_config(p);
    CHECK(c.sensors_mode == 0620);
    CHECK(c.commands_mode == 0660);  // the default, whatever the umask
    CHECK(c.sensors_group == group_name);
    CHECK(socket_gid(c.sensors_group) == long(getegid()));
    CHECK(socket_gid(c.commands_group) == -1);  // none given: augerd's own
    CHECK_FALSE(socket_gid("no-such-group-x"));
    CHECK(c.idle_timeout_s == 2);
    unlink(p.c_str());
  }
  for (const Bad& b :
       {Bad{replace(kGood, "omega_max_rpm = 20", "omega_max_rpm = 20\nomega_min_rpm = 25"),
            ":10:1: omega_min_rpm = 25 (" },
        Bad{replace(kGood, "omega_max_rpm = 20", "omega_max_rpm = 2"), "is above omega_max_rpm = 2"},
        Bad{replace(replace(kGood, "[serial]", "[serial]\ntelemetry_timeout_s = 0.03"), "[control]",
                    "[control]\nperiod_s = 0.02"),
            ":3:1: telemetry_timeout_s = 0.03 is shorter than two loop periods"},
        Bad{replace(kGood, "sensors = \"/run/s.sock\"", "sensors = \"/run/s.sock\"\nsensors_mode = 0o666"),
            ":14:16: 'sensors_mode' must not let every user write"},
        Bad{replace(kGood, "sensors = \"/run/s.sock\"", "sensors = \"/run/s.sock\"\ncommands_mode = 0o060"),
            "'commands_mode' must give augerd's user read and write"},
        Bad{replace(kGood, "sensors = \"/run/s.sock\"", "sensors = \"/run/s.sock\"\nsensors_group = 7"),
            ":14:17: 'sensors_group' must be a string"}}) {
    expect_config_error(b.text, b.where);
  }
}

TEST_CASE("start-up checks: what augerd --check must catch before anything is opened", "[daemon][unit]") {
  char templ[] = "/tmp/augerd-startup-XXXXXX";
  REQUIRE(mkdtemp(templ));
  const std::string d = templ;
  REQUIRE(mkdir((d + "/log").c_str(), 0755) == 0);
  std::ofstream(d + "/regular") << "not a port\n";
  const Ptys ptys(4);  // ttys, as serial ports are
  DaemonConfig c;
  c.ports = {ptys.names[0], ptys.names[1], ptys.names[2], ptys.names[3]};
  c.log_dir = d + "/log";
  c.commands_socket = d + "/c.sock";
  c.sensors_socket = d + "/s.sock";
  CHECK(check_startup(c).empty());

  auto problems = [&](const DaemonConfig& x) {
    std::string all;
    bool final = false;
    for (const auto& p : check_startup(x)) all += p.text + "\n", final |= p.final;
    return std::make_pair(final, all);
  };
  DaemonConfig x = c;
  x.ports[1] = d + "/ttyUSB9";  // missing: may appear (unplugged module), not final
  auto r = problems(x);
  CHECK_FALSE(r.first);
  CHECK(r.second.find(d + "/ttyUSB9 does not exist") != std::string::npos);
  x = c;
  x.ports[2] = d + "/regular";
  r = problems(x);
  CHECK(r.first);
  CHECK(r.second.find("is not a character device") != std::string::npos);
  // A character device that is no tty (issue 28): /dev/zero would be read as endless zeros.
  x = c;
  x.ports[3] = "/dev/zero";
  r = problems(x);
  CHECK(r.first);
  CHECK(r.second.find("serial port /dev/zero is not a serial port or a pty (character device 1:5") != std::string::npos);
  // Two names of one device (a udev symlink beside its target): two modules on one port.
  REQUIRE(symlink(ptys.names[0].c_str(), (d + "/ttyAlias").c_str()) == 0);
  x = c;
  x.ports[2] = d + "/ttyAlias";
  r = problems(x);
  CHECK(r.first);
  CHECK(r.second.find("serial ports " + ptys.names[0] + " and " + d + "/ttyAlias are the same device") !=
        std::string::npos);
  // A pseudo filesystem as log directory: root passes access(), nothing can be written there.
  x = c;
  x.log_dir = "/proc";
  r = problems(x);
  CHECK(r.first);
  CHECK(r.second.find("log directory /proc is on the proc pseudo filesystem") != std::string::npos);
  x = c;
  x.log_dir = d + "/nolog";
  r = problems(x);
  CHECK(r.first);
  CHECK(r.second.find("log directory " + d + "/nolog does not exist") != std::string::npos);
  x = c;
  x.log_dir = d + "/regular";
  CHECK(problems(x).second.find("is not a directory") != std::string::npos);
  x = c;
  x.commands_socket = d + "/regular";
  r = problems(x);
  CHECK(r.first);
  CHECK(r.second.find("exists and is not a socket") != std::string::npos);
  x = c;
  x.sensors_socket = d + "/./log/../c.sock";  // the same file spelled otherwise
  CHECK(problems(x).second.find("are the same file") != std::string::npos);
  x = c;
  x.sensors_socket = d + "/nodir/s.sock";
  CHECK(problems(x).second.find("directory " + d + "/nodir does not exist") != std::string::npos);
  x = c;
  x.path = "/etc/auger/augerd.toml";
  x.sensors_group = "no-such-group-x";
  x.line_sensors_group = 17;
  r = problems(x);
  CHECK(r.first);  // the group must be created (sysusers) before augerd can start
  CHECK(r.second.find("/etc/auger/augerd.toml:17: sensors_group: no group named 'no-such-group-x'") != std::string::npos);
  std::error_code ec;
  std::filesystem::remove_all(d, ec);
}
