// augerd's two socket line protocols (docs/daemon-protocol.md), parsed for augerd and for the
// tools that speak them (auger calib reads the sensors' lines); free of I/O so that the tests can
// check every malformed input without a running daemon.
#pragma once

#include <string>
#include <vector>

namespace auger::io {

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
  double imu_psi_rad = 0, imu_r_radps = 0;                                  // imu
};

// Each returns an empty string on success, else the error text (without "error: "). A line
// with a control byte, a number that is not the whole field, or a value outside the bounds of
// auger/input_limits.hpp is refused.
std::string parse_command(const std::string& line, Command& out);
std::string parse_sensor(const std::string& line, SensorMessage& out);

// The input as one printable quoted line for an error answer (auger::quote_input, 200 bytes).
std::string quote_line(const std::string& s);

// Splits at runs of spaces and tabs.
std::vector<std::string> split_fields(const std::string& line);

}  // namespace auger::io
