// augerd's log rows and the mode -> setpoint rule (daemon_log.hpp).
#include "daemon_log.hpp"

#include <algorithm>
#include <cmath>

#include "auger/log.hpp"

namespace auger::daemon {

std::array<double, 4> mode_setpoints(const MotionInput& in, const std::array<double, 4>& ctrl_rpm,
                                     const Model& model, double omega_max_rpm) {
  std::array<double, 4> cmd_rpm{};
  const double lim = omega_max_rpm;
  switch (in.mode) {
    case Mode::spin:
      cmd_rpm[std::size_t(in.spin_module)] = std::clamp(in.spin_rpm, -lim, lim);
      break;
    case Mode::vel: {
      // Open loop, eq. (4): the core's controller tracks poses only.
      const Vec4 w = kinematic_screw_speeds_rpm(model, in.vel);
      const double peak = w.cwiseAbs().maxCoeff();
      const double scale = peak > lim ? lim / peak : 1.0;  // keep the direction when saturated
      for (std::size_t i = 0; i < 4; ++i) cmd_rpm[i] = w[int(i)] * scale;
      break;
    }
    case Mode::go_to:
    case Mode::follow:
    case Mode::hold:
      cmd_rpm = ctrl_rpm;
      break;
    case Mode::stopped:
    case Mode::idle:
      break;
  }
  return cmd_rpm;
}

const std::vector<LogColumn>& log_row_columns() {
  static const std::vector<LogColumn> cols = {
      {"mode", &LogRow::mode},
      {"ctrl_events", &LogRow::ctrl_events},
      {"ctrl_enabled", &LogRow::ctrl_enabled},
      {"alloc_nullspace", &LogRow::alloc_nullspace},
      {"goal_x_m", &LogRow::goal_x_m},
      {"goal_y_m", &LogRow::goal_y_m},
      {"goal_psi_rad", &LogRow::goal_psi_rad},
      {"traj_n", &LogRow::traj_n},
      {"tm_fresh_0", &LogRow::tm_fresh_0},
      {"tm_fresh_1", &LogRow::tm_fresh_1},
      {"tm_fresh_2", &LogRow::tm_fresh_2},
      {"tm_fresh_3", &LogRow::tm_fresh_3},
      {"pose_sx_m", &LogRow::pose_sx_m},
      {"pose_sy_m", &LogRow::pose_sy_m},
      {"pose_spsi_rad", &LogRow::pose_spsi_rad},
      {pose_capture_column(), &LogRow::pose_capture_t_s},
      {"vel_u_mps", &LogRow::vel_u_mps},
      {"vel_v_mps", &LogRow::vel_v_mps},
      {"vel_r_radps", &LogRow::vel_r_radps},
      {"spin_module", &LogRow::spin_module},
      {"spin_rpm", &LogRow::spin_rpm},
      {"xe_m", &LogRow::xe_m},
      {"ye_m", &LogRow::ye_m},
      {"psie_rad", &LogRow::psie_rad}};
  return cols;
}

const std::vector<std::string>& online_columns() {
  static const std::vector<std::string> cols = {
      "on_sigma_long",    "on_sigma_lat",    "on_D_x",    "on_D_y",    "on_D_psi",
      "on_sd_sigma_long", "on_sd_sigma_lat", "on_sd_D_x", "on_sd_D_y", "on_sd_D_psi",
      "on_cusum",         "on_change",       "on_fallback",
      "ctl_sigma_long",   "ctl_sigma_lat",   "ctl_D_x",   "ctl_D_y",   "ctl_D_psi"};
  return cols;
}

const std::vector<std::string>& feedforward_columns() {
  static const std::vector<std::string> cols = {"ff_force_x_n", "ff_force_y_n", "ff_torque_psi_nm"};
  return cols;
}

const std::vector<std::string>& replay_columns() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const LogColumn& c : log_row_columns()) n.push_back(c.name);
    return n;
  }();
  return names;
}

void log_row_values(const LogRow& row, std::vector<double>& values) {
  const auto& cols = log_row_columns();
  values.resize(cols.size());
  for (std::size_t i = 0; i < cols.size(); ++i) values[i] = row.*(cols[i].value);
}

LogRowReader::LogRowReader(CsvLogReader& reader) : reader_(reader) {
  reader_.require_columns(replay_columns());
  for (const LogColumn& c : log_row_columns()) index_.push_back(reader_.column_index(c.name));
}

LogRow LogRowReader::row() const {
  LogRow r;
  const auto& cols = log_row_columns();
  for (std::size_t i = 0; i < cols.size(); ++i) r.*(cols[i].value) = reader_.value(index_[i]);
  return r;
}

}  // namespace auger::daemon
