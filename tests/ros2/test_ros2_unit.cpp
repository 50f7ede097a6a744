// augerd's ROS 2 interface, the parts without DDS: ROS 2's name rules, the conversions between
// ROS messages' conventions and augerd's quantities, and the [ros2] configuration section.
#include <catch2/catch.hpp>

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "config.hpp"
#include "convert.hpp"
#include "diagnostics.hpp"
#include "ros2.hpp"
#include "ros2_keys.hpp"

using namespace auger::ros2;

TEST_CASE("ROS 2 topic names map to DDS topics", "[ros2][unit]") {
  CHECK(dds_topic_name(fully_qualified_name("odom", "")) == "rt/odom");
  CHECK(dds_topic_name(fully_qualified_name("odom", "/")) == "rt/odom");
  CHECK(dds_topic_name(fully_qualified_name("odom", "/robot1")) == "rt/robot1/odom");
  CHECK(dds_topic_name(fully_qualified_name("odom", "robot1")) == "rt/robot1/odom");
  CHECK(dds_topic_name(fully_qualified_name("imu/data", "/a/b")) == "rt/a/b/imu/data");
  CHECK(dds_topic_name(fully_qualified_name("/diagnostics", "/robot1")) == "rt/diagnostics");
  CHECK(dds_topic_name(fully_qualified_name("cmd_vel_keyboard", "")) == "rt/cmd_vel_keyboard");
  struct Bad {
    std::string name, ns, why;
  };
  for (const Bad& b : {Bad{"", "", "empty"}, Bad{"/", "", "empty"}, Bad{"odom/", "", "end with '/'"},
                       Bad{"a//b", "", "repeated '/'"}, Bad{"a__b", "", "repeated '_'"},
                       Bad{"2odom", "", "starting with a digit"}, Bad{"a/2b", "", "starting with a digit"},
                       Bad{"odom", "/2robot", "starting with a digit"}, Bad{"od-om", "", "character '-' at 3"},
                       Bad{"odom", "/ro bot", "character ' '"}, Bad{"~/odom", "", "substitution"},
                       Bad{"{node}/odom", "", "substitution"}, Bad{std::string(260, 'a'), "", "too long"}}) {
    INFO(b.name << " in " << b.ns);
    try {
      fully_qualified_name(b.name, b.ns);
      FAIL("accepted");
    } catch (const std::invalid_argument& e) {
      CHECK(std::string(e.what()).find(b.why) != std::string::npos);
    }
  }
}

TEST_CASE("ROS 2 message conventions", "[ros2][unit]") {
  int32_t sec;
  uint32_t ns;
  unix_s_to_stamp(1795481377.757133484, sec, ns);
  CHECK(sec == 1795481377);
  CHECK(std::abs(int64_t(ns) - 757133484) < 300);  // a double holds ~0.24 us at 1.8e9 s
  unix_s_to_stamp(10.9999999999, sec, ns);  // rounding up into the next second
  CHECK((sec == 11 && ns == 0));
  CHECK(stamp_to_unix_s(12, 500000000) == 12.5);

  std::string why;
  double yaw = 0, q[4];
  for (double psi : {0.0, 0.3, -2.0, 3.1}) {
    quaternion_from_yaw(psi, q);
    REQUIRE(yaw_from_quaternion(q[0], q[1], q[2], q[3], yaw, why));
    CHECK(yaw == Approx(psi).margin(1e-12));
  }
  // Yaw of a tilted robot (roll 0.2 rad, then yaw 0.7 rad, z-y-x): still 0.7.
  const double cy = std::cos(0.35), sy = std::sin(0.35), cr = std::cos(0.1), sr = std::sin(0.1);
  REQUIRE(yaw_from_quaternion(sr * cy, sr * sy, cr * sy, cr * cy, yaw, why));
  CHECK(yaw == Approx(0.7).margin(1e-12));
  // Slightly off unit norm is normalised; far off or non-finite is refused.
  REQUIRE(yaw_from_quaternion(0, 0, 1.05 * std::sin(0.2), 1.05 * std::cos(0.2), yaw, why));
  CHECK(yaw == Approx(0.4).margin(1e-12));
  CHECK_FALSE(yaw_from_quaternion(0, 0, 0, 0, yaw, why));
  CHECK(why.find("not a unit quaternion") != std::string::npos);
  CHECK_FALSE(yaw_from_quaternion(0, 0, NAN, 1, yaw, why));

  // The estimator's [x, y, psi, u, v, r] covariance into Odometry's pose and twist blocks.
  double cov[36], pose[36], twist[36];
  for (int i = 0; i < 36; ++i) cov[i] = 100 + i;  // entry (r, c) = 100 + 6 r + c
  odometry_covariance(cov, pose, twist);
  CHECK(pose[0] == 100);            // x x
  CHECK(pose[1] == 101);            // x y
  CHECK(pose[5] == 102);            // x psi -> (x, rot Z)
  CHECK(pose[6 * 5 + 5] == 114);    // psi psi
  CHECK(pose[6 * 5 + 1] == 113);    // psi y
  CHECK(twist[0] == 121);           // u u
  CHECK(twist[6 * 1 + 5] == 129);   // v r -> (vy, wz)
  CHECK(twist[6 * 5 + 5] == 135);   // r r
  for (int k : {2, 3, 4}) {
    CHECK(pose[7 * k] == kNotEstimatedVariance);
    CHECK(twist[7 * k] == kNotEstimatedVariance);
    CHECK(pose[6 * k] == 0);        // no correlation with what is not estimated
  }
}

namespace {
std::string write_tmp(const std::string& text) {
  static int n = 0;
  const std::string p = "/tmp/augerd-ros2-unit-" + std::to_string(getpid()) + "-" + std::to_string(n++) + ".toml";
  std::ofstream(p) << text;
  return p;
}
const std::string kBase =
    "schema = 1\n"
    "[serial]\nports = [\"/dev/a\", \"/dev/b\", \"/dev/c\", \"/dev/d\"]\n"
    "[model]\nfile = \"" AUGER_SOURCE_DIR "/models/robot.toml\"\n"
    "[sockets]\ncommands = \"c.sock\"\nsensors = \"s.sock\"\n"
    "[log]\ndir = \"/tmp\"\n";
}  // namespace

TEST_CASE("the [ros2] configuration section", "[ros2][unit]") {
  {
    const std::string p = write_tmp(kBase);
    const augerd::DaemonConfig c = augerd::load_daemon_config(p);
    CHECK_FALSE(c.ros2.enabled);  // off unless asked for
    CHECK(c.ros2.cmd_vel_topic == "cmd_vel");
    CHECK(c.ros2.odom_rate_hz == 50);
    CHECK(c.ros2.online_topic == "online_estimate");
    CHECK(c.ros2.online_rate_hz == 10);
    unlink(p.c_str());
  }
  {
    const std::string p = write_tmp(kBase +
                                    "[ros2]\nenabled = false\ndomain_id = 42\nnamespace = \"/robot1\"\n"
                                    "cmd_vel_topic = \"/cmd_vel_keyboard\"\nimu_topic = \"bno080_imu\"\n"
                                    "pose_std = [0.01, 0.02, 0.03]\ntf = false\ndds_config = \"dds.xml\"\n"
                                    "joint_names = [\"a\", \"b\", \"c\", \"d\"]\nodom_rate_hz = 20\n"
                                    "online_topic = \"terrain\"\nonline_rate_hz = 5\n");
    const augerd::DaemonConfig c = augerd::load_daemon_config(p);
    CHECK(c.ros2.domain_id == 42);
    CHECK(c.ros2.ns == "/robot1");
    CHECK(c.ros2.cmd_vel_topic == "/cmd_vel_keyboard");
    CHECK(c.ros2.imu_topic == "bno080_imu");
    CHECK(c.ros2.pose_std[1] == 0.02);
    CHECK_FALSE(c.ros2.tf);
    CHECK(c.ros2.dds_config == "/tmp/dds.xml");  // relative to the file
    CHECK(c.ros2.joint_names[3] == "d");
    CHECK(c.ros2.odom_rate_hz == 20);
    CHECK(c.ros2.online_topic == "terrain");
    CHECK(c.ros2.online_rate_hz == 5);
    unlink(p.c_str());
  }
  struct Bad {
    std::string text, where;
  };
  const int l = 11;  // the line of [ros2]
  for (const Bad& b : {Bad{"[ros2]\ndomain_id = 233\n", ":" + std::to_string(l + 1) + ":13: 'domain_id' = 233 is outside 0..232"},
                       Bad{"[ros2]\ndomain_id = 1.5\n", "whole number"},
                       Bad{"[ros2]\nodom_topic = \"od-om\"\n", ":" + std::to_string(l + 1) + ":14: ROS 2 name 'od-om' has the character '-'"},
                       Bad{"[ros2]\nodom_topic = \"\"\n", "is empty"},
                       Bad{"[ros2]\nnamespace = \"/a//b\"\n", "repeated '/'"},
                       Bad{"[ros2]\nodom_frame = \"base_link\"\n", "must differ"},
                       Bad{"[ros2]\nbase_frame = \"base link\"\n", "space"},
                       Bad{"[ros2]\nodom_rate_hz = 200\n", "outside 0..100"},
                       Bad{"[ros2]\nonline_rate_hz = 200\n", ":" + std::to_string(l + 1) + ":18: 'online_rate_hz' = 200 is outside 0..100"},
                       Bad{"[ros2]\nonline_topic = \"on line\"\n", ":" + std::to_string(l + 1) + ":16: ROS 2 name 'on line' has the character ' '"},
                       Bad{"[ros2]\nenabled = 1\n", "true or false"},
                       // The sensors socket's bounds (input_limits.hpp): 20 rad would refuse every pose.
                       Bad{"[ros2]\npose_std = [0.01, 0.01, 20]\n", "pose_std[2] = 20 rad is outside 1e-06..10 rad"},
                       Bad{"[ros2]\nqos = \"fast\"\n", "unknown key 'qos' in [ros2]"},
                       // Who may command the robot is stated (issue 28): keys, or insecure said aloud.
                       Bad{"[ros2]\nenabled = true\ndomain_id = 7\n",
                           ":" + std::to_string(l + 1) + ":11: [ros2] enabled without DDS Security: give 'keystore' "
                           "(made by `auger ros2-keys create`), or 'insecure = true' to let anyone who reaches DDS "
                           "domain 7 command the robot"},
                       Bad{"[ros2]\nkeystore = \"k\"\ninsecure = true\n",
                           ":" + std::to_string(l + 2) + ":12: 'insecure = true' and 'keystore' contradict"},
                       Bad{"[ros2]\nlocal_priority_s = -1\n", "'local_priority_s' = -1 is outside 0..60"}}) {
    const std::string q = write_tmp(kBase + b.text);
    INFO(b.text);
    try {
      augerd::load_daemon_config(q);
      FAIL("accepted");
    } catch (const std::exception& e) {
      INFO(e.what());
      CHECK(std::string(e.what()).find(b.where) != std::string::npos);
    }
    unlink(q.c_str());
  }
  {
    const std::string p = write_tmp(kBase + "[ros2]\nenabled = false\nkeystore = \"keys\"\nlocal_priority_s = 0.5\n");
    const Settings r = augerd::load_daemon_config(p).ros2;
    CHECK(r.keystore == "/tmp/keys");  // relative to the file
    CHECK(r.local_priority_s == 0.5);
    CHECK_FALSE(r.insecure);
    const auto files = security_files(r);
    REQUIRE(files.size() == 6);
    CHECK(files[2].path == "/tmp/keys/enclaves/augerd/key.pem");
    CHECK(std::string(files[2].property) == "dds.sec.auth.private_key");
    unlink(p.c_str());
  }
  // enabled = true is accepted exactly when this build has the bridge.
  const std::string p = write_tmp(kBase + "[ros2]\nenabled = true\ninsecure = true\n");
  if (available()) {
    CHECK(augerd::load_daemon_config(p).ros2.enabled);
  } else {
    CHECK_THROWS_WITH(augerd::load_daemon_config(p), Catch::Contains("built without the ROS 2 interface"));
  }
  unlink(p.c_str());
}

// [ros2] dds_config as Cyclone DDS will read it (issue 28): what it would silently read as its
// defaults (open on every interface), what it refuses only at start, and DDS Security in two
// places, each a final start-up problem naming the file; then the keystore's files.
TEST_CASE("augerd --check: dds_config and the keystore", "[ros2][unit]") {
  if (!available()) return;  // built without Cyclone DDS: [ros2] enabled is refused when read
  char templ[] = "/tmp/augerd-ddscheck-XXXXXX";
  REQUIRE(mkdtemp(templ));
  const std::string d = templ;
  Settings s;
  s.enabled = true;
  s.domain_id = 37;
  s.insecure = true;
  auto problems = [&](const std::string& path) {
    s.dds_config = path;
    std::string all;
    for (const auto& x : check_dds_config(s)) all += x + "\n";
    return all;
  };
  auto file = [&](const std::string& name, const std::string& text) {
    std::ofstream(d + "/" + name) << text;
    return d + "/" + name;
  };
  const std::string lo =
      "<CycloneDDS>\n  <Domain Id=\"37\">\n    <General><Interfaces><NetworkInterface name=\"lo\"/></Interfaces>"
      "</General>\n  </Domain>\n</CycloneDDS>\n";
  CHECK(problems(file("good.xml", lo)) == "");
  CHECK(problems(file("any.xml", "<CycloneDDS><Domain Id=\"any\"/></CycloneDDS>")) == "");
  CHECK(problems(file("noid.xml", "<CycloneDDS><Domain/></CycloneDDS>")) == "");
  struct Bad {
    std::string path, message;
  };
  const std::string silently = "Cyclone DDS would silently run on its defaults";
  for (const Bad& b :
       {Bad{d + "/missing.xml", "dds_config " + d + "/missing.xml: No such file or directory"},
        Bad{d, "dds_config " + d + " is a directory, not a Cyclone DDS XML file: " + silently},
        Bad{"/dev/null", "dds_config /dev/null is not a regular file (a device or a pipe): " + silently},
        Bad{file("empty.xml", ""), "empty.xml is empty: " + silently},
        Bad{file("text.xml", "interfaces: lo\n"), "text.xml:1: [ros2] dds_config is not well-formed XML"},
        Bad{file("open.xml", "<CycloneDDS>\n<Domain>\n"), "open.xml:3: [ros2] dds_config is not well-formed XML"},
        Bad{file("root.xml", "<Cyclone><Domain/></Cyclone>"), "the root element is <Cyclone>, not <CycloneDDS>"},
        Bad{file("other.xml", "<CycloneDDS><Domain Id=\"3\"/></CycloneDDS>"),
            "has no <Domain> for domain 37 (Id=\"any\" or Id=\"37\"): " + silently},
        Bad{file("sec.xml", "<CycloneDDS>\n<Domain>\n<Security/>\n</Domain></CycloneDDS>"),
            "sec.xml:3: [ros2] dds_config has a <Security> section: augerd's DDS Security comes from [ros2] keystore"},
        Bad{file("bogus.xml", "<CycloneDDS><Domain><General><Bogus>1</Bogus></General></Domain></CycloneDDS>"),
            "bogus.xml: Cyclone DDS refuses it"},
        Bad{file("a,b.xml", lo), "has a ',', which Cyclone DDS reads as a separator"}}) {
    INFO(b.path);
    const std::string all = problems(b.path);
    CHECK(all.find(b.message) != std::string::npos);
    CHECK(std::count(all.begin(), all.end(), '\n') == 1);
  }
  s.enabled = false;  // nothing is checked of what is not used
  CHECK(problems(d + "/missing.xml") == "");

  // The keystore through augerd's start-up check: missing, then present but its key readable by all.
  augerd::DaemonConfig c;
  c.log_dir = d;
  c.commands_socket = d + "/c.sock";
  c.sensors_socket = d + "/s.sock";
  c.ports = {"/nonexistent/0", "/nonexistent/1", "/nonexistent/2", "/nonexistent/3"};  // not final
  c.ros2.enabled = true;
  c.ros2.keystore = d + "/keys";
  auto final_problems = [&] {
    std::string all;
    for (const auto& x : augerd::check_startup(c))
      if (x.final) all += x.text + "\n";
    return all;
  };
  CHECK(final_problems().find("[ros2] keystore " + d + "/keys has no enclave augerd") != std::string::npos);
  const std::string e = d + "/keys/enclaves/augerd";
  std::filesystem::create_directories(e);
  for (const auto& f : security_files(c.ros2)) std::ofstream(f.path) << "x";
  chmod((e + "/key.pem").c_str(), 0644);
  CHECK(final_problems().find(e + "/key.pem is readable by every user") != std::string::npos);
  chmod((e + "/key.pem").c_str(), 0600);
  CHECK(final_problems() == "");
  unlink((e + "/cert.pem").c_str());
  CHECK(final_problems().find(e + "/cert.pem: No such file or directory") != std::string::npos);
  std::filesystem::remove_all(d);
}

// What augerd's permissions allow (auger ros2-keys): exactly its topics under its settings.
TEST_CASE("the keystore's permissions: augerd's topics, nothing else", "[ros2][unit]") {
  Settings s;
  s.ns = "/robot1";
  s.pose_topic = "/camera/pose";
  s.joint_states_rate_hz = 0;  // not published: not allowed
  CHECK(input_topics(s) == std::vector<std::string>{"/robot1/cmd_vel", "/camera/pose"});
  CHECK(output_topics(s) == std::vector<std::string>{"/robot1/odom", "/tf", "/diagnostics", "/robot1/online_estimate"});
  const std::string x = auger::ros2_keys::permissions_xml("augerd", "CN=augerd", 5, {"rt/robot1/odom"},
                                                          {"rt/robot1/cmd_vel"}, 0, 86400);
  CHECK(x.find("<subject_name>CN=augerd</subject_name>") != std::string::npos);
  CHECK(x.find("<domains><id>5</id></domains>") != std::string::npos);
  CHECK(x.find("<not_before>1970-01-01T00:00:00</not_before>") != std::string::npos);
  CHECK(x.find("<not_after>1970-01-02T00:00:00</not_after>") != std::string::npos);
  const auto pub = x.find("<publish>"), sub = x.find("<subscribe>");
  REQUIRE(pub != std::string::npos);
  REQUIRE(sub != std::string::npos);
  CHECK(x.find("rt/robot1/odom", pub) < sub);
  CHECK(x.find("rt/robot1/cmd_vel", sub) != std::string::npos);
  CHECK(x.find("<default>DENY</default>") != std::string::npos);
  const std::string g = auger::ros2_keys::governance_xml(5);
  CHECK(g.find("<allow_unauthenticated_participants>false</allow_unauthenticated_participants>") != std::string::npos);
  CHECK(g.find("<data_protection_kind>ENCRYPT</data_protection_kind>") != std::string::npos);
  // A name goes into a certificate subject (/CN=NAME): nothing that adds a field or an option.
  CHECK(auger::ros2_keys::check_name("operator_1").empty());
  for (const char* bad : {"", "a/b", "CN=x", "-x", "1a", "a b", "ä"}) CHECK_FALSE(auger::ros2_keys::check_name(bad).empty());
}

// The diagnostics as a subscriber reads them (diagnostics.hpp): the modules', the controller's and,
// with [online], the online estimator's, WARN while its fallback is latched; the estimate topic's
// data in its documented layout.
TEST_CASE("the /diagnostics entries and the online estimate's data", "[ros2][unit]") {
  Snapshot s;
  s.module[2].answering = true;
  s.module[2].status = 0x0001;
  s.module[2].pwm = 0.25;
  std::vector<DiagnosticEntry> d = diagnostics(s, 0);
  REQUIRE(d.size() == 5);  // without [online]: no estimator entry
  CHECK(d[4].name == "augerd: controller");
  const auto value = [](const DiagnosticEntry& e, const std::string& key) {
    for (const auto& [k, v] : e.kv)
      if (k == key) return v;
    FAIL("no key " << key << " in " << e.name);
    return std::string();
  };
  CHECK(d[0].level == 3);  // not answering: STALE
  CHECK(value(d[2], "status") == "0x0001");  // the status word, not the pwm formatted after it
  CHECK(value(d[2], "pwm") == "0.2500");

  OnlineSnapshot& o = s.online;
  o.enabled = true;
  const double v[5] = {0.4396, 0.247, 560.33, 320.08, 11.46}, sd[5] = {0.012, 0.1, 5.6, 3.2, 0.11};
  for (int k = 0; k < 5; ++k) o.value[k] = v[k], o.sd[k] = sd[k], o.held[k] = k >= 2;
  o.cusum = 3.5, o.cusum_threshold = 40, o.changes = 2;
  std::snprintf(o.believed.data(), o.believed.size(), "frozen_grass");
  std::snprintf(o.basis.data(), o.basis.size(), "sigma / D (D held)");
  d = diagnostics(s, 0);
  REQUIRE(d.size() == 6);
  const DiagnosticEntry& e = d[5];
  CHECK(e.name == "augerd: online estimator");
  CHECK(e.level == 0);
  CHECK(e.message == "ground believed: frozen_grass");
  CHECK(value(e, "believed_terrain") == "frozen_grass");
  CHECK(value(e, "believed_by") == "sigma / D (D held)");
  CHECK(value(e, "sigma_long") == "0.4396 N/rpm");
  CHECK(value(e, "sigma_long_sd") == "0.012 N/rpm");
  CHECK(value(e, "D_x") == "560.3 N/(m/s) (held)");
  CHECK(value(e, "D_psi_sd") == "0.11 N m/(rad/s)");
  CHECK(value(e, "cusum") == "3.5");
  CHECK(value(e, "cusum_threshold") == "40");
  CHECK(value(e, "changes") == "2");
  CHECK(value(e, "fallback") == "none");
  // An effect's parameter marked online: its value and SD with the unit.
  o.effects = 1;
  o.effect_value[0] = 0.0791, o.effect_sd[0] = 0.00075;
  std::snprintf(o.effect_name[0].data(), o.effect_name[0].size(), "terrain_slope.incline_x_rad");
  std::snprintf(o.effect_unit[0].data(), o.effect_unit[0].size(), "rad");
  d = diagnostics(s, 0);
  CHECK(value(d[5], "terrain_slope.incline_x_rad") == "0.0791 rad");
  CHECK(value(d[5], "terrain_slope.incline_x_rad_sd") == "0.00075 rad");
  std::snprintf(o.fallback.data(), o.fallback.size(), "a parameter stayed at its physical bound");
  d = diagnostics(s, 0);
  CHECK(d[5].level == 1);  // WARN, never ERROR: the robot drives on with the configured terrain
  CHECK(d[5].message == "fallback to the configured terrain (a parameter stayed at its physical bound)");
  CHECK(value(d[5], "fallback") == "a parameter stayed at its physical bound");

  double data[kOnlineParams * kOnlineColumns];
  online_estimate_data(o, data);
  for (int k = 0; k < 5; ++k) {
    CHECK(data[2 * k] == v[k]);
    CHECK(data[2 * k + 1] == sd[k]);
  }
}
