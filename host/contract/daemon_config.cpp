// Reader of augerd's TOML configuration (toml++ stays inside this file and the core's model_file.cpp,
// with one kit: auger/toml_kit.hpp).
#include "daemon_config.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>

#include <toml++/toml.h>

#include "auger/effect.hpp"
#include "auger/input_limits.hpp"
#include "auger/model_file.hpp"
#include "auger/toml_kit.hpp"

namespace auger {
namespace {

using auger::ConfigError;

std::string shortest(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

// The model file's TOML kit (auger/toml_kit.hpp) with this file's name and its rules: numbers in
// a range, strings not empty.
struct Reader {
  std::string file;

  [[noreturn]] void fail(const toml::node& n, const std::string& msg) const { toml_kit::fail(file, n, msg); }
  double number(const toml::node& n, const std::string& key, double lo, double hi) const {
    const double v = toml_kit::number(file, n, key);
    if (!std::isfinite(v) || v < lo || v > hi)
      fail(n, "'" + key + "' = " + shortest(v) + " is outside " + shortest(lo) + ".." + shortest(hi));
    return v;
  }
  std::string text(const toml::node& n, const std::string& key) const {
    std::string s = toml_kit::text(file, n, key);
    if (s.empty()) fail(n, "'" + key + "' must not be empty");
    return s;
  }
  auger::Vec3 vec3(const toml::node& n, const std::string& key, double lo, double hi) const {
    const toml::array& a = toml_kit::vec3_array(file, n, key);
    auger::Vec3 v;
    for (int i = 0; i < 3; ++i) v[i] = number(*a.get(static_cast<std::size_t>(i)), key, lo, hi);
    return v;
  }
  // Calls the handler of each key; an unknown key is an error listing the known ones.
  void keys(const toml::table& t, const std::string& where,
            const std::map<std::string, std::function<void(const toml::node&)>>& handlers) const {
    for (auto&& [k, v] : t) {
      const std::string key(k.str());
      auto it = handlers.find(key);
      if (it == handlers.end()) {
        std::string known;
        for (const auto& h : handlers) known += (known.empty() ? "" : ", ") + h.first;
        toml_kit::unknown_key(file, v, key, where, known);
      }
      it->second(v);
    }
  }
  bool boolean(const toml::node& n, const std::string& key) const { return toml_kit::boolean(file, n, key); }
  int line(const toml::node& n) const { return toml_kit::line_of(n); }
  // A socket file's mode: an integer (TOML writes octal as 0o660), owner read-write, and never
  // writable by every user (that would let anyone command the robot).
  unsigned socket_mode(const toml::node& n, const std::string& key) const {
    const double v = number(n, key, 0, 0777);
    const auto m = static_cast<unsigned>(v);
    if (double(m) != v) fail(n, "'" + key + "' must be an integer mode such as 0o660");
    if ((m & 0600) != 0600) fail(n, "'" + key + "' must give augerd's user read and write (0o600)");
    if (m & 0002) fail(n, "'" + key + "' must not let every user write the socket (others' w bit)");
    return m;
  }
  const toml::table& table(const toml::node& n, const std::string& key) const {
    return toml_kit::as_table(file, n, key, " [" + key + "]");
  }
};

std::string resolve(const std::string& config_path, const std::string& p) {
  if (p.empty() || p[0] == '/') return p;
  const auto slash = config_path.rfind('/');
  return slash == std::string::npos ? p : config_path.substr(0, slash + 1) + p;
}

// [ros2] (docs/ros2.md): every key optional; nothing happens unless enabled = true.
void read_ros2(const Reader& r, const toml::table& t, const std::string& path, bool available,
               bool security_stated, auger::ros2::Settings& s) {
  namespace ros2 = auger::ros2;
  auto name_check = [&](const toml::node& v, const std::string& name) {
    try {
      ros2::fully_qualified_name(name, "");
    } catch (const std::invalid_argument& e) {
      r.fail(v, e.what());
    }
  };
  // A topic; an input's may be "" (not subscribed).
  auto topic = [&](std::string& to, bool may_be_empty) {
    return [&r, &to, may_be_empty, name_check](const toml::node& v) {
      if (!v.is_string()) r.fail(v, "a topic must be a string");
      to = *v.value<std::string>();
      if (to.empty() && may_be_empty) return;
      name_check(v, to);
    };
  };
  auto frame = [&](std::string& to) {
    return [&r, &to](const toml::node& v) {
      to = r.text(v, "frame");
      try {
        ros2::check_frame_id(to);
      } catch (const std::invalid_argument& e) {
        r.fail(v, e.what());
      }
    };
  };
  auto rate = [&](double& to, const char* key) {
    return [&r, &to, key](const toml::node& v) { to = r.number(v, key, 0, 100); };
  };
  const toml::node *enabled_at = nullptr, *insecure_at = nullptr;
  r.keys(t, "[ros2]",
         {{"enabled",
           [&](const toml::node& v) {
             s.enabled = r.boolean(v, "enabled");
             enabled_at = &v;
             if (s.enabled && !available)
               r.fail(v, "this augerd was built without the ROS 2 interface (Cyclone DDS): build it with "
                         "-DAUGER_WITH_ROS2=ON (for the board: make board ROS2=1)");
           }},
          {"domain_id", [&](const toml::node& v) {
             const double d = r.number(v, "domain_id", 0, 232);
             if (d != std::floor(d)) r.fail(v, "'domain_id' must be a whole number");
             s.domain_id = int(d);
           }},
          {"dds_config", [&](const toml::node& v) { s.dds_config = resolve(path, r.text(v, "dds_config")); }},
          {"keystore", [&](const toml::node& v) { s.keystore = resolve(path, r.text(v, "keystore")); }},
          {"insecure",
           [&](const toml::node& v) {
             s.insecure = r.boolean(v, "insecure");
             insecure_at = &v;
           }},
          {"local_priority_s", [&](const toml::node& v) { s.local_priority_s = r.number(v, "local_priority_s", 0, 60); }},
          {"namespace",
           [&](const toml::node& v) {
             if (!v.is_string()) r.fail(v, "'namespace' must be a string");
             s.ns = *v.value<std::string>();
             try {
               ros2::fully_qualified_name("x", s.ns);
             } catch (const std::invalid_argument& e) {
               r.fail(v, e.what());
             }
           }},
          {"cmd_vel_topic", topic(s.cmd_vel_topic, true)},
          {"cmd_vel_stamped_topic", topic(s.cmd_vel_stamped_topic, true)},
          {"pose_topic", topic(s.pose_topic, true)},
          {"pose_cov_topic", topic(s.pose_cov_topic, true)},
          {"imu_topic", topic(s.imu_topic, true)},
          {"pose_std",
           [&](const toml::node& v) {
             // The sensors socket's bounds (input_limits.hpp): a value every pose would be refused for
             // is an error here, not a silent refusal of every PoseStamped.
             const auger::Vec3 sd = r.vec3(v, "pose_std", auger::limits::kPositionSd.lo, auger::limits::kPositionSd.hi);
             if (const std::string e = auger::check_bound("pose_std[2]", sd[2], auger::limits::kHeadingSd); !e.empty())
               r.fail(v, e);
             s.pose_std = {sd[0], sd[1], sd[2]};
           }},
          {"odom_topic", topic(s.odom_topic, false)},
          {"joint_states_topic", topic(s.joint_states_topic, false)},
          {"diagnostics_topic", topic(s.diagnostics_topic, false)},
          {"tf_topic", topic(s.tf_topic, false)},
          {"online_topic", topic(s.online_topic, false)},
          {"odom_rate_hz", rate(s.odom_rate_hz, "odom_rate_hz")},
          {"joint_states_rate_hz", rate(s.joint_states_rate_hz, "joint_states_rate_hz")},
          {"diagnostics_rate_hz", rate(s.diagnostics_rate_hz, "diagnostics_rate_hz")},
          {"online_rate_hz", rate(s.online_rate_hz, "online_rate_hz")},
          {"tf", [&](const toml::node& v) { s.tf = r.boolean(v, "tf"); }},
          {"odom_frame", frame(s.odom_frame)},
          {"base_frame", frame(s.base_frame)},
          {"joint_names", [&](const toml::node& v) {
             const toml::array* a = v.as_array();
             if (!a || a->size() != 4) r.fail(v, "'joint_names' must be an array of 4 names (screws 0..3)");
             for (std::size_t i = 0; i < 4; ++i) {
               s.joint_names[i] = r.text(*a->get(i), "joint_names");
               frame(s.joint_names[i])(*a->get(i));
             }
           }}});
  // Who may command the robot over DDS is stated, never a default (docs/ros2.md).
  if (s.insecure && !s.keystore.empty())
    r.fail(*insecure_at, "'insecure = true' and 'keystore' contradict each other: give one of them");
  if (security_stated && s.enabled && !s.insecure && s.keystore.empty())
    r.fail(*enabled_at,
           "[ros2] enabled without DDS Security: give 'keystore' (made by `auger ros2-keys create`), or "
           "'insecure = true' to let anyone who reaches DDS domain " + std::to_string(s.domain_id) +
               " command the robot (docs/ros2.md)");
}

// [online] (docs/daemon.md "Online identification"): off unless enabled = true.
void read_online(const Reader& r, const toml::table& t, DaemonConfig& c) {
  auger::OnlineConfig& o = c.online;
  r.keys(t, "[online]",
         {{"enabled", [&](const toml::node& v) { o.enabled = r.boolean(v, "enabled"); }},
          {"apply", [&](const toml::node& v) { c.online_apply = r.boolean(v, "apply"); }},
          {"velocity_sd", [&](const toml::node& v) { o.velocity_sd = r.vec3(v, "velocity_sd", 1e-5, 1); }},
          {"memory_s", [&](const toml::node& v) { o.memory_s = r.number(v, "memory_s", 0.5, 600); }},
          {"detect_memory_s",
           [&](const toml::node& v) { o.detect_memory_s = r.number(v, "detect_memory_s", 0, 600); }},
          {"cusum_threshold", [&](const toml::node& v) { o.cusum_threshold = r.number(v, "cusum_threshold", 1, 1000); }},
          {"apply_rel_sd", [&](const toml::node& v) { o.apply_rel_sd = r.number(v, "apply_rel_sd", 0.001, 1); }},
          {"drag_prior_rel_sd",
           [&](const toml::node& v) { o.drag_prior_rel_sd = r.number(v, "drag_prior_rel_sd", 1e-4, 10); }},
          {"slow_screw_rpm", [&](const toml::node& v) { o.slow_screw_rpm = r.number(v, "slow_screw_rpm", 0, 50); }},
          {"slow_screw_guard_s",
           [&](const toml::node& v) { o.slow_screw_guard_s = r.number(v, "slow_screw_guard_s", 0, 0.5); }},
          {"accelerometer", [&](const toml::node& v) { c.online_kin.use_accelerometer = r.boolean(v, "accelerometer"); }},
          {"acc_noise_mps2_per_sqrt_hz",
           [&](const toml::node& v) {
             c.online_kin.acc_noise_mps2_per_sqrt_hz = r.number(v, "acc_noise_mps2_per_sqrt_hz", 1e-6, 1);
           }},
          {"acc_bias_walk_mps2_per_sqrt_s",
           [&](const toml::node& v) {
             c.online_kin.acc_bias_walk_mps2_per_sqrt_s = r.number(v, "acc_bias_walk_mps2_per_sqrt_s", 1e-7, 1);
           }},
          {"acc_gravity_walk_mps2_per_sqrt_s",
           [&](const toml::node& v) {
             c.online_kin.acc_gravity_walk_mps2_per_sqrt_s = r.number(v, "acc_gravity_walk_mps2_per_sqrt_s", 0, 1);
           }},
          {"camera_noise_corr_s",
           [&](const toml::node& v) { c.online_kin.pose_noise_corr_s = r.number(v, "camera_noise_corr_s", 0, 60); }},
          {"acc_bias_sd_mps2",
           [&](const toml::node& v) { c.online_kin.acc_bias_sd_mps2 = r.number(v, "acc_bias_sd_mps2", 1e-4, 10); }},
          {"velocity", [&](const toml::node& v) {
             const std::string s = r.text(v, "velocity");
             if (s != "ekf" && s != "kinematic") r.fail(v, "velocity must be \"ekf\" or \"kinematic\", not \"" + s + "\"");
             c.online_kinematic = s == "kinematic";
           }}});
}

// What the tables leave to the checks made after the model file is read: which required keys
// came, and the [control] values that apply over the model file's defaults.
struct Pending {
  bool have_ports = false, have_model = false, have_cmd = false, have_sens = false, have_log = false;
  std::vector<std::function<void()>> control_overrides;
  std::string allocator_text;
};

void read_serial(const Reader& r, const toml::table& t, DaemonConfig& c, Pending& p) {
  r.keys(t, "[serial]",
         {{"ports",
           [&](const toml::node& v) {
             const toml::array* a = v.as_array();
             if (!a || a->size() != 4) r.fail(v, "'ports' must be an array of 4 port paths");
             for (std::size_t i = 0; i < 4; ++i) c.ports[i] = r.text(*a->get(i), "ports");
             for (std::size_t i = 0; i < 4; ++i)
               for (std::size_t j = 0; j < i; ++j)
                 if (c.ports[i] == c.ports[j]) r.fail(v, "port '" + c.ports[i] + "' is listed twice");
             p.have_ports = true;
           }},
          {"baud", [&](const toml::node& v) { c.baud = unsigned(r.number(v, "baud", 1200, 4000000)); }},
          {"identity_timeout_s",
           [&](const toml::node& v) { c.identity_timeout_s = r.number(v, "identity_timeout_s", 0.1, 30); }},
          {"telemetry_timeout_s", [&](const toml::node& v) {
             c.telemetry_timeout_s = r.number(v, "telemetry_timeout_s", 0.02, 0.25);
             c.line_telemetry_timeout = r.line(v);
           }}});
}

void read_model(const Reader& r, const toml::table& t, DaemonConfig& c, Pending& p) {
  r.keys(t, "[model]",
         {{"file",
           [&](const toml::node& v) {
             c.model_file = resolve(c.path, r.text(v, "file"));
             p.have_model = true;
           }},
          {"terrain", [&](const toml::node& v) { c.terrain = r.text(v, "terrain"); }}});
}

// [control]: the loop's own keys at once; the controller's after the model file's defaults.
void read_control(const Reader& r, const toml::table& t, DaemonConfig& c, Pending& p) {
  auto later = [&p](std::function<void()> f) { p.control_overrides.push_back(std::move(f)); };
  auto vec3 = [&](auger::Vec3 auger::ControllerConfig::*group, const char* key, double lo, double hi) {
    return [&r, &c, later, group, key, lo, hi](const toml::node& v) {
      const auger::Vec3 x = r.vec3(v, key, lo, hi);
      later([&c, group, x] { c.controller.*group = x; });
    };
  };
  auto gain = [&](auger::Vec3 auger::PidGains::*member, const char* key) {
    return [&r, &c, later, member, key](const toml::node& v) {
      const auger::Vec3 x = r.vec3(v, key, 0, 1e6);
      later([&c, member, x] { c.controller.gains.*member = x; });
    };
  };
  auto rpm = [&](double auger::AllocatorConfig::*member, const char* key, double lo, int* line) {
    return [&r, &c, later, member, key, lo, line](const toml::node& v) {
      const double x = r.number(v, key, lo, 327);
      if (line) *line = r.line(v);
      later([&c, member, x] { c.controller.allocator.*member = x; });
    };
  };
  r.keys(t, "[control]",
         {{"period_s",
           [&](const toml::node& v) {
             c.period_s = r.number(v, "period_s", 0.002, 0.1);
             c.line_period = r.line(v);
           }},
          {"vel_timeout_s", [&](const toml::node& v) { c.vel_timeout_s = r.number(v, "vel_timeout_s", 0.05, 5); }},
          {"realtime_priority",
           [&](const toml::node& v) { c.realtime_priority = int(r.number(v, "realtime_priority", 0, 99)); }},
          {"allocator",
           [&](const toml::node& v) {
             p.allocator_text = r.text(v, "allocator");
             if (p.allocator_text != "pinv" && p.allocator_text != "nullspace")
               r.fail(v, "allocator must be \"pinv\" or \"nullspace\", not \"" + p.allocator_text + "\"");
           }},
          {"priority",
           [&](const toml::node& v) {
             std::string pr = r.text(v, "priority");
             if (pr != "yaw" && pr != "translation")
               r.fail(v, "priority must be \"yaw\" or \"translation\", not \"" + pr + "\"");
             later([&c, pr] {
               c.controller.allocator.priority =
                   pr == "yaw" ? auger::AllocationPriority::yaw : auger::AllocationPriority::translation;
             });
           }},
          {"estimator",
           [&](const toml::node& v) {
             std::string e = r.text(v, "estimator");
             auger::EstimatorKind k;
             if (e == "ekf") k = auger::EstimatorKind::ekf;
             else if (e == "dead_reckoning") k = auger::EstimatorKind::dead_reckoning;
             else if (e == "dead_reckoning_imu") k = auger::EstimatorKind::dead_reckoning_imu;
             else r.fail(v, "estimator must be ekf, dead_reckoning or dead_reckoning_imu, not \"" + e + "\"");
             later([&c, k] { c.controller.estimator = k; });
           }},
          {"effect_feedforward",
           [&](const toml::node& v) {
             const bool on = r.boolean(v, "effect_feedforward");
             later([&c, on] { c.controller.effect_feedforward = on; });
           }},
          {"omega_max_rpm", rpm(&auger::AllocatorConfig::omega_max_rpm, "omega_max_rpm", 0.1, &c.line_omega_max)},
          {"omega_min_rpm", rpm(&auger::AllocatorConfig::omega_min_rpm, "omega_min_rpm", 0, &c.line_omega_min)},
          {"engage_rpm", rpm(&auger::AllocatorConfig::engage_rpm, "engage_rpm", 0, nullptr)},
          {"sign_hold_rpm", rpm(&auger::AllocatorConfig::sign_hold_rpm, "sign_hold_rpm", 0, nullptr)},
          {"gamma_per_s", vec3(&auger::ControllerConfig::gamma_per_s, "gamma_per_s", 1e-3, 100)},
          {"kp", gain(&auger::PidGains::kp, "kp")},
          {"ki", gain(&auger::PidGains::ki, "ki")},
          {"kd", gain(&auger::PidGains::kd, "kd")},
          {"integral_limit", gain(&auger::PidGains::integral_limit, "integral_limit")}});
}

void read_sockets(const Reader& r, const toml::table& t, DaemonConfig& c, Pending& p) {
  r.keys(t, "[sockets]",
         {{"commands",
           [&](const toml::node& v) {
             c.commands_socket = resolve(c.path, r.text(v, "commands"));
             p.have_cmd = true;
           }},
          {"sensors",
           [&](const toml::node& v) {
             c.sensors_socket = resolve(c.path, r.text(v, "sensors"));
             p.have_sens = true;
           }},
          {"commands_mode", [&](const toml::node& v) { c.commands_mode = r.socket_mode(v, "commands_mode"); }},
          {"sensors_mode", [&](const toml::node& v) { c.sensors_mode = r.socket_mode(v, "sensors_mode"); }},
          {"commands_group",
           [&](const toml::node& v) {
             c.commands_group = r.text(v, "commands_group");
             c.line_commands_group = r.line(v);
           }},
          {"sensors_group",
           [&](const toml::node& v) {
             c.sensors_group = r.text(v, "sensors_group");
             c.line_sensors_group = r.line(v);
           }},
          {"idle_timeout_s",
           [&](const toml::node& v) { c.idle_timeout_s = r.number(v, "idle_timeout_s", 0.5, 3600); }}});
}

void read_log(const Reader& r, const toml::table& t, DaemonConfig& c, Pending& p) {
  r.keys(t, "[log]",
         {{"dir",
           [&](const toml::node& v) {
             c.log_dir = resolve(c.path, r.text(v, "dir"));
             p.have_log = true;
           }},
          {"rotate_bytes",
           [&](const toml::node& v) { c.log_rotate_bytes = std::uint64_t(r.number(v, "rotate_bytes", 4096, 1e12)); }},
          {"flush_interval_s",
           [&](const toml::node& v) { c.log_flush_interval_s = r.number(v, "flush_interval_s", 0.01, 1.0); }},
          {"fsync_interval_s",
           [&](const toml::node& v) { c.log_fsync_interval_s = r.number(v, "fsync_interval_s", 0.1, 3600); }},
          {"mcap", [&](const toml::node& v) { c.log_mcap = r.boolean(v, "mcap"); }}});
}

// The required keys, the sockets' paths, the [ros2] names together.
void check_tables(const DaemonConfig& c, const Pending& p) {
  const std::string& path = c.path;
  auto missing = [&](const std::string& what) { throw ConfigError(path, 1, 1, "missing " + what); };
  if (!p.have_ports) missing("[serial] ports (four port paths)");
  if (!p.have_model) missing("[model] file");
  if (!p.have_cmd) missing("[sockets] commands");
  if (!p.have_sens) missing("[sockets] sensors");
  if (!p.have_log) missing("[log] dir");
  if (c.commands_socket == c.sensors_socket) throw ConfigError(path, 1, 1, "the two sockets need different paths");
  // sockaddr_un holds 108 bytes including the terminating zero.
  for (const auto* s : {&c.commands_socket, &c.sensors_socket})
    if (s->size() > 107) throw ConfigError(path, 1, 1, "socket path too long (max 107 bytes): " + *s);

  try {
    auger::ros2::check_settings(c.ros2);  // the namespace with each topic, the frames
  } catch (const std::invalid_argument& e) {
    throw ConfigError(path, 1, 1, std::string("[ros2]: ") + e.what());
  }
}

// The model file (its own errors name that file); then this file's overrides.
void apply_model(DaemonConfig& c, const Pending& p) {
  c.model = auger::load_model_file(c.model_file);
  const auger::ModelFile& model = c.model;
  if (!model.find_terrain(c.terrain))
    throw ConfigError(c.path, 1, 1, "terrain '" + c.terrain + "' is not in " + c.model_file);
  c.controller = auger::controller_config(model, c.terrain);
  if (c.online.enabled && !(model.find_terrain(c.terrain)->params.D_psi > 0))
    throw ConfigError(c.path, 1, 1, "[online] enabled needs D_psi of terrain '" + c.terrain + "' in " + c.model_file);
  for (auto& f : p.control_overrides) f();
  if (p.allocator_text == "pinv") c.controller.allocator.kind = auger::AllocatorKind::pseudo_inverse;
  if (p.allocator_text == "nullspace") c.controller.allocator.kind = auger::AllocatorKind::null_space;
}

// Values that must be ordered, wherever each came from (this file, the model file, Table 5).
void check_order(const DaemonConfig& c) {
  const std::string& path = c.path;
  auto from = [&](int line) { return line > 0 ? path + ":" + std::to_string(line) : "the model file " + c.model_file; };
  const auto& a = c.controller.allocator;
  if (a.omega_min_rpm > a.omega_max_rpm)
    throw ConfigError(path, std::max(c.line_omega_min ? c.line_omega_min : c.line_omega_max, 1), 1,
                      "omega_min_rpm = " + shortest(a.omega_min_rpm) + " (" + from(c.line_omega_min) +
                          ") is above omega_max_rpm = " + shortest(a.omega_max_rpm) + " (" + from(c.line_omega_max) +
                          "): no screw speed satisfies both");
  if (c.telemetry_timeout_s < 2 * c.period_s)
    throw ConfigError(path, std::max(c.line_telemetry_timeout ? c.line_telemetry_timeout : c.line_period, 1), 1,
                      "telemetry_timeout_s = " + shortest(c.telemetry_timeout_s) + " is shorter than two loop periods (" +
                          "period_s = " + shortest(c.period_s) + "): every module would count as lost");
  if (c.vel_timeout_s < 2 * c.period_s)
    throw ConfigError(path, std::max(c.line_period, 1), 1,
                      "vel_timeout_s = " + shortest(c.vel_timeout_s) + " is shorter than two loop periods");
}

}  // namespace

DaemonConfig read_daemon_config(const std::string& path, bool ros2_available, bool ros2_security_stated) {
  DaemonConfig c;
  c.path = path;
  Reader r{path};
  toml::table root;
  try {
    root = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    const auto& src = e.source();
    throw ConfigError(path, static_cast<int>(src.begin.line), static_cast<int>(src.begin.column),
                      std::string(e.description()));
  }
  Pending p;
  auto section = [&](void (*read)(const Reader&, const toml::table&, DaemonConfig&, Pending&), const char* name) {
    return [&r, &c, &p, read, name](const toml::node& n) { read(r, r.table(n, name), c, p); };
  };
  r.keys(root, "the top level",
         {{"schema",
           [&](const toml::node& n) {
             if (r.number(n, "schema", 1, 1) != 1) r.fail(n, "schema must be 1");
           }},
          {"serial", section(read_serial, "serial")},
          {"model", section(read_model, "model")},
          {"control", section(read_control, "control")},
          {"sockets", section(read_sockets, "sockets")},
          {"ros2",
           [&](const toml::node& n) {
             read_ros2(r, r.table(n, "ros2"), path, ros2_available, ros2_security_stated, c.ros2);
           }},
          {"online", [&](const toml::node& n) { read_online(r, r.table(n, "online"), c); }},
          {"log", section(read_log, "log")}});
  check_tables(c, p);
  apply_model(c, p);
  check_order(c);
  return c;
}

}  // namespace auger
