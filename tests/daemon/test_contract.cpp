// augerd's contract (host/contract) as its users see it: the status answer read back by the field
// tools, the log row's named columns, the mode -> setpoint rule augerd and `auger replay` share,
// the checks of a typed input that never was a line (ROS 2).
#include <catch2/catch.hpp>

#include <cmath>
#include <set>
#include <string>
#include <vector>

#include "auger/effect.hpp"
#include "auger/model_file.hpp"
#include "daemon_lines.hpp"
#include "daemon_log.hpp"
#include "status.hpp"

using namespace auger;
using namespace auger::daemon;

TEST_CASE("a status line reads back into the struct it was written from", "[daemon][unit]") {
  Status s;
  s.t_s = 12.345;
  s.enabled = true;
  s.mode = "goto";
  s.x_m = 0.1234, s.y_m = -0.5, s.psi_rad = 3.1416;
  s.xd_m = 1, s.yd_m = 2, s.psid_rad = -0.25;
  s.fault = "2:overcurrent";
  s.loop_dt_s = 0.01001, s.loop_jitter_max_s = 0.00042;
  s.arrived = true;
  s.log_ok = false;
  const std::string plain = format_status(s);
  CHECK(plain == "status t_s=12.345 enabled=1 mode=goto x_m=0.1234 y_m=-0.5000 psi_rad=3.1416 xd_m=1.0000 "
                 "yd_m=2.0000 psid_rad=-0.2500 fault=2:overcurrent loop_dt_s=0.01001 loop_jitter_max_s=0.00042 "
                 "arrived=1 log_ok=0 poses_rejected=0");
  Status back;
  REQUIRE(parse_status(plain, back) == "");
  CHECK_FALSE(back.all);
  CHECK(back.mode == "goto");
  CHECK(back.fault == "2:overcurrent");
  CHECK(back.x_m == 0.1234);
  CHECK(back.psid_rad == -0.25);
  CHECK(back.arrived);
  CHECK_FALSE(back.log_ok);

  s.all = true;
  s.modules[3].port = "/dev/ttyUSB3";
  s.modules[3].lost = false;
  s.modules[3].time_ms = 4000000000u;
  s.modules[3].omega_rpm = -12.5;
  s.modules[3].position_counts = -123456;
  s.modules[3].status = 0x0203;
  s.modules[3].faults = "F_OVERCURRENT";
  s.modules[3].host_bytes_skipped = 65535;
  s.imu_age_s = s.imu_psi_rad = s.imu_r_radps = s.imu_ax_mps2 = NAN;  // never received
  s.imu_ay_mps2 = -0.0123;
  s.pose_age_s = 0.05, s.cam_x_m = 1.5;
  s.ros2 = true;
  s.ros2_applied = 17, s.ros2_refused = 2, s.ros2_hook_max_us = 81.5;
  const std::string all = format_status(s);
  CHECK(all.rfind(plain, 0) == 0);  // `status all` extends `status`
  CHECK(all.find(" m3_port=/dev/ttyUSB3 m3_lost=0 ") != std::string::npos);
  CHECK(all.find(" m3_status=0x0203 m3_faults=F_OVERCURRENT ") != std::string::npos);
  REQUIRE(parse_status(all, back) == "");
  CHECK(back.all);
  CHECK(back.modules[3].port == "/dev/ttyUSB3");
  CHECK_FALSE(back.modules[3].lost);
  CHECK(back.modules[3].time_ms == 4000000000u);
  CHECK(back.modules[3].omega_rpm == -12.5);
  CHECK(back.modules[3].position_counts == -123456);
  CHECK(back.modules[3].status == 0x0203);
  CHECK(back.modules[3].faults == "F_OVERCURRENT");
  CHECK(back.modules[3].host_bytes_skipped == 65535);
  CHECK(back.modules[0].lost);
  CHECK(std::isnan(back.imu_age_s));
  CHECK(std::isnan(back.imu_ax_mps2));
  CHECK(back.imu_ay_mps2 == -0.0123);
  CHECK(back.cam_x_m == 1.5);
  CHECK(back.ros2);
  CHECK(back.ros2_applied == 17);
  CHECK(back.ros2_hook_max_us == 81.5);

  // What is wrong with a line is named.
  CHECK(parse_status("status t_s=1", back).find("no 'enabled'") != std::string::npos);
  CHECK(parse_status("error: not enabled", back).find("not a status line") != std::string::npos);
  std::string bad = plain;
  bad.replace(bad.find("x_m=0.1234"), 10, "x_m=zz");
  CHECK(parse_status(bad, back).find("'x_m=zz' is not a number") != std::string::npos);
}

TEST_CASE("the log row's columns name each member once", "[daemon][unit]") {
  const auto& cols = log_row_columns();
  // Every member of LogRow is a double with a column (a member added without one is caught).
  CHECK(sizeof(LogRow) == cols.size() * sizeof(double));
  std::set<std::string> names;
  LogRow row;
  for (std::size_t i = 0; i < cols.size(); ++i) {
    names.insert(cols[i].name);
    row.*(cols[i].value) = double(i);
  }
  CHECK(names.size() == cols.size());
  std::vector<double> values;
  log_row_values(row, values);
  REQUIRE(values.size() == cols.size());
  for (std::size_t i = 0; i < cols.size(); ++i) CHECK(values[i] == double(i));
  CHECK(replay_columns().size() == cols.size());
  CHECK(replay_columns()[15] == pose_capture_column());
}

TEST_CASE("what each mode sends to the screws", "[daemon][unit]") {
  const Model m = build_model(load_model_file(AUGER_SOURCE_DIR "/models/robot.toml"), "sand");
  const std::array<double, 4> ctrl{1, -2, 3, -4};
  MotionInput in;
  for (Mode mode : {Mode::go_to, Mode::follow, Mode::hold}) {
    in.mode = mode;
    CHECK(mode_setpoints(in, ctrl, m, 23) == ctrl);
  }
  for (Mode mode : {Mode::stopped, Mode::idle}) {
    in.mode = mode;
    CHECK(mode_setpoints(in, ctrl, m, 23) == std::array<double, 4>{});
  }
  in.mode = Mode::spin;
  in.spin_module = 2;
  in.spin_rpm = -40;
  CHECK(mode_setpoints(in, ctrl, m, 23) == std::array<double, 4>{0, 0, -23, 0});
  // vel: eq. (4), scaled as a whole when a screw would exceed the limit.
  in.mode = Mode::vel;
  in.vel = Vec3(0.02, 0, 0);
  const Vec4 w = kinematic_screw_speeds_rpm(m, in.vel);
  const double peak = w.cwiseAbs().maxCoeff();
  const std::array<double, 4> slow = mode_setpoints(in, ctrl, m, 2 * peak);
  for (int i = 0; i < 4; ++i) CHECK(slow[std::size_t(i)] == w[i]);
  const std::array<double, 4> capped = mode_setpoints(in, ctrl, m, 0.5 * peak);
  for (int i = 0; i < 4; ++i) CHECK(capped[std::size_t(i)] == Approx(0.5 * w[i]));
}

TEST_CASE("a typed input meets a line's checks, and its variances reach the estimator", "[daemon][unit]") {
  Command c;
  c.kind = CommandKind::vel;
  c.a = 1e308;
  CHECK(check_command(c).find("u_mps = 1e+308 m/s is outside -10..10 m/s") != std::string::npos);
  c.a = NAN;
  CHECK(check_command(c) == "u_mps must be a finite number, got 'nan'");
  c.a = 0.1;
  CHECK(check_command(c) == "");
  SensorMessage p;
  p.kind = SensorKind::pose;
  p.t_unix_s = 1700000000;
  p.sx_m = std::sqrt(-1.0);  // a negative variance in a PoseWithCovarianceStamped
  p.sy_m = p.spsi_rad = 0.01;
  CHECK(check_sensor(p).find("sx_m must be a finite number") != std::string::npos);
  p.sx_m = 0.01;
  CHECK(check_sensor(p) == "");
  // The line parser refuses what the struct check refuses.
  SensorMessage q;
  CHECK(parse_sensor("pose 1 0 0 0 1e300 0.01 0.01", q) == check_sensor([] {
          SensorMessage s;
          s.kind = SensorKind::pose;
          s.t_unix_s = 1;
          s.sx_m = 1e300, s.sy_m = s.spsi_rad = 0.01;
          return s;
        }()));
  // The standard deviations' squares, unless the source gave the variances themselves.
  p.sx_m = 0.1, p.sy_m = 0.2, p.spsi_rad = 0.3;
  CHECK(pose_covariance(p).diagonal().isApprox(Vec3(0.01, 0.04, 0.09)));
  p.var_x_m2 = 0.0101, p.var_y_m2 = 0.0402, p.var_psi_rad2 = 0.0903;
  CHECK(pose_covariance(p).diagonal() == Vec3(0.0101, 0.0402, 0.0903));
  CHECK(pose_covariance(p)(0, 1) == 0);
  // Into the controller's input of the cycle, at the given time on the loop's clock.
  SensorInput in;
  p.x_m = 1, p.y_m = 2, p.psi_rad = 0.5;
  to_sensor_input(p, 41.25, in);
  CHECK(in.has_pose);
  CHECK(in.pose == Vec3(1, 2, 0.5));
  CHECK(in.pose_t_s == 41.25);
  CHECK(in.pose_cov == pose_covariance(p));
  CHECK_FALSE(in.has_imu_psi);
  SensorMessage imu;
  imu.kind = SensorKind::imu;
  imu.imu_psi_rad = 0.3, imu.imu_r_radps = -0.1;
  to_sensor_input(imu, 41.26, in);
  CHECK(in.has_pose);  // the cycle's pose stays
  CHECK((in.has_imu_psi && in.has_imu_r && in.imu_psi_rad == 0.3 && in.imu_r_radps == -0.1));
}
