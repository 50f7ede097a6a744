#include "daemon_lines.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <initializer_list>
#include <utility>

#include "auger/args.hpp"
#include "auger/input_limits.hpp"

namespace auger::daemon {
namespace {

using auger::check_goal;
using auger::check_imu;
using auger::check_imu_acceleration;
using auger::check_pose;
using auger::check_screw_speed;
using auger::check_velocity;

std::string quote(const std::string& s) { return quote_line(s); }

// A finite decimal number over the whole field (auger::decimal_number: a NUL, trailing bytes,
// hexadecimal such as `0x1`, `inf` and `nan` are not numbers); else an error naming the field.
bool number(const std::string& field, const char* name, double& out, std::string& err) {
  if (!auger::decimal_number(field, out)) {
    err = name + std::string(" must be a finite decimal number, got ") + quote(field);
    return false;
  }
  return true;
}

// A line is printable text: a control byte (a NUL cuts a C string short) is refused where it is.
std::string control_byte(const std::string& line) {
  for (std::size_t i = 0; i < line.size(); ++i) {
    const auto ch = static_cast<unsigned char>(line[i]);
    if ((ch < 0x20 && ch != '\t' && !(ch == '\r' && i + 1 == line.size())) || ch == 0x7f) {
      char b[96];
      std::snprintf(b, sizeof b, "control byte 0x%02x at byte %zu of the line (text only)", ch, i + 1);
      return b;
    }
  }
  return "";
}

// A value as a line would carry it (%.17g: every double exactly).
std::string number_text(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.17g", v);
  return quote(b);
}

// Non-finite values of an input that never was a line (ROS 2) refused as the parser refuses them
// in a line (number above), naming the first.
std::string finite(std::initializer_list<std::pair<const char*, double>> values) {
  for (const auto& [name, v] : values)
    if (!std::isfinite(v)) return name + std::string(" must be a finite number, got ") + number_text(v);
  return "";
}

}  // namespace

std::string check_command(const Command& c) {
  std::string err;
  switch (c.kind) {
    case CommandKind::vel:
      if (!(err = finite({{"u_mps", c.a}, {"v_mps", c.b}, {"r_radps", c.c}})).empty()) return err;
      return check_velocity(c.a, c.b, c.c);
    case CommandKind::go_to:
      if (!(err = finite({{"x_m", c.a}, {"y_m", c.b}, {"psi_rad", c.c}})).empty()) return err;
      return check_goal(c.a, c.b, c.c);
    case CommandKind::spin:
      if (!(err = finite({{"module", c.a}, {"omega_rpm", c.b}})).empty()) return err;
      if (c.a != 0 && c.a != 1 && c.a != 2 && c.a != 3) return "module must be 0, 1, 2 or 3, got " + number_text(c.a);
      return check_screw_speed(c.b);
    default: return "";
  }
}

std::string check_sensor(const SensorMessage& m) {
  std::string err;
  if (m.kind == SensorKind::imu) {
    if (!(err = finite({{"t_unix_s", m.t_unix_s}, {"psi_rad", m.imu_psi_rad}, {"r_radps", m.imu_r_radps}})).empty())
      return err;
    if (m.has_acc && !(err = finite({{"ax_mps2", m.ax_mps2}, {"ay_mps2", m.ay_mps2}})).empty()) return err;
    if (!(err = check_imu(m.imu_psi_rad, m.imu_r_radps)).empty() || !m.has_acc) return err;
    return check_imu_acceleration(m.ax_mps2, m.ay_mps2);
  }
  if (!(err = finite({{"t_unix_s", m.t_unix_s}, {"x_m", m.x_m}, {"y_m", m.y_m}, {"psi_rad", m.psi_rad},
                      {"sx_m", m.sx_m}, {"sy_m", m.sy_m}, {"spsi_rad", m.spsi_rad}})).empty())
    return err;
  return check_pose(m.x_m, m.y_m, m.psi_rad, m.sx_m, m.sy_m, m.spsi_rad);
}

Mat3 pose_covariance(const SensorMessage& m) {
  auto var = [](double given, double sd) { return std::isnan(given) ? sd * sd : given; };
  return Vec3(var(m.var_x_m2, m.sx_m), var(m.var_y_m2, m.sy_m), var(m.var_psi_rad2, m.spsi_rad)).asDiagonal();
}

void to_sensor_input(const SensorMessage& m, double t_loop_s, SensorInput& in) {
  if (m.kind == SensorKind::pose) {
    in.has_pose = true;
    in.pose = Vec3(m.x_m, m.y_m, m.psi_rad);
    in.pose_cov = pose_covariance(m);
    in.pose_t_s = t_loop_s;  // the EKF compares it with its prediction for that time
  } else {
    in.has_imu_psi = in.has_imu_r = true;
    in.imu_psi_rad = m.imu_psi_rad;
    in.imu_r_radps = m.imu_r_radps;
    in.has_imu_acc = m.has_acc;  // the cycle's last imu message says whether it has one
    in.imu_ax_mps2 = m.ax_mps2;
    in.imu_ay_mps2 = m.ay_mps2;
  }
}

std::string sensor_line(const SensorMessage& m) {
  char b[320];
  if (m.kind == SensorKind::pose)
    std::snprintf(b, sizeof b, "pose %.17g %.17g %.17g %.17g %.17g %.17g %.17g", m.t_unix_s, m.x_m, m.y_m, m.psi_rad,
                  m.sx_m, m.sy_m, m.spsi_rad);
  else if (m.has_acc)
    std::snprintf(b, sizeof b, "imu %.17g %.17g %.17g %.17g %.17g", m.t_unix_s, m.imu_psi_rad, m.imu_r_radps,
                  m.ax_mps2, m.ay_mps2);
  else
    std::snprintf(b, sizeof b, "imu %.17g %.17g %.17g", m.t_unix_s, m.imu_psi_rad, m.imu_r_radps);
  return b;
}

std::string quote_line(const std::string& s) { return auger::quote_input(s, 200); }

std::vector<std::string> split_fields(const std::string& line) {
  std::vector<std::string> f;
  std::string cur;
  for (char ch : line) {
    if (ch == ' ' || ch == '\t' || ch == '\r') {
      if (!cur.empty()) f.push_back(cur), cur.clear();
    } else {
      cur += ch;
    }
  }
  if (!cur.empty()) f.push_back(cur);
  return f;
}

std::string parse_command(const std::string& line, Command& out) {
  if (std::string e = control_byte(line); !e.empty()) return e + ": " + quote(line);
  const auto f = split_fields(line);
  if (f.empty()) return "empty command (enable, stop, vel, goto, follow, allocator, status, spin)";
  const std::string& w = f[0];
  auto arity = [&](std::size_t n, const char* usage) -> std::string {
    if (f.size() != n + 1) return "'" + w + "' takes " + std::to_string(n) + " argument(s): " + usage + ", got " + quote(line);
    return "";
  };
  std::string err;
  Command c;
  if (w == "status" && f.size() == 2) {
    // `status all`: the robot's line plus every module's telemetry (auger monitor, auger step).
    if (f[1] != "all") return "'status' takes nothing or 'all', got " + quote(line);
    c.kind = CommandKind::status;
    c.text = "all";
  } else if (w == "enable" || w == "stop" || w == "status") {
    if (!(err = arity(0, w.c_str())).empty()) return err;
    c.kind = w == "enable" ? CommandKind::enable : w == "stop" ? CommandKind::stop : CommandKind::status;
  } else if (w == "vel" || w == "goto") {
    const bool vel = w == "vel";
    if (!(err = arity(3, vel ? "vel <u_mps> <v_mps> <r_radps>" : "goto <x_m> <y_m> <psi_rad>")).empty()) return err;
    c.kind = vel ? CommandKind::vel : CommandKind::go_to;
    if (!number(f[1], vel ? "u_mps" : "x_m", c.a, err) || !number(f[2], vel ? "v_mps" : "y_m", c.b, err) ||
        !number(f[3], vel ? "r_radps" : "psi_rad", c.c, err))
      return err;
    if (!(err = check_command(c)).empty()) return err;
  } else if (w == "spin") {
    if (!(err = arity(2, "spin <module 0..3> <omega_rpm>")).empty()) return err;
    c.kind = CommandKind::spin;
    if (!number(f[1], "module", c.a, err) || !number(f[2], "omega_rpm", c.b, err)) return err;
    if (c.a != 0 && c.a != 1 && c.a != 2 && c.a != 3) return "module must be 0, 1, 2 or 3, got " + quote(f[1]);
    if (!(err = check_command(c)).empty()) return err;
  } else if (w == "follow") {
    if (!(err = arity(1, "follow <csv_path>")).empty()) return err;
    c.kind = CommandKind::follow;
    c.text = f[1];
  } else if (w == "allocator") {
    if (!(err = arity(1, "allocator pinv|nullspace")).empty()) return err;
    if (f[1] != "pinv" && f[1] != "nullspace") return "allocator must be pinv or nullspace, got " + quote(f[1]);
    c.kind = CommandKind::allocator;
    c.text = f[1];
  } else {
    return "unknown command " + quote(w) + " (enable, stop, vel, goto, follow, allocator, status, spin)";
  }
  out = c;
  return "";
}

std::string parse_sensor(const std::string& line, SensorMessage& out) {
  if (std::string e = control_byte(line); !e.empty()) return e + ": " + quote(line);
  const auto f = split_fields(line);
  if (f.empty()) return "empty sensor message (pose, imu)";
  std::string err;
  SensorMessage m;
  if (f[0] == "pose") {
    if (f.size() != 8)
      return "pose takes 7 fields: pose <t_unix_s> <x_m> <y_m> <psi_rad> <sx_m> <sy_m> <spsi_rad>, got " + quote(line);
    m.kind = SensorKind::pose;
    if (!number(f[1], "t_unix_s", m.t_unix_s, err) || !number(f[2], "x_m", m.x_m, err) ||
        !number(f[3], "y_m", m.y_m, err) || !number(f[4], "psi_rad", m.psi_rad, err) ||
        !number(f[5], "sx_m", m.sx_m, err) || !number(f[6], "sy_m", m.sy_m, err) ||
        !number(f[7], "spsi_rad", m.spsi_rad, err))
      return err;
    if (!(err = check_sensor(m)).empty()) return err;
  } else if (f[0] == "imu") {
    if (f.size() != 4 && f.size() != 6)
      return "imu takes 3 or 5 fields: imu <t_unix_s> <psi_rad> <r_radps> [<ax_mps2> <ay_mps2>], got " + quote(line);
    m.kind = SensorKind::imu;
    if (!number(f[1], "t_unix_s", m.t_unix_s, err) || !number(f[2], "psi_rad", m.imu_psi_rad, err) ||
        !number(f[3], "r_radps", m.imu_r_radps, err))
      return err;
    m.has_acc = f.size() == 6;
    if (m.has_acc && (!number(f[4], "ax_mps2", m.ax_mps2, err) || !number(f[5], "ay_mps2", m.ay_mps2, err))) return err;
    if (!(err = check_sensor(m)).empty()) return err;
  } else {
    return "unknown sensor message " + quote(f[0]) + " (pose, imu)";
  }
  out = m;
  return "";
}

}  // namespace auger::daemon
