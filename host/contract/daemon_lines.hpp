// augerd's two socket line protocols (docs/daemon-protocol.md), parsed for augerd and for the
// tools that speak them (auger calib reads the sensors' lines); free of I/O so that the tests can
// check every malformed input without a running daemon. The checks of a command's and a sensor
// message's values work on the structs, so that an input that never was a line (ROS 2, through
// the bridge) meets the same bounds.
#pragma once

#include <string>
#include <vector>

#include "auger/controller.hpp"
#include "auger/model.hpp"

namespace auger::daemon {

enum class CommandKind { enable, stop, vel, go_to, follow, allocator, status, spin };

struct Command {
  CommandKind kind = CommandKind::status;
  double a = 0, b = 0, c = 0;  // vel: u_mps v_mps r_radps; goto: x_m y_m psi_rad; spin: module rpm
  std::string text;            // follow: csv path; allocator: pinv | nullspace; status: "" | all
};

enum class SensorKind { pose, imu };

struct SensorMessage {
  SensorKind kind = SensorKind::pose;
  double t_unix_s = 0;
  double x_m = 0, y_m = 0, psi_rad = 0, sx_m = 0, sy_m = 0, spsi_rad = 0;  // pose
  // The pose's variances where its source gave them (ROS 2's PoseWithCovarianceStamped); NaN:
  // the squares of the standard deviations above (a `pose` line, PoseStamped's pose_std).
  double var_x_m2 = NAN, var_y_m2 = NAN, var_psi_rad2 = NAN;
  double imu_psi_rad = 0, imu_r_radps = 0;                                  // imu
  // Optional on an imu line: the body-frame specific force (x forward, y left; m/s^2), what an
  // accelerometer reads (gravity's part along the ground included). Without it: none.
  bool has_acc = false;
  double ax_mps2 = 0, ay_mps2 = 0;
};

// The pose's covariance for the estimator (diagonal): the variances given, else the squares of
// the standard deviations. The one place a pose's covariance is built (augerd, auger replay).
Mat3 pose_covariance(const SensorMessage& m);

// A message into the controller's sensor input of this cycle (augerd; `auger replay` from the
// log's row): t_loop_s is its time on the loop's clock (a pose's capture time).
void to_sensor_input(const SensorMessage& m, double t_loop_s, SensorInput& in);

// Each returns an empty string on success, else the error text (without "error: "). A line
// with a control byte, a number that is not the whole field, or a value outside the bounds of
// auger/input_limits.hpp is refused.
std::string parse_command(const std::string& line, Command& out);
std::string parse_sensor(const std::string& line, SensorMessage& out);

// The message as its line, without the newline (%.17g: every double exactly): the one writer of
// the sensors' line format, for every program that sends or echoes one.
std::string sensor_line(const SensorMessage& m);

// The bounds alone (what the parsers check after the numbers): "" or the error text.
std::string check_command(const Command& c);
std::string check_sensor(const SensorMessage& m);

// The input as one printable quoted line for an error answer (auger::quote_input, 200 bytes).
std::string quote_line(const std::string& s);

// Splits at runs of spaces and tabs.
std::vector<std::string> split_fields(const std::string& line);

}  // namespace auger::daemon
