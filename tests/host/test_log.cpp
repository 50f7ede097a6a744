// Log reader/writer (docs/log-format.md): round trips and errors with file, line and column.
#include <catch2/catch.hpp>

#include <cmath>
#include <sstream>

#include "auger/log.hpp"

using namespace auger;

namespace {
bool same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

template <class F>
LogError log_error(F&& f) {
  try {
    f();
  } catch (const LogError& e) {
    return e;
  }
  FAIL("no LogError thrown");
  return LogError("", 0, 0, "");
}
}  // namespace

TEST_CASE("robot log round trip keeps every value, NaN as not measured, metadata and extras") {
  std::stringstream ss;
  std::vector<RobotSample> written;
  {
    RobotLogWriter w(ss, {{"terrain", "sand"}, {"t0_unix_s", "1700000000.25"}}, {"note_x"});
    for (int k = 0; k < 50; ++k) {
      RobotSample s;
      s.t_s = 0.01 * k + 1e-13 * k;  // not round in decimal: tests the shortest round-trip form
      for (int i = 0; i < 4; ++i) {
        s.omega_rpm[static_cast<std::size_t>(i)] = std::sin(k + i) * 23.0;
        s.cmd_rpm[static_cast<std::size_t>(i)] = (k % 3 == 0) ? kNotMeasured : 1.0 / (i + 3);
        s.status[static_cast<std::size_t>(i)] = k % 2 ? std::optional<std::int64_t>(k * 7 + i) : std::nullopt;
        s.seq_ack[static_cast<std::size_t>(i)] = 1000000000LL + k;
      }
      if (k % 10 == 0) s.x_m = 0.1 * k, s.y_m = -1e-7 * k, s.psi_rad = -3.14159;
      s.imu_r_radps = k % 4 ? 0.001 * k : kNotMeasured;
      s.loop_dt_s = 0.0100003;
      if (k % 3) s.imu_ax_mps2 = 0.0123 * k, s.imu_ay_mps2 = -1.0 / (k + 7);
      w.write(s, {k % 5 ? double(k) : kNotMeasured});
      written.push_back(s);
    }
  }
  std::string text = ss.str();
  REQUIRE(text.rfind("# format: auger-robot-log v1\n# terrain: sand\n", 0) == 0);  // metadata first
  RobotLogReader r(ss, "mem.csv");
  CHECK(r.csv().meta("format") == std::string(kRobotLogFormat));
  CHECK(r.csv().meta("t0_unix_s") == std::string("1700000000.25"));
  REQUIRE(r.extra_columns().size() == 1);
  RobotSample s;
  std::size_t n = 0;
  while (r.next(s)) {
    const RobotSample& e = written[n];
    CHECK(same(s.t_s, e.t_s));
    for (std::size_t i = 0; i < 4; ++i) {
      CHECK(same(s.omega_rpm[i], e.omega_rpm[i]));
      CHECK(same(s.cmd_rpm[i], e.cmd_rpm[i]));
      CHECK(same(s.current_a[i], e.current_a[i]));
      CHECK(s.status[i] == e.status[i]);
      CHECK(s.seq_ack[i] == e.seq_ack[i]);
    }
    CHECK(same(s.x_m, e.x_m));
    CHECK(same(s.y_m, e.y_m));
    CHECK(same(s.psi_rad, e.psi_rad));
    CHECK(same(s.imu_r_radps, e.imu_r_radps));
    CHECK(same(s.loop_dt_s, e.loop_dt_s));
    CHECK(same(s.imu_ax_mps2, e.imu_ax_mps2));
    CHECK(same(s.imu_ay_mps2, e.imu_ay_mps2));
    CHECK(same(r.csv().value(r.extra_columns()[0]), n % 5 ? double(n) : kNotMeasured));
    ++n;
  }
  CHECK(n == written.size());
}

TEST_CASE("robot log from another program: free order, unknown columns, nan, CRLF, comments") {
  std::stringstream ss;
  ss << "\xEF\xBB\xBF# format: auger-robot-log v1\r\n"
        "# a free note\r\n"
        "# camera: overhead 2\r\n"
        "psi_rad, comment ,omega_rpm_3,t_s,omega_rpm_0,omega_rpm_1,x_m,omega_rpm_2,y_m\r\n"
        "0.5,hello,3,0.00,0,1,,2,NaN\r\n"
        "\r\n"
        ",x y,-3, 0.01 ,+0.5,1e1,1.5,-2,2.5\r\n";
  RobotLogReader r(ss, "other.csv");
  CHECK(r.csv().meta("camera") == std::string("overhead 2"));
  CHECK_FALSE(r.csv().meta("a"));
  RobotSample s;
  REQUIRE(r.next(s));
  CHECK(s.t_s == 0.0);
  CHECK(s.omega_rpm[3] == 3);
  CHECK(s.psi_rad == 0.5);
  CHECK(std::isnan(s.x_m));
  CHECK(std::isnan(s.y_m));
  CHECK(std::isnan(s.imu_psi_rad));  // column absent
  CHECK(r.csv().field_text(r.csv().column_index("comment")) == "hello");
  REQUIRE(r.next(s));
  CHECK(s.t_s == 0.01);
  CHECK(s.omega_rpm[0] == 0.5);
  CHECK(s.omega_rpm[1] == 10);
  CHECK(std::isnan(s.psi_rad));
  CHECK(s.y_m == 2.5);
  CHECK_FALSE(r.next(s));
}

TEST_CASE("log errors name file, line, column and the offending text") {
  const std::string head = "# format: auger-robot-log v1\nt_s,omega_rpm_0,omega_rpm_1,omega_rpm_2,omega_rpm_3,x_m,y_m,psi_rad\n";
  auto read_all = [](const std::string& text) {
    std::stringstream ss(text);
    RobotLogReader r(ss, "bad.csv");
    RobotSample s;
    while (r.next(s)) {
    }
  };
  SECTION("bad number") {
    auto e = log_error([&] { read_all(head + "0,1,2,3,4,,,\n0.01,1,2,x3,4,,,\n"); });
    CHECK(e.file() == "bad.csv");
    CHECK(e.line() == 4);
    CHECK(e.column() == 10);
    CHECK_THAT(e.what(), Catch::Contains("'x3'") && Catch::Contains("omega_rpm_2") && Catch::Contains("bad.csv:4:10"));
  }
  SECTION("time not increasing") {
    auto e = log_error([&] { read_all(head + "0.5,1,2,3,4,,,\n0.5,1,2,3,4,,,\n"); });
    CHECK(e.line() == 4);
    CHECK(e.column() == 1);
    CHECK_THAT(e.what(), Catch::Contains("'0.5'") && Catch::Contains("t_s"));
  }
  SECTION("empty time") {
    CHECK(log_error([&] { read_all(head + ",1,2,3,4,,,\n"); }).line() == 3);
  }
  SECTION("field count") {
    auto e = log_error([&] { read_all(head + "0,1,2,3,4,,\n"); });
    CHECK(e.line() == 3);
    CHECK_THAT(e.what(), Catch::Contains("7 fields"));
    CHECK(log_error([&] { read_all(head + "0,1,2,3,4,,,,\n"); }).column() == 14);
  }
  SECTION("missing required column") {
    auto e = log_error([&] { read_all("# format: auger-robot-log v1\nt_s,omega_rpm_0,omega_rpm_1,omega_rpm_2,x_m,y_m,psi_rad\n"); });
    CHECK(e.line() == 2);
    CHECK_THAT(e.what(), Catch::Contains("omega_rpm_3"));
  }
  SECTION("wrong format") {
    auto e = log_error([&] { read_all("# note\n# format: auger-gantry-log v1\n" + head.substr(head.find('\n') + 1)); });
    CHECK(e.line() == 2);
    CHECK_THAT(e.what(), Catch::Contains("auger-gantry-log v1"));
  }
  SECTION("status must be an integer, inf is not a number") {
    const std::string h2 = "t_s,omega_rpm_0,omega_rpm_1,omega_rpm_2,omega_rpm_3,x_m,y_m,psi_rad,status_2\n";
    auto e = log_error([&] { read_all(h2 + "0,1,2,3,4,,,,2.5\n"); });
    CHECK(e.line() == 2);
    CHECK_THAT(e.what(), Catch::Contains("'2.5'") && Catch::Contains("status_2"));
    CHECK(log_error([&] { read_all(h2 + "0,inf,2,3,4,,,,2\n"); }).column() == 3);
  }
  SECTION("header problems") {
    CHECK(log_error([&] { read_all("# only comments\n"); }).line() == 2);
    CHECK_THAT(log_error([&] { read_all("t_s,x_m,x_m\n"); }).what(), Catch::Contains("duplicate"));
    CHECK(log_error([&] { read_all("time,omega\n"); }).line() == 1);
  }
  SECTION("missing file") {
    CHECK_THROWS_AS(RobotLogReader("/nonexistent/dir/log.csv"), LogError);
  }
}

TEST_CASE("writers refuse what the format forbids") {
  std::stringstream ss;
  GantryLogWriter w(ss, {{"axis", "lateral"}});
  GantrySample g;
  g.t_s = 1.0;
  w.write(g);
  CHECK_THROWS_AS(w.write(g), std::invalid_argument);  // t_s not increasing
  std::stringstream s2;
  CHECK_THROWS_AS(CsvLogWriter(s2, {{"bad key", "v"}}, {"t_s"}), std::invalid_argument);
  CHECK_THROWS_AS(CsvLogWriter(s2, {}, {"t_s", "a,b"}), std::invalid_argument);
}

TEST_CASE("gantry log round trip, streamed over many rows") {
  std::stringstream ss;
  const int n = 20000;
  {
    GantryLogWriter w(ss, {{"axis", "longitudinal"}, {"terrain", "sand"}, {"mass_kg", "16"}});
    for (int k = 0; k < n; ++k) {
      GantrySample g;
      g.t_s = k * 0.01;
      g.omega_rpm = {-20.0 + k * 1e-4, -20.0};
      g.force_n = k % 7 ? 32.48 + k * 1e-3 : kNotMeasured;
      g.position_m = 0.061 * g.t_s;
      w.write(g);
    }
  }
  GantryLogReader r(ss, "gantry.csv");
  CHECK(r.csv().meta("axis") == std::string("longitudinal"));
  GantrySample g;
  int k = 0;
  bool all_same = true;
  while (r.next(g)) {
    all_same = all_same && same(g.t_s, k * 0.01) && same(g.omega_rpm[0], -20.0 + k * 1e-4) &&
               same(g.force_n, k % 7 ? 32.48 + k * 1e-3 : kNotMeasured) && same(g.position_m, 0.061 * (k * 0.01));
    ++k;
  }
  CHECK(all_same);
  CHECK(k == n);
}

TEST_CASE("a last row cut short is dropped with a warning; the rows before it are read") {
  // Issue 13: a full disk cut augerd's last row mid-field and every reader refused the file.
  const std::string head = "# format: auger-robot-log v1\nt_s,omega_rpm_0,omega_rpm_1,omega_rpm_2,omega_rpm_3,x_m,y_m,psi_rad\n";
  const std::string rows = "0,1,2,3,4,,,\n0.01,1,2,3,4,0.5,0.25,0.125\n";
  auto count = [](const std::string& text, bool* cut) {
    std::stringstream ss(text);
    RobotLogReader r(ss, "cut.csv");
    RobotSample s;
    int n = 0;
    while (r.next(s)) ++n;
    *cut = r.csv().last_row_cut();
    return n;
  };
  bool cut = false;
  for (const std::string& tail : {std::string("0.02,1,2,3"), std::string("0.02,1,2,3,4,0.5,0.2"),
                                   std::string("0.02,1,2,3,4,0.5,0.25,1e"), std::string("0.0")}) {
    INFO(tail);
    CHECK(count(head + rows + tail, &cut) == 2);
    CHECK(cut);
  }
  // A whole last row without its newline (some programs write that) is a row.
  CHECK(count(head + rows + "0.02,1,2,3,4,0.5,0.25,0.125", &cut) == 3);
  CHECK_FALSE(cut);
  // The same cut anywhere but at the end of the file is an error as before.
  bool unused = false;
  CHECK(log_error([&] { count(head + "0.02,1,2,3\n" + rows, &unused); }).line() == 3);
}

TEST_CASE("hostile logs: long fields are cut in messages, a huge header reads in linear time, devices refused") {
  const std::string huge(10u << 20, '7');
  std::stringstream ss("t_s,x_m\n0,1\n" + huge + "x,2\n");
  CsvLogReader r(ss, "huge.csv");
  REQUIRE(r.next());
  const LogError e = log_error([&] { r.next(); });
  CHECK(std::string(e.what()).size() < 300);
  CHECK_THAT(e.what(), Catch::Contains("... (10485761 bytes)"));

  // 200 000 columns: a quadratic duplicate check took minutes; linear takes milliseconds.
  std::string header = "t_s";
  for (int i = 0; i < 200000; ++i) header += ",c" + std::to_string(i);
  std::stringstream wide(header + "\n");
  CsvLogReader w(wide, "wide.csv");
  CHECK(w.columns().size() == 200001);
  CHECK(w.column_index("c199999") == 200000);
  std::stringstream dup(header + ",c5\n");
  CHECK_THAT(log_error([&] { CsvLogReader d(dup, "dup.csv"); }).what(), Catch::Contains("duplicate column 'c5'"));

  CHECK_THAT(log_error([&] { CsvLogReader d("/dev/zero"); }).what(), Catch::Contains("not a log file"));
  CHECK_THAT(log_error([&] { CsvLogReader d("/tmp"); }).what(), Catch::Contains("is a directory"));
}

// A log written before the IMU's acceleration had columns reads as without an accelerometer,
// and an acceleration beyond an accelerometer's full scale is refused at its field.
TEST_CASE("robot log: the IMU's acceleration columns are optional and bounded") {
  std::stringstream old;
  old << "# format: auger-robot-log v1\nt_s,omega_rpm_0,omega_rpm_1,omega_rpm_2,omega_rpm_3,x_m,y_m,psi_rad,imu_r_radps\n"
         "0,1,2,3,4,0,0,0,0.1\n";
  RobotLogReader r(old, "old.csv");
  RobotSample s;
  REQUIRE(r.next(s));
  CHECK(s.imu_r_radps == 0.1);
  CHECK(std::isnan(s.imu_ax_mps2));
  CHECK(std::isnan(s.imu_ay_mps2));
  CHECK(r.extra_columns().empty());
  std::stringstream bad;
  bad << "# format: auger-robot-log v1\nt_s,omega_rpm_0,omega_rpm_1,omega_rpm_2,omega_rpm_3,x_m,y_m,psi_rad,imu_ax_mps2\n"
         "0,1,2,3,4,0,0,0,900\n";
  RobotLogReader rb(bad, "bad.csv");
  try {
    rb.next(s);
    FAIL("accepted");
  } catch (const LogError& e) {
    INFO(e.what());
    CHECK(std::string(e.what()).find("bad.csv:3:") == 0);
    CHECK(std::string(e.what()).find("imu_ax_mps2 = 900 m/s^2 is outside -157..157") != std::string::npos);
  }
}
