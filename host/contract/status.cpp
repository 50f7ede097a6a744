// augerd's `status` line (status.hpp): each key, its format and its member written down once, in
// the tables below, which both the writer and the reader go through.
#include "status.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <type_traits>
#include <variant>
#include <vector>

#include "daemon_log.hpp"

namespace auger::daemon {
namespace {

static_assert(std::is_same_v<std::uint32_t, unsigned>, "time_ms is read and written as unsigned");

// One key=value field of a struct S: its key, its printf format and its member.
template <class S>
struct Field {
  // (std::uint32_t is unsigned on the platforms auger runs on: static_assert below.)
  using Member = std::variant<double S::*, bool S::*, std::string S::*, std::int32_t S::*, std::uint16_t S::*,
                              unsigned S::*, long S::*>;
  const char* key;
  const char* format;
  Member member;
};

const std::vector<Field<Status>>& line_fields() {
  static const std::vector<Field<Status>> f = {
      {"t_s", "%.3f", &Status::t_s},
      {"enabled", "%d", &Status::enabled},
      {"mode", "%s", &Status::mode},
      {"x_m", "%.4f", &Status::x_m},
      {"y_m", "%.4f", &Status::y_m},
      {"psi_rad", "%.4f", &Status::psi_rad},
      {"xd_m", "%.4f", &Status::xd_m},
      {"yd_m", "%.4f", &Status::yd_m},
      {"psid_rad", "%.4f", &Status::psid_rad},
      {"fault", "%s", &Status::fault},
      {"loop_dt_s", "%.5f", &Status::loop_dt_s},
      {"loop_jitter_max_s", "%.5f", &Status::loop_jitter_max_s},
      {"arrived", "%d", &Status::arrived},
      {"log_ok", "%d", &Status::log_ok},
      {"poses_rejected", "%ld", &Status::poses_rejected}};
  return f;
}

// `status all`: each module's, with the prefix m<i>_ ...
const std::vector<Field<ModuleStatus>>& module_fields() {
  static const std::vector<Field<ModuleStatus>> f = {
      {"port", "%s", &ModuleStatus::port},
      {"lost", "%d", &ModuleStatus::lost},
      {"tm_age_s", "%.3f", &ModuleStatus::tm_age_s},
      {"time_ms", "%u", &ModuleStatus::time_ms},
      {"omega_rpm", "%.2f", &ModuleStatus::omega_rpm},
      {"cmd_rpm", "%.2f", &ModuleStatus::cmd_rpm},
      {"omega_cmd_rpm", "%.2f", &ModuleStatus::omega_cmd_rpm},
      {"position_counts", "%d", &ModuleStatus::position_counts},
      {"current_a", "%.3f", &ModuleStatus::current_a},
      {"voltage_v", "%.3f", &ModuleStatus::voltage_v},
      {"pwm", "%.4f", &ModuleStatus::pwm},
      {"status", "0x%04x", &ModuleStatus::status},
      {"faults", "%s", &ModuleStatus::faults},
      {"rx_errors", "%u", &ModuleStatus::rx_errors},
      {"encoder_errors", "%u", &ModuleStatus::encoder_errors},
      {"host_crc_errors", "%u", &ModuleStatus::host_crc_errors},
      {"host_header_errors", "%u", &ModuleStatus::host_header_errors},
      {"host_bytes_skipped", "%u", &ModuleStatus::host_bytes_skipped}};
  return f;
}

// ... then the latest sensor values, then with ROS 2 its counters.
const std::vector<Field<Status>>& sensor_fields() {
  static const std::vector<Field<Status>> f = {
      {"imu_age_s", "%.3f", &Status::imu_age_s},
      {"imu_psi_rad", "%.4f", &Status::imu_psi_rad},
      {"imu_r_radps", "%.4f", &Status::imu_r_radps},
      {"imu_ax_mps2", "%.4f", &Status::imu_ax_mps2},
      {"imu_ay_mps2", "%.4f", &Status::imu_ay_mps2},
      {"pose_age_s", "%.3f", &Status::pose_age_s},
      {"cam_x_m", "%.4f", &Status::cam_x_m},
      {"cam_y_m", "%.4f", &Status::cam_y_m},
      {"cam_psi_rad", "%.4f", &Status::cam_psi_rad},
      {"poses_dropped", "%ld", &Status::poses_dropped}};
  return f;
}

const std::vector<Field<Status>>& ros2_fields() {
  static const std::vector<Field<Status>> f = {{"ros2_applied", "%ld", &Status::ros2_applied},
                                               {"ros2_refused", "%ld", &Status::ros2_refused},
                                               {"ros2_hook_max_us", "%.1f", &Status::ros2_hook_max_us}};
  return f;
}

const std::vector<Field<Status>>& online_fields() {
  static const std::vector<Field<Status>> f = {
      {"online_terrain", "%s", &Status::online_terrain},     {"on_drag_held", "%d", &Status::on_drag_held},
      {"on_sigma_long", "%.4g", &Status::on_sigma_long},
      {"on_sigma_lat", "%.4g", &Status::on_sigma_lat},         {"on_D_x", "%.5g", &Status::on_D_x},
      {"on_D_y", "%.5g", &Status::on_D_y},                     {"on_D_psi", "%.4g", &Status::on_D_psi},
      {"on_sd_sigma_long", "%.2g", &Status::on_sd_sigma_long}, {"on_sd_sigma_lat", "%.2g", &Status::on_sd_sigma_lat},
      {"on_sd_D_x", "%.2g", &Status::on_sd_D_x},               {"on_sd_D_y", "%.2g", &Status::on_sd_D_y},
      {"on_sd_D_psi", "%.2g", &Status::on_sd_D_psi},           {"on_cusum", "%.3g", &Status::on_cusum},
      {"on_changes", "%ld", &Status::on_changes},              {"on_fallback", "%d", &Status::on_fallback}};
  return f;
}

// Named as the log's columns (one list of names for both).
const std::vector<Field<Status>>& feedforward_fields() {
  const std::vector<std::string>& k = feedforward_columns();
  static const std::vector<Field<Status>> f = {{k[0].c_str(), "%.4g", &Status::ff_force_x_n},
                                               {k[1].c_str(), "%.4g", &Status::ff_force_y_n},
                                               {k[2].c_str(), "%.4g", &Status::ff_torque_psi_nm}};
  return f;
}

// An online effect parameter's two fields (Status::on_effects), each key its word and the
// parameter's name: on_eff_<name>=value on_sd_eff_<name>=SD (the prefix carries the key).
const std::vector<Field<Status::OnlineEffect>>& effect_value_field() {
  static const std::vector<Field<Status::OnlineEffect>> f = {{"", "%.4g", &Status::OnlineEffect::value}};
  return f;
}
const std::vector<Field<Status::OnlineEffect>>& effect_sd_field() {
  static const std::vector<Field<Status::OnlineEffect>> f = {{"", "%.2g", &Status::OnlineEffect::sd}};
  return f;
}

template <class S>
void write(const S& s, const std::vector<Field<S>>& fields, const std::string& prefix, std::string& out) {
  char buf[256];
  for (const Field<S>& f : fields) {
    std::visit(
        [&](auto member) {
          const auto& v = s.*member;
          using V = std::decay_t<decltype(v)>;
          if constexpr (std::is_same_v<V, std::string>) std::snprintf(buf, sizeof buf, f.format, v.c_str());
          else if constexpr (std::is_same_v<V, bool>) std::snprintf(buf, sizeof buf, f.format, v ? 1 : 0);
          else if constexpr (std::is_same_v<V, std::uint16_t>) std::snprintf(buf, sizeof buf, f.format, unsigned(v));
          else std::snprintf(buf, sizeof buf, f.format, v);
        },
        f.member);
    out += " " + prefix + f.key + "=" + buf;
  }
}

// The key=value fields of a line, the first word ("status") skipped.
std::map<std::string, std::string> key_values(const std::string& line) {
  std::map<std::string, std::string> kv;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && line[i] == ' ') ++i;
    std::size_t j = i;
    while (j < line.size() && line[j] != ' ') ++j;
    const std::string field = line.substr(i, j - i);
    const auto eq = field.find('=');
    if (eq != std::string::npos) kv[field.substr(0, eq)] = field.substr(eq + 1);
    i = j;
  }
  return kv;
}

// Reads the fields of a struct from the line's key=values; "" or the first problem.
template <class S>
std::string read(const std::map<std::string, std::string>& kv, const std::vector<Field<S>>& fields,
                 const std::string& prefix, S& s) {
  for (const Field<S>& f : fields) {
    const std::string key = prefix + f.key;
    const auto it = kv.find(key);
    if (it == kv.end()) return "no '" + key + "' in the status line";
    const std::string& text = it->second;
    bool ok = true;
    std::visit(
        [&](auto member) {
          auto& v = s.*member;
          using V = std::decay_t<decltype(v)>;
          if constexpr (std::is_same_v<V, std::string>) {
            v = text;
            return;
          } else {
            char* end = nullptr;
            errno = 0;
            // Any double augerd prints, "nan" (a sensor never received) included; an unsigned
            // integer in decimal or, as the status word, 0x hexadecimal.
            if constexpr (std::is_floating_point_v<V>) v = std::strtod(text.c_str(), &end);
            else if constexpr (std::is_same_v<V, bool>) v = std::strtol(text.c_str(), &end, 10) != 0;
            else if constexpr (std::is_signed_v<V>) v = V(std::strtol(text.c_str(), &end, 10));
            else v = V(std::strtoul(text.c_str(), &end, 0));
            ok = !text.empty() && *end == '\0' && errno != ERANGE;
          }
        },
        f.member);
    if (!ok) return "'" + key + "=" + text + "' is not a number";
  }
  return "";
}

}  // namespace

std::string format_status(const Status& s) {
  std::string out = "status";
  write(s, line_fields(), "", out);
  if (!s.all) return out;
  for (int i = 0; i < 4; ++i) write(s.modules[std::size_t(i)], module_fields(), "m" + std::to_string(i) + "_", out);
  write(s, sensor_fields(), "", out);
  if (s.ros2) write(s, ros2_fields(), "", out);
  if (s.online) write(s, online_fields(), "", out);
  if (s.feedforward) write(s, feedforward_fields(), "", out);
  for (const Status::OnlineEffect& e : s.on_effects) {
    write(e, effect_value_field(), "on_eff_" + e.name, out);
    write(e, effect_sd_field(), "on_sd_eff_" + e.name, out);
  }
  return out;
}

std::string parse_status(const std::string& line, Status& out) {
  if (line.rfind("status ", 0) != 0) return "not a status line: " + line.substr(0, 80);
  const auto kv = key_values(line);
  Status s;
  std::string err = read(kv, line_fields(), "", s);
  s.all = kv.count("m0_port") > 0;
  for (int i = 0; s.all && err.empty() && i < 4; ++i)
    err = read(kv, module_fields(), "m" + std::to_string(i) + "_", s.modules[std::size_t(i)]);
  if (s.all && err.empty()) err = read(kv, sensor_fields(), "", s);
  s.ros2 = s.all && kv.count("ros2_applied") > 0;
  if (s.ros2 && err.empty()) err = read(kv, ros2_fields(), "", s);
  s.online = s.all && kv.count("online_terrain") > 0;
  if (s.online && err.empty()) err = read(kv, online_fields(), "", s);
  s.feedforward = s.all && kv.count(feedforward_columns()[0]) > 0;
  if (s.feedforward && err.empty()) err = read(kv, feedforward_fields(), "", s);
  for (const auto& field : kv) {
    const std::string& key = field.first;
    if (!err.empty() || key.rfind("on_eff_", 0) != 0) continue;
    Status::OnlineEffect e;
    e.name = key.substr(7);
    err = read(kv, effect_value_field(), key, e);
    if (err.empty()) err = read(kv, effect_sd_field(), "on_sd_eff_" + e.name, e);
    s.on_effects.push_back(e);
  }
  if (!err.empty()) return err;
  out = s;
  return "";
}

}  // namespace auger::daemon
