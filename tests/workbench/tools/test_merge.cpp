// auger merge: a camera pose log on a clock shifted by a known offset, with a wrong t0_unix_s,
// aligned with the robot log by the IMU yaw rate; the offset is recovered within one sample
// and the robot log comes back with the camera pose at its samples.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>

#include "auger/log.hpp"
#include "auger/measured.hpp"
#include "auger/model.hpp"
#include "merge.hpp"
#include "tools_fixtures.hpp"

namespace {

// The true motion in robot time: yaw rate a sum of incommensurate sines (a unique
// correlation peak), heading its exact integral, crossing +-pi; x, y any smooth path.
struct Truth {
  double p[3] = {0.3, 1.9, 4.0};
  double f[3] = {0.21, 0.53, 1.3};  // rad/s
  double yaw_rate(double t) const {
    return 0.3 * std::sin(f[0] * t + p[0]) + 0.2 * std::sin(f[1] * t + p[1]) + 0.15 * std::sin(f[2] * t + p[2]);
  }
  double psi(double t) const {
    auto prim = [&](double s) {
      return -0.3 / f[0] * std::cos(f[0] * s + p[0]) - 0.2 / f[1] * std::cos(f[1] * s + p[1]) -
             0.15 / f[2] * std::cos(f[2] * s + p[2]);
    };
    return 3.0 + prim(t) - prim(0);
  }
  double x(double t) const { return 0.5 * std::sin(0.1 * t); }
  double y(double t) const { return 0.3 * std::cos(0.07 * t); }
};

constexpr double kRobotT0 = 1767225600.0;
constexpr double kTrueOffset = 7.4321;  // t_robot = t_camera + this
constexpr double kT0Error = 1.3;        // the camera computer's clock is 1.3 s ahead

std::string robot_log(const Truth& tr, bool with_imu, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0, 1);
  std::ostringstream os;
  os.precision(12);
  os << "# format: auger-robot-log v1\n# terrain: sand\n# t0_unix_s: " << kRobotT0 << "\n"
     << "t_s,omega_rpm_0,omega_rpm_1,omega_rpm_2,omega_rpm_3,x_m,y_m,psi_rad" << (with_imu ? ",imu_r_radps" : "")
     << ",my_note\n";
  for (int k = 0; k < 12000; ++k) {
    const double t = 0.01 * k + 0.001 * std::sin(k);  // not quite uniform, as a real loop
    os << t << ",1,2,3,4,,,";
    if (with_imu) os << "," << tr.yaw_rate(t) + 0.003 * n01(rng);
    os << "," << k << "\n";
  }
  return os.str();
}

std::string camera_log(const Truth& tr, bool with_t0, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0, 1);
  std::ostringstream os;
  os.precision(17);
  os << "# format: auger-robot-log v1\n";
  if (with_t0) os << "# t0_unix_s: " << kRobotT0 + kTrueOffset + kT0Error << "\n";
  os << "t_s,x_m,y_m,psi_rad\n";
  for (int k = 0; k < 1900; ++k) {  // 20 Hz for 95 s; some frames dropped
    const double tc = 0.05 * k;
    if (k % 37 == 5) {
      os << tc << ",,,\n";
      continue;
    }
    const double t = tc + kTrueOffset;
    os << tc << "," << tr.x(t) + 0.003 * n01(rng) << "," << tr.y(t) + 0.003 * n01(rng) << ","
       << auger::wrap_angle(tr.psi(t) + 0.005 * n01(rng)) << "\n";
  }
  return os.str();
}

}  // namespace

TEST_CASE("merge recovers a shifted camera clock within one sample despite a wrong t0_unix_s") {
  const tools_test::TempDir tmp("merge");
  const std::string dir = tmp.path;
  Truth tr;
  tools_test::write_text(dir + "/robot.csv", robot_log(tr, true, 1));
  tools_test::write_text(dir + "/camera.csv", camera_log(tr, true, 2));
  const auto r = tools_test::run_auger(dir, "merge " + dir + "/robot.csv " + dir + "/camera.csv --out " +
                                                dir + "/merged.csv --json");
  INFO(r.out << r.err);
  REQUIRE(r.code == 0);
  CHECK(tools_test::json_number(dir, r.out, "d['coarse_offset_s']") == Approx(kTrueOffset + kT0Error).margin(1e-6));
  const double offset = tools_test::json_number(dir, r.out, "d['offset_s']");
  CHECK(std::fabs(offset - kTrueOffset) < 0.01);  // one robot sample
  CHECK(tools_test::json_eval(dir, r.out, "d['quality']") == "good");
  CHECK(tools_test::json_number(dir, r.out, "d['correlation']") > 0.9);

  // The merged log: camera pose at the robot's samples, none outside the camera's time.
  auger::RobotLogReader log(dir + "/merged.csv");
  CHECK(log.csv().meta("t0_unix_s") == std::string("1767225600"));
  REQUIRE(log.extra_columns().size() == 1);
  auger::RobotSample s;
  int with_pose = 0, n = 0;
  double worst_xy = 0, worst_psi = 0;
  while (log.next(s)) {
    CHECK(log.csv().value(log.extra_columns()[0]) == n);
    ++n;
    const double tc = s.t_s - kTrueOffset;
    const bool inside = tc >= 0.02 && tc <= 94.9;
    if (!auger::measured(s.x_m)) {
      CHECK_FALSE(inside);
      continue;
    }
    ++with_pose;
    CHECK(s.psi_rad > -auger::kPi - 1e-12);
    CHECK(s.psi_rad <= auger::kPi);
    worst_xy = std::max({worst_xy, std::fabs(s.x_m - tr.x(s.t_s)), std::fabs(s.y_m - tr.y(s.t_s))});
    worst_psi = std::max(worst_psi, std::fabs(auger::wrap_angle(s.psi_rad - tr.psi(s.t_s))));
  }
  CHECK(n == 12000);
  CHECK(with_pose == Approx(9500).margin(20));
  CHECK(worst_xy < 0.015);  // 3 mm noise, 5 sigma
  CHECK(worst_psi < 0.03);  // 5 mrad noise; interpolated across +-pi without a 2 pi jump
}

TEST_CASE("merge without t0_unix_s searches around zero; without an IMU it keeps t0") {
  const tools_test::TempDir tmp("merge2");
  const std::string dir = tmp.path;
  Truth tr;
  tools_test::write_text(dir + "/robot.csv", robot_log(tr, true, 3));
  tools_test::write_text(dir + "/camera.csv", camera_log(tr, false, 4));
  auto r = tools_test::run_auger(dir, "merge " + dir + "/robot.csv " + dir + "/camera.csv --json");
  INFO(r.out << r.err);
  REQUIRE(r.code == 0);
  CHECK(tools_test::json_eval(dir, r.out, "d['t0_used']") == "False");
  CHECK(std::fabs(tools_test::json_number(dir, r.out, "d['offset_s']") - kTrueOffset) < 0.01);
  CHECK(tools_test::json_eval(dir, r.out, "d['out']") == "None");

  tools_test::write_text(dir + "/robot_noimu.csv", robot_log(tr, false, 5));
  tools_test::write_text(dir + "/camera_t0.csv", camera_log(tr, true, 6));
  r = tools_test::run_auger(dir, "merge " + dir + "/robot_noimu.csv " + dir + "/camera_t0.csv --json");
  REQUIRE(r.code == 0);
  CHECK(tools_test::json_eval(dir, r.out, "d['quality']") == "t0 only");
  CHECK(tools_test::json_number(dir, r.out, "d['offset_s']") == Approx(kTrueOffset + kT0Error).margin(1e-6));
}

TEST_CASE("merge refuses a camera log from another run: poor correlation, exit 1, nothing written") {
  const tools_test::TempDir tmp("merge3");
  const std::string dir = tmp.path;
  Truth robot_truth, other;
  other.f[0] = 0.17, other.f[1] = 0.71, other.f[2] = 1.7;
  tools_test::write_text(dir + "/robot.csv", robot_log(robot_truth, true, 7));
  tools_test::write_text(dir + "/camera.csv", camera_log(other, true, 8));
  const auto r = tools_test::run_auger(dir, "merge " + dir + "/robot.csv " + dir + "/camera.csv --out " +
                                                dir + "/merged.csv");
  INFO(r.out << r.err);
  CHECK(r.code == 1);
  CHECK_THAT(r.err, Catch::Contains("poor"));
  CHECK(tools_test::read_text(dir + "/merged.csv").empty());
}

TEST_CASE("merge puts back the pose of a simulator log split in two with a shifted camera clock") {
  // auger-sim-log's robot log (its own IMU noise and 20 Hz camera), split: the robot part keeps
  // everything but the pose, the camera part is the pose rows on a clock 12.345 s behind, with a
  // t0_unix_s 2.2 s off. Merged, the pose rows must come back where they were.
  const tools_test::TempDir tmp("merge-split");
  const std::string dir = tmp.path;
  const std::string sim = dir + "/sim.csv";
  REQUIRE(std::system((tools_test::shell_quote(AUGER_SIM_LOG_PATH) + " --out " + tools_test::shell_quote(sim) +
                       " --trajectory manual --seconds 120 --seed 4 2>/dev/null").c_str()) == 0);
  const double offset = 12.345, t0 = 1767225600.0;
  std::vector<auger::RobotSample> original;
  {
    auger::RobotLogReader in(sim);
    std::ofstream robot(dir + "/robot.csv"), camera(dir + "/camera.csv");
    auger::RobotLogWriter rw(robot, {{"terrain", "sand"}, {"t0_unix_s", "1767225600"}});
    char t0_cam[64];
    std::snprintf(t0_cam, sizeof t0_cam, "%.6f", t0 + offset - 2.2);
    auger::CsvLogWriter cw(camera, {{"format", auger::kRobotLogFormat}, {"t0_unix_s", t0_cam}},
                           {"t_s", "x_m", "y_m", "psi_rad"});
    auger::RobotSample s;
    while (in.next(s)) {
      original.push_back(s);
      if (auger::measured(s.x_m) && s.t_s - offset > 0) {
        const double row[4] = {s.t_s - offset, s.x_m, s.y_m, s.psi_rad};
        cw.write_row(row, 4);
      }
      s.x_m = s.y_m = s.psi_rad = auger::kNotMeasured;
      rw.write(s);
    }
  }
  const auto r = tools_test::run_auger(dir, "merge " + dir + "/robot.csv " + dir + "/camera.csv --out " + dir +
                                                "/merged.csv --json");
  INFO(r.out << r.err);
  REQUIRE(r.code == 0);
  CHECK(std::fabs(tools_test::json_number(dir, r.out, "d['offset_s']") - offset) < 0.01);
  CHECK(tools_test::json_eval(dir, r.out, "d['quality']") == "good");
  auger::RobotLogReader merged(dir + "/merged.csv");
  auger::RobotSample s;
  std::size_t k = 0, compared = 0;
  double worst_m = 0, worst_rad = 0;
  while (merged.next(s)) {
    const auto& o = original.at(k++);
    CHECK(s.t_s == o.t_s);
    CHECK(s.omega_rpm == o.omega_rpm);
    // Inside the camera's time, away from its ends (a few ms of offset error moves them).
    if (!auger::measured(o.x_m) || o.t_s - offset <= 0.1 || o.t_s >= original.back().t_s - 0.1) continue;
    REQUIRE(auger::measured(s.x_m));
    worst_m = std::max({worst_m, std::fabs(s.x_m - o.x_m), std::fabs(s.y_m - o.y_m)});
    worst_rad = std::max(worst_rad, std::fabs(auger::wrap_angle(s.psi_rad - o.psi_rad)));
    ++compared;
  }
  CHECK(k == original.size());
  CHECK(compared > 2000);  // 20 Hz over the ~107 s both have
  // Found within a fraction of a sample, the pose rows come back to within a fraction of the
  // 3 mm / 5 mrad camera noise (the interpolation mixes in the neighbouring frame; measured
  // 1.4 mm and 2.7 mrad at worst).
  INFO("worst position difference " << worst_m << " m, heading " << worst_rad << " rad");
  CHECK(worst_m < 0.003);
  CHECK(worst_rad < 0.005);
}
