// augerd: the I/O shell around auger_core's controller (DESIGN.md): four motor modules on
// serial ports, the 100 Hz loop on CLOCK_MONOTONIC, the command and sensor sockets
// (docs/daemon-protocol.md), the robot log, and the safety rules. docs/daemon.md.
#include <algorithm>
#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <sched.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "auger/controller.hpp"
#include "auger/effect.hpp"
#include "auger/log.hpp"
#include "auger/model_file.hpp"
#include "config.hpp"
#include "line_server.hpp"
#include "lines.hpp"
#include "module_link.hpp"
#include "ros2.hpp"
#include "status_text.hpp"

namespace augerd {
namespace {

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

double clock_s(clockid_t id) {
  timespec ts;
  clock_gettime(id, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// Exit codes (docs/daemon.md).
constexpr int kExitOk = 0, kExitStartup = 1, kExitConfig = 2;

// 16-bit sequence numbers wrap: a is at or after b when the signed difference is >= 0.
bool seq_at_or_after(uint16_t a, uint16_t b) { return int16_t(uint16_t(a - b)) >= 0; }

using auger::io::fault_bits_text;  // every call has a fault bit set

struct Module {
  std::string port;
  std::unique_ptr<auger::io::ModuleLink> link;  // null while the port is closed after a failure
  proto_identity_t identity{};
  bool identified = false;   // after a reopen: telemetry counts only once the identity matched
  bool have_tm = false;
  proto_telemetry_t tm{};    // latest telemetry (keyed on the module's time_ms)
  bool fresh = false;        // a newer telemetry frame arrived this cycle
  double last_valid_s = 0;   // loop time of the last valid telemetry
  uint64_t bytes_at_valid = 0;    // bytes received up to the last valid telemetry
  bool lost = false;         // no valid telemetry for telemetry_timeout_s, or the port failed
  double reopen_at_s = 0;    // next reopen attempt after a port failure
  double request_at_s = 0;   // next identity request after a reopen
  uint16_t seq = 0;          // next setpoint sequence number
  uint8_t telemetry_period_ms = 10;  // the module's setting (CONFIG_REPORT): augerd follows it
  bool clearing = false;     // CLEAR_FAULTS is sent until the module acknowledges clear_seq
  uint16_t clear_seq = 0;
};

class Daemon {
 public:
  Daemon(const DaemonConfig& cfg, auger::Model model)
      : cfg_(cfg), model_(std::move(model)), ctrl_cfg_(cfg.controller) {
    controller_ = std::make_unique<auger::Controller>(model_, ctrl_cfg_);
  }

  // Opens the ports, identifies the modules and maps them by id. Throws runtime_error.
  void open_modules();
  void open_sockets() {
    commands_ = std::make_unique<LineServer>(cfg_.commands_socket);
    sensors_ = std::make_unique<LineServer>(cfg_.sensors_socket);
  }
  void open_log();
  // The ROS 2 interface when [ros2] enabled (docs/ros2.md). Throws runtime_error.
  void open_ros2() {
    if (cfg_.ros2.enabled) ros2_ = auger::ros2::make_bridge(cfg_.ros2);
    if (ros2_) std::fprintf(stderr, "augerd: ROS 2 on DDS, %s\n", ros2_->describe().c_str());
  }
  void run();

 private:
  void pump(Module& m, int index);
  void check_safety();
  void fault(int module, const std::string& reason_token, const std::string& detail);
  std::string command(const std::string& line);
  std::string sensor(const std::string& line);
  std::string status_line() const;
  void send_setpoints(const std::array<double, 4>& rpm, bool enable);
  void write_log(const std::array<double, 4>& cmd_rpm);
  void log_failed(const std::string& what);
  bool start_log_file();
  void event(int module, const std::string& what, const std::string& action);
  std::string modules_status() const;
  void disable_controller() {
    controller_->set_enabled(false);
    ctrl_events_ |= kEvDisabled;
  }
  void check_arrival();
  int save_trajectory();
  void ros2_inputs();
  void ros2_publish();
  void ros2_refused(const std::string& why);
  static constexpr double kArrivedM = 0.02, kArrivedRad = 0.05;  // docs/daemon.md, "arrived"

  const DaemonConfig& cfg_;
  auger::Model model_;
  auger::ControllerConfig ctrl_cfg_;
  std::unique_ptr<auger::Controller> controller_;
  std::array<Module, 4> modules_;  // index = module id = screw index
  std::unique_ptr<LineServer> commands_, sensors_;

  double t0_mono_s_ = 0, t0_unix_s_ = 0;
  double t_s_ = 0;            // loop time of this cycle (CLOCK_MONOTONIC since start)
  double mono_to_unix_s_ = 0; // CLOCK_REALTIME - CLOCK_MONOTONIC now, for sensor timestamps
  double loop_dt_s_ = 0;
  double jitter_max_s_ = 0;   // over the last second, for `status`

  bool enabled_ = false;
  std::string mode_ = "stopped";  // stopped, idle, vel, goto, follow
  auger::Vec3 vel_cmd_ = auger::Vec3::Zero();
  double vel_until_s_ = 0;
  std::vector<auger::Waypoint> waypoints_;
  double motion_t0_s_ = 0;    // goto/follow: loop time the motion started (its waypoint clock)
  bool arrived_ = false;      // goto/follow: past the last waypoint and at the final pose
  int spin_module_ = -1;      // `spin`: one module at spin_rpm_, the others 0 (auger step, calib)
  double spin_rpm_ = 0;
  int fault_module_ = -1;
  std::string fault_reason_ = "none";

  auger::SensorInput sensors_in_;
  auger::Vec3 pose_sd_ = auger::Vec3::Constant(NAN);  // standard deviations of this cycle's pose
  // Latest sensor values whenever they came (status all: calib and teleop checks).
  double last_imu_t_s_ = NAN, last_imu_r_radps_ = NAN, last_imu_psi_rad_ = NAN;
  double last_pose_t_s_ = NAN;
  auger::Vec3 last_pose_ = auger::Vec3::Constant(NAN);

  // What changed the core controller's state this cycle, before its step (log column
  // ctrl_events, so that auger replay applies the same changes in the same cycle).
  static constexpr int kEvDisabled = 1, kEvWaypoints = 2, kEvRebuilt = 4;
  int ctrl_events_ = 0;
  auger::Vec3 goal_ = auger::Vec3::Constant(NAN);  // goto of this cycle
  int traj_n_ = 0;          // follow files copied beside the log (…-follow-N.waypoints)
  int traj_logged_ = -1;    // the follow file of this cycle, -1 none
  std::string run_name_;    // augerd-<UTC start>: names the log files of this run
  std::FILE* events_ = nullptr;
  std::string events_path_;

  // log
  std::unique_ptr<std::ofstream> log_file_;
  std::unique_ptr<auger::RobotLogWriter> log_;
  std::string log_path_;
  int log_index_ = 0;
  bool log_broken_ = false;
  double log_retry_at_s_ = 0;
  double log_flushed_at_s_ = 0;
  std::array<double, 4> last_cmd_rpm_{};

  // ROS 2 (null unless enabled): what its inputs did, and the time the loop spends on it.
  std::unique_ptr<auger::ros2::Bridge> ros2_;
  auger::ros2::Snapshot ros2_out_;
  long ros2_applied_ = 0, ros2_refused_ = 0;
  std::string ros2_last_refusal_;
  double ros2_said_at_s_ = -1e9;  // refusals are printed at most every 5 s
  long ros2_unsaid_ = 0;
  // The loop's time inside Bridge::poll and Bridge::publish (docs/benchmarks.md): this cycle's,
  // the longest over the last whole second (status all, diagnostics), and over the run; wall
  // time, and the loop thread's CPU time (wall minus CPU: the thread was preempted, not
  // waiting: nothing in there waits).
  double ros2_cycle_us_ = 0, ros2_window_max_us_ = 0, ros2_window_start_s_ = 0, ros2_hook_us_max_ = 0;
  double ros2_sum_us_ = 0, ros2_max_all_us_ = 0;
  double ros2_cycle_cpu_us_ = 0, ros2_sum_cpu_us_ = 0, ros2_max_cpu_us_ = 0;
  long ros2_cycles_ = 0;
};

using Links = std::array<std::unique_ptr<auger::io::ModuleLink>, 4>;

// Pumps the four links until each has sent a frame `decode` accepts (into T), or throws after
// timeout_s naming the ports and `what`; `between(waited_s, got)` runs between rounds.
template <typename T, typename Decode, typename Between>
std::array<T, 4> collect_frames(Links& links, const std::array<std::string, 4>& ports, double timeout_s,
                                const std::string& what, Decode decode, Between between) {
  std::array<std::optional<T>, 4> got;
  const double start = clock_s(CLOCK_MONOTONIC);
  std::vector<proto_frame_t> frames;
  for (;;) {
    bool all = true;
    for (std::size_t i = 0; i < 4; ++i) {
      frames.clear();
      links[i]->pump(frames);
      for (const auto& f : frames) {
        T v;
        if (!got[i] && decode(&f, &v)) got[i] = v;
      }
      all = all && got[i];
    }
    if (all) break;
    const double waited = clock_s(CLOCK_MONOTONIC) - start;
    between(waited, got);
    if (waited > timeout_s) {
      std::string missing;
      for (std::size_t i = 0; i < 4; ++i)
        if (!got[i]) missing += " " + ports[i];
      throw std::runtime_error("no " + what + " within " + std::to_string(timeout_s) + " s from the module(s) on" +
                               missing + " (powered? right port and baud?)");
    }
    usleep(2000);
  }
  std::array<T, 4> out;
  for (std::size_t i = 0; i < 4; ++i) out[i] = *got[i];
  return out;
}

// REQUEST frame; timeout_s 0 in the loop: never wait for room in the port.
void request(auger::io::ModuleLink& link, uint8_t what, double timeout_s = 1.0) {
  uint8_t buf[PROTO_MAX_FRAME];
  proto_request_t rq{what};
  link.send_frame(buf, proto_encode_request(&rq, buf), timeout_s);
}

void Daemon::open_modules() {
  Links links;
  // Open every port first: each open resets its module (DTR), so they boot in parallel.
  for (std::size_t i = 0; i < 4; ++i) links[i] = std::make_unique<auger::io::ModuleLink>(cfg_.ports[i], cfg_.baud);
  bool asked = false;
  const auto ids = collect_frames<proto_identity_t>(
      links, cfg_.ports, cfg_.identity_timeout_s, "identity frame", proto_decode_identity,
      [&](double waited, const std::array<std::optional<proto_identity_t>, 4>& got) {
        // A module that was not reset by the open (no DTR) never sends one by itself: ask
        // late, after the bootloader's time, so the request does not go to the bootloader.
        if (asked || waited <= 0.75 * cfg_.identity_timeout_s) return;
        for (std::size_t i = 0; i < 4; ++i)
          if (!got[i]) request(*links[i], PROTO_T_IDENTITY);
        asked = true;
      });
  std::array<int, 4> port_of_id{-1, -1, -1, -1};
  for (std::size_t i = 0; i < 4; ++i) {
    const proto_identity_t& id = ids[i];
    auger::io::require_protocol(id, cfg_.ports[i], "augerd");
    if (id.module_id > 3)
      throw std::runtime_error(cfg_.ports[i] + ": module id " + std::to_string(id.module_id) +
                               " is not a screw index 0..3 (set it with auger-module PORT set id=N)");
    if (port_of_id[id.module_id] >= 0)
      throw std::runtime_error("duplicate module id " + std::to_string(id.module_id) + " on " +
                               cfg_.ports[std::size_t(port_of_id[id.module_id])] + " and " + cfg_.ports[i]);
    port_of_id[id.module_id] = int(i);
  }
  // Each module's telemetry period (its settings): the no-telemetry timeout follows it.
  for (auto& link : links) request(*link, PROTO_T_CONFIG_REPORT);
  const auto cfgs = collect_frames<proto_config_t>(links, cfg_.ports, cfg_.identity_timeout_s, "settings report",
                                                   proto_decode_config_report, [](double, const auto&) {});
  // Four ports with four distinct ids in 0..3: every id is present.
  const double now = clock_s(CLOCK_MONOTONIC);
  for (std::size_t k = 0; k < 4; ++k) {
    const std::size_t i = std::size_t(port_of_id[k]);
    Module& m = modules_[k];
    m.port = cfg_.ports[i];
    m.link = std::move(links[i]);
    m.identity = ids[i];
    m.identified = true;
    m.telemetry_period_ms = cfgs[i].telemetry_period_ms;
    m.last_valid_s = now;  // converted to loop time in run()
    std::fprintf(stderr,
                 "augerd: module %zu on %s (firmware %u.%u.%u, protocol %u, telemetry every %u ms, settings from %s, "
                 "last reset: %s)\n",
                 k, m.port.c_str(), m.identity.fw_major, m.identity.fw_minor, m.identity.fw_patch,
                 m.identity.protocol_version, m.telemetry_period_ms,
                 auger::io::settings_origin_text(m.identity.flags).c_str(),
                 auger::io::reset_cause_text(m.identity.reset_cause).c_str());
  }
}

// No valid telemetry this long: the module is lost. The configured timeout, or two of the
// module's telemetry periods and a control period, whichever is longer.
double telemetry_timeout_s(const DaemonConfig& cfg, const Module& m) {
  return std::max(cfg.telemetry_timeout_s, (2.0 * m.telemetry_period_ms + 10.0) / 1000.0);
}

// ---- log ----

// Columns beyond LOG-FORMAT.md's (docs/daemon.md "The log"): what `auger replay` needs to run
// the core's estimator and controller again on this log and compare.
const std::vector<std::string>& replay_columns() {
  static const std::vector<std::string> cols = {
      "mode",      "ctrl_events", "ctrl_enabled", "alloc_nullspace", "goal_x_m",  "goal_y_m",
      "goal_psi_rad", "traj_n",   "tm_fresh_0",  "tm_fresh_1",      "tm_fresh_2", "tm_fresh_3",
      "pose_sx_m", "pose_sy_m",   "pose_spsi_rad", "pose_capture_t_s", "vel_u_mps",     "vel_v_mps", "vel_r_radps",
      "spin_module", "spin_rpm",  "xe_m",        "ye_m",            "psie_rad"};
  return cols;
}

// Mode codes of the log's `mode` column.
int mode_code(const std::string& mode) {
  static const char* names[] = {"stopped", "idle", "vel", "goto", "follow", "hold", "spin"};
  for (int i = 0; i < 7; ++i)
    if (mode == names[i]) return i;
  return -1;
}

bool Daemon::start_log_file() {
  char stamp[32];
  const std::time_t now = std::time(nullptr);
  std::tm tm_utc;
  gmtime_r(&now, &tm_utc);
  std::strftime(stamp, sizeof stamp, "%Y%m%dT%H%M%SZ", &tm_utc);
  if (run_name_.empty()) run_name_ = std::string("augerd-") + stamp;
  log_path_ = cfg_.log_dir + "/augerd-" + stamp + "-" + std::to_string(log_index_++) + ".csv";
  log_.reset();
  log_file_ = std::make_unique<std::ofstream>(log_path_, std::ios::out | std::ios::trunc);
  if (!*log_file_) return false;
  char t0[64];
  std::snprintf(t0, sizeof t0, "%.6f", t0_unix_s_);
  log_ = std::make_unique<auger::RobotLogWriter>(
      *log_file_, std::vector<std::pair<std::string, std::string>>{{"format", auger::kRobotLogFormat},
                                                                   {"terrain", cfg_.terrain},
                                                                   {"t0_unix_s", t0},
                                                                   {"writer", "augerd"},
                                                                   {"run", run_name_}},
      replay_columns());
  log_->flush();
  return bool(*log_file_);
}

void Daemon::open_log() {
  struct stat st;
  if (::stat(cfg_.log_dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
    throw std::runtime_error("log directory " + cfg_.log_dir + " does not exist");
  if (::access(cfg_.log_dir.c_str(), W_OK) != 0)
    throw std::runtime_error("log directory " + cfg_.log_dir + " is not writable");
  t0_unix_s_ = clock_s(CLOCK_REALTIME);
  if (!start_log_file()) throw std::runtime_error("cannot create the log file " + log_path_);
  std::fprintf(stderr, "augerd: logging to %s\n", log_path_.c_str());
  // The fault event log: one line per event, flushed at once (a fault is what one reads
  // after a crash). Not rotated: a few lines per fault.
  events_path_ = cfg_.log_dir + "/" + run_name_ + "-events.log";
  events_ = std::fopen(events_path_.c_str(), "a");
  if (!events_) throw std::runtime_error("cannot create the event log " + events_path_ + ": " + std::strerror(errno));
  std::fprintf(events_, "# auger event log v1: wall-clock UTC, t_s (the data log's clock), module, port, event, action\n");
  event(-1, "start", "augerd started, robot stopped; data log " + log_path_);
}

void Daemon::event(int module, const std::string& what, const std::string& action) {
  if (!events_) return;
  const double wall = t0_unix_s_ + t_s_;
  const std::time_t sec = std::time_t(wall);
  std::tm tm_utc;
  gmtime_r(&sec, &tm_utc);
  char stamp[40];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%S", &tm_utc);
  const std::string port = module >= 0 ? modules_[std::size_t(module)].port : "-";
  const std::string mod = module >= 0 ? std::to_string(module) : "-";
  std::fprintf(events_, "%s.%03dZ t_s=%.3f module=%s port=%s event=%s action=\"%s\"\n", stamp,
               int((wall - double(sec)) * 1000), t_s_, mod.c_str(), port.c_str(), what.c_str(), action.c_str());
  // A write error (full disk) must not stop control: the data log reports it.
  std::fflush(events_);
}

void Daemon::log_failed(const std::string& what) {
  // Reported once per failure; control goes on without the log and a new file is tried later.
  if (!log_broken_)
    std::fprintf(stderr, "augerd: log %s: %s failed (%s); control goes on, retrying every 10 s\n", log_path_.c_str(),
                 what.c_str(), std::strerror(errno));
  log_broken_ = true;
  log_.reset();
  log_file_.reset();
  log_retry_at_s_ = t_s_ + 10.0;
}

void Daemon::write_log(const std::array<double, 4>& cmd_rpm) {
  if (log_broken_) {
    if (t_s_ < log_retry_at_s_) return;
    if (!start_log_file()) {
      log_retry_at_s_ = t_s_ + 10.0;
      return;
    }
    log_broken_ = false;
    std::fprintf(stderr, "augerd: logging again, to %s\n", log_path_.c_str());
  }
  auger::RobotSample s;
  s.t_s = t_s_;
  for (std::size_t i = 0; i < 4; ++i) {
    const Module& m = modules_[i];
    s.cmd_rpm[i] = cmd_rpm[i];
    if (!m.have_tm || m.lost) continue;
    s.omega_rpm[i] = m.tm.omega_crpm / 100.0;
    s.current_a[i] = m.tm.current_ma / 1000.0;
    s.voltage_v[i] = m.tm.voltage_mv / 1000.0;
    s.pwm[i] = m.tm.duty_x10000 / 10000.0;
    s.status[i] = m.tm.status;
    s.seq_ack[i] = m.tm.seq_ack;
  }
  if (sensors_in_.has_pose) {
    s.x_m = sensors_in_.pose[0];
    s.y_m = sensors_in_.pose[1];
    s.psi_rad = sensors_in_.pose[2];
  }
  if (sensors_in_.has_imu_psi) s.imu_psi_rad = sensors_in_.imu_psi_rad;
  if (sensors_in_.has_imu_r) s.imu_r_radps = sensors_in_.imu_r_radps;
  if (controller_->enabled()) {
    const auto& eta_d = controller_->reference().eta_d;
    s.xd_m = eta_d[0];
    s.yd_m = eta_d[1];
    s.psid_rad = eta_d[2];
  }
  s.loop_dt_s = loop_dt_s_;
  static thread_local std::vector<double> extra(replay_columns().size());
  const auto& eta = controller_->eta_estimate();
  const bool vel = mode_ == "vel", spin = mode_ == "spin";
  const double goal_x = (ctrl_events_ & kEvWaypoints) && traj_logged_ < 0 ? goal_[0] : NAN;
  const double values[] = {double(mode_code(mode_)),
                           double(ctrl_events_),
                           controller_->enabled() ? 1.0 : 0.0,
                           ctrl_cfg_.allocator.kind == auger::AllocatorKind::null_space ? 1.0 : 0.0,
                           goal_x,
                           std::isnan(goal_x) ? NAN : goal_[1],
                           std::isnan(goal_x) ? NAN : goal_[2],
                           traj_logged_ >= 0 ? double(traj_logged_) : NAN,
                           modules_[0].fresh ? 1.0 : 0.0,
                           modules_[1].fresh ? 1.0 : 0.0,
                           modules_[2].fresh ? 1.0 : 0.0,
                           modules_[3].fresh ? 1.0 : 0.0,
                           sensors_in_.has_pose ? pose_sd_[0] : NAN,
                           sensors_in_.has_pose ? pose_sd_[1] : NAN,
                           sensors_in_.has_pose ? pose_sd_[2] : NAN,
                           sensors_in_.has_pose ? sensors_in_.pose_t_s : NAN,
                           vel ? vel_cmd_[0] : NAN,
                           vel ? vel_cmd_[1] : NAN,
                           vel ? vel_cmd_[2] : NAN,
                           spin ? double(spin_module_) : NAN,
                           spin ? spin_rpm_ : NAN,
                           eta[0],
                           eta[1],
                           eta[2]};
  static_assert(sizeof values / sizeof values[0] == 24, "one value per replay column");
  std::copy(std::begin(values), std::end(values), extra.begin());
  log_->write(s, extra);
  if (t_s_ - log_flushed_at_s_ >= cfg_.log_flush_interval_s) {
    log_->flush();
    log_flushed_at_s_ = t_s_;
  }
  if (!*log_file_) return log_failed("write");
  if (std::uint64_t(log_file_->tellp()) >= cfg_.log_rotate_bytes) {
    log_->flush();
    if (!*log_file_) return log_failed("write");
    if (!start_log_file()) return log_failed("rotation");
  }
}

// ---- modules ----

void Daemon::fault(int module, const std::string& reason_token, const std::string& detail) {
  const bool first = fault_module_ < 0;
  if (first || enabled_) {
    fault_module_ = module;
    fault_reason_ = reason_token;
  }
  // Every event is printed; `status` keeps the one that stopped the robot.
  std::fprintf(stderr, "augerd: t=%.3f s: module %d (%s): %s; all screws stopped until `enable`\n", t_s_, module,
               modules_[std::size_t(module)].port.c_str(), detail.c_str());
  event(module, reason_token,
        detail + (enabled_ ? "; stopped all screws (was " + mode_ + "), waiting for enable"
                           : "; already stopped, waiting for enable"));
  enabled_ = false;
  mode_ = "stopped";
  disable_controller();
}

void Daemon::pump(Module& m, int index) {
  if (!m.link) {
    if (t_s_ < m.reopen_at_s) return;
    m.reopen_at_s = t_s_ + 1.0;
    try {
      m.link = std::make_unique<auger::io::ModuleLink>(m.port, cfg_.baud);
      m.identified = false;
      m.request_at_s = t_s_ + 0.75 * cfg_.identity_timeout_s;
      std::fprintf(stderr, "augerd: t=%.3f s: reopened %s, waiting for module %d's identity\n", t_s_, m.port.c_str(),
                   index);
    } catch (const std::exception&) {
      return;  // still gone; no message every second
    }
  }
  static thread_local std::vector<proto_frame_t> frames;
  frames.clear();
  try {
    m.link->pump(frames);
  } catch (const std::exception& e) {
    m.link.reset();
    m.lost = true;
    m.reopen_at_s = t_s_ + 1.0;
    fault(index, "port-error", e.what());
    return;
  }
  for (const auto& f : frames) {
    proto_identity_t id;
    proto_telemetry_t tm;
    proto_config_t cfg;
    proto_fault_t ft;
    if (proto_decode_fault(&f, &ft)) {
      // The module's own record of a trip: what it measured at that moment (the telemetry
      // that reports the fault bit follows, and check_safety stops the robot on it).
      const std::string text = auger::io::fault_snapshot_text(ft);
      std::fprintf(stderr, "augerd: t=%.3f s: module %d (%s): %s\n", t_s_, index, m.port.c_str(), text.c_str());
      event(index, "fault-snapshot", text);
    } else if (proto_decode_config_report(&f, &cfg)) {
      if (cfg.telemetry_period_ms != m.telemetry_period_ms)
        event(index, "telemetry-period", "the module sends telemetry every " + std::to_string(cfg.telemetry_period_ms) +
                                             " ms; augerd follows it");
      m.telemetry_period_ms = cfg.telemetry_period_ms;
    } else if (proto_decode_identity(&f, &id)) {
      if (id.module_id != index) {
        m.link.reset();
        m.lost = true;
        m.reopen_at_s = t_s_ + 1.0;
        fault(index, "wrong-id", "the module now on this port has id " + std::to_string(id.module_id));
        return;
      }
      if (m.identified) {
        // An identity frame nobody asked for: the module has rebooted (power, watchdog).
        fault(index, "reset", "the module reset; last reset: " + auger::io::reset_cause_text(id.reset_cause) +
                                  ", settings from " + auger::io::settings_origin_text(id.flags));
      }
      m.identified = true;
      m.identity = id;
      m.have_tm = false;  // its clock restarted: the next telemetry is not "older"
      // Its settings may be others now (defaults after a corrupt EEPROM): the telemetry period.
      try {
        request(*m.link, PROTO_T_CONFIG_REPORT, 0.0);
      } catch (const std::exception&) {
      }
    } else if (proto_decode_telemetry(&f, &tm) && m.identified) {
      // Key on the module's clock: a frame not newer than the last one is stale or repeated.
      if (m.have_tm) {
        const int32_t step_ms = int32_t(tm.time_ms - m.tm.time_ms);
        if (step_ms <= 0 && step_ms > -1000) continue;
        // Far back: the module restarted and its identity frame was lost.
        if (step_ms <= -1000) fault(index, "reset", "the module's clock went back " + std::to_string(-step_ms) + " ms");
      }
      m.tm = tm;
      m.have_tm = true;
      m.fresh = true;
      m.last_valid_s = t_s_;
      m.bytes_at_valid = m.link->bytes_received();
    }
  }
  if (m.link && !m.identified && t_s_ >= m.request_at_s) {
    try {
      request(*m.link, PROTO_T_IDENTITY, 0.0);
    } catch (const std::exception&) {
    }
    m.request_at_s = t_s_ + 0.5;
  }
}

void Daemon::check_safety() {
  for (int i = 0; i < 4; ++i) {
    Module& m = modules_[std::size_t(i)];
    if (m.fresh && m.lost) {
      m.lost = false;
      std::fprintf(stderr, "augerd: t=%.3f s: module %d answers again; stays stopped until `enable`\n", t_s_, i);
      event(i, "answers-again", "stays stopped until enable");
    }
    if (!m.lost && m.link && t_s_ - m.last_valid_s > telemetry_timeout_s(cfg_, m)) {
      m.lost = true;
      const int ms = int(std::lround(1000 * (t_s_ - m.last_valid_s)));
      const uint64_t garbage = m.link->bytes_received() - m.bytes_at_valid;
      // A frame cut short when the line died is not corruption: ask for two frames' worth.
      if (garbage >= 2 * PROTO_FRAME_SIZE(PROTO_LEN_TELEMETRY))
        fault(i, "corrupt-frames", "only corrupt frames for " + std::to_string(ms) + " ms (" +
                                       std::to_string(garbage) + " bytes without a valid frame)");
      else
        fault(i, "no-telemetry", "no telemetry for " + std::to_string(ms) + " ms");
    }
    if (m.fresh && m.clearing && seq_at_or_after(m.tm.seq_ack, m.clear_seq)) m.clearing = false;
    // Latched faults count once the module has seen our CLEAR_FAULTS (they may persist).
    if (m.fresh && enabled_ && !m.clearing && (m.tm.status & PROTO_F_MASK))
      fault(i, fault_bits_text(m.tm.status), "reports " + fault_bits_text(m.tm.status));
  }
}

void Daemon::send_setpoints(const std::array<double, 4>& rpm, bool enable) {
  for (int i = 0; i < 4; ++i) {
    Module& m = modules_[std::size_t(i)];
    if (!m.link) continue;
    proto_setpoint_t sp;
    sp.seq = m.seq++;
    const double crpm = std::clamp(rpm[std::size_t(i)] * 100.0, -32767.0, 32767.0);
    sp.omega_crpm = int16_t(std::lround(crpm));
    sp.flags = uint8_t((enable ? PROTO_SP_ENABLE : 0) | (m.clearing ? PROTO_SP_CLEAR_FAULTS : 0));
    uint8_t buf[PROTO_MAX_FRAME];
    const std::size_t n = proto_encode_setpoint(&sp, buf);
    try {
      // No waiting: a port that cannot take 11 bytes is not draining (module gone).
      m.link->send_frame(buf, n, 0.0);
    } catch (const std::exception& e) {
      m.link.reset();
      m.lost = true;
      m.reopen_at_s = t_s_ + 1.0;
      fault(i, "port-error", e.what());
    }
  }
}

// ---- sockets ----

std::string Daemon::command(const std::string& line) {
  Command c;
  const std::string err = parse_command(line, c);
  if (!err.empty()) return "error: " + err;
  switch (c.kind) {
    case CommandKind::status:
      return c.text == "all" ? status_line() + modules_status() : status_line();
    case CommandKind::enable:
      for (int i = 0; i < 4; ++i) {
        const Module& m = modules_[std::size_t(i)];
        if (m.lost || !m.link)
          return "error: module " + std::to_string(i) + " (" + m.port + ") is not answering; cannot enable";
      }
      for (auto& m : modules_) {
        m.clearing = true;
        m.clear_seq = m.seq;
      }
      if (fault_module_ >= 0) {
        std::fprintf(stderr, "augerd: t=%.3f s: enable: clearing fault of module %d (%s)\n", t_s_, fault_module_,
                     fault_reason_.c_str());
        event(fault_module_, "re-enabled", "fault " + fault_reason_ + " cleared by enable from " +
                                               commands_->current_peer());
      } else if (!enabled_) {
        event(-1, "enable", "enabled by " + commands_->current_peer());
      }
      fault_module_ = -1;
      fault_reason_ = "none";
      enabled_ = true;
      mode_ = "idle";
      disable_controller();
      return "ok";
    case CommandKind::stop:
      if (enabled_) event(-1, "stop", "all screws stopped (was " + mode_ + ") by " + commands_->current_peer());
      enabled_ = false;
      mode_ = "stopped";
      disable_controller();
      return "ok";
    case CommandKind::spin:
      if (!enabled_) return "error: not enabled (send enable first): '" + line + "'";
      if (mode_ == "goto" || mode_ == "follow" || mode_ == "hold")
        return "error: cannot spin one module during " + mode_ + " (stop first): '" + line + "'";
      // One module alone (step responses, calibration): the robot is not tracking, and the
      // command expires like `vel` (the dead-man).
      if (mode_ != "spin") event(int(c.a), "spin", "one module driven alone by " + commands_->current_peer());
      disable_controller();
      spin_module_ = int(c.a);
      spin_rpm_ = c.b;
      vel_until_s_ = t_s_ + cfg_.vel_timeout_s;
      mode_ = "spin";
      return "ok";
    case CommandKind::vel:
      if (!enabled_) return "error: not enabled (send enable first): '" + line + "'";
      disable_controller();
      vel_cmd_ = auger::Vec3(c.a, c.b, c.c);
      vel_until_s_ = t_s_ + cfg_.vel_timeout_s;
      mode_ = "vel";
      return "ok";
    case CommandKind::go_to:
      if (!enabled_) return "error: not enabled (send enable first): '" + line + "'";
      waypoints_ = {auger::Waypoint{0.0, auger::Vec3(c.a, c.b, c.c)}};
      controller_->set_waypoints(waypoints_);
      controller_->set_enabled(true);
      ctrl_events_ |= kEvWaypoints;
      goal_ = waypoints_[0].eta_p;
      traj_logged_ = -1;
      motion_t0_s_ = t_s_;
      arrived_ = false;
      mode_ = "goto";
      return "ok";
    case CommandKind::follow: {
      if (!enabled_) return "error: not enabled (send enable first): '" + line + "'";
      std::vector<auger::Waypoint> w;
      try {
        w = auger::load_waypoints_csv(c.text);
        auger::check_waypoints(w);
        if (w.empty()) return "error: " + c.text + ": no waypoints";
      } catch (const std::exception& e) {
        return std::string("error: ") + e.what();
      }
      waypoints_ = std::move(w);
      controller_->set_waypoints(waypoints_);
      controller_->set_enabled(true);
      ctrl_events_ |= kEvWaypoints;
      traj_logged_ = save_trajectory();
      motion_t0_s_ = t_s_;
      arrived_ = false;
      mode_ = "follow";
      return "ok";
    }
    case CommandKind::allocator: {
      // The core's controller takes its configuration at construction: a new one, started
      // from the current estimate. Only between motions, so no trajectory restarts.
      if (mode_ == "goto" || mode_ == "follow" || mode_ == "hold")
        return "error: cannot switch the allocator during " + mode_ + " (stop or wait: '" + line + "')";
      ctrl_cfg_.allocator.kind =
          c.text == "pinv" ? auger::AllocatorKind::pseudo_inverse : auger::AllocatorKind::null_space;
      const auger::Vec3 eta = controller_->eta_estimate();
      controller_ = std::make_unique<auger::Controller>(model_, ctrl_cfg_);
      controller_->reset(eta);
      ctrl_events_ |= kEvRebuilt;
      return "ok";
    }
  }
  return "error: internal";
}

std::string Daemon::sensor(const std::string& line) {
  SensorMessage m;
  const std::string err = parse_sensor(line, m);
  if (!err.empty()) return "error: " + err;
  // Wall-clock stamp to the loop's clock (CLOCK_MONOTONIC since start).
  const double t_loop_s = m.t_unix_s - mono_to_unix_s_ - t0_mono_s_;
  const double age_s = t_s_ - t_loop_s;
  if (age_s < -0.5) return "error: timestamp " + std::to_string(m.t_unix_s) + " is in the future by " +
                           std::to_string(-age_s) + " s (clocks in sync?): '" + line + "'";
  if (age_s > 2.0)
    return "error: timestamp " + std::to_string(m.t_unix_s) + " is " + std::to_string(age_s) + " s old: '" + line + "'";
  if (m.kind == SensorKind::pose) {
    sensors_in_.has_pose = true;
    sensors_in_.pose = auger::Vec3(m.x_m, m.y_m, m.psi_rad);
    sensors_in_.pose_cov = auger::Vec3(m.sx_m * m.sx_m, m.sy_m * m.sy_m, m.spsi_rad * m.spsi_rad).asDiagonal();
    sensors_in_.pose_t_s = t_loop_s;  // the EKF compares it with its prediction for that time
    pose_sd_ = auger::Vec3(m.sx_m, m.sy_m, m.spsi_rad);
    last_pose_ = sensors_in_.pose;
    last_pose_t_s_ = t_loop_s;
  } else {
    sensors_in_.has_imu_psi = sensors_in_.has_imu_r = true;
    sensors_in_.imu_psi_rad = m.imu_psi_rad;
    sensors_in_.imu_r_radps = m.imu_r_radps;
    last_imu_t_s_ = t_loop_s;
    last_imu_psi_rad_ = m.imu_psi_rad;
    last_imu_r_radps_ = m.imu_r_radps;
  }
  return "";
}

// A goto or follow has arrived once its waypoint clock is past the last waypoint and the
// estimate is within tolerance of the final pose; the controller keeps tracking that pose
// (mode hold) until the next command. Before, follow stayed "follow" for ever.
void Daemon::check_arrival() {
  if (!enabled_ || (mode_ != "goto" && mode_ != "follow") || waypoints_.empty()) return;
  const auger::Waypoint& last = waypoints_.back();
  if (t_s_ - motion_t0_s_ < last.t_s) return;
  const auger::Vec3 e = last.eta_p - controller_->eta_estimate();
  if (std::hypot(e[0], e[1]) > kArrivedM || std::fabs(auger::wrap_angle(e[2])) > kArrivedRad) return;
  arrived_ = true;
  char what[160];
  std::snprintf(what, sizeof what, "%s arrived at x=%.3f y=%.3f psi=%.3f; holding the final pose", mode_.c_str(),
                last.eta_p[0], last.eta_p[1], last.eta_p[2]);
  event(-1, "arrived", what);
  std::fprintf(stderr, "augerd: t=%.3f s: %s\n", t_s_, what);
  mode_ = "hold";
}

// Per-module fields of `status all` (docs/daemon-protocol.md): the latest telemetry, the
// setpoint sent, the link's error counters; then the latest sensor values.
std::string Daemon::modules_status() const {
  std::string out;
  char buf[640];
  for (int i = 0; i < 4; ++i) {
    const Module& m = modules_[std::size_t(i)];
    const proto_telemetry_t& tm = m.tm;
    const uint16_t crc = m.link ? m.link->parser_stats().crc_errors : 0;
    const uint16_t hdr = m.link ? m.link->parser_stats().header_errors : 0;
    const uint16_t skipped = m.link ? m.link->parser_stats().bytes_discarded : 0;
    const bool ok = m.have_tm && !m.lost;
    std::snprintf(buf, sizeof buf,
                  " m%d_port=%s m%d_lost=%d m%d_tm_age_s=%.3f m%d_time_ms=%" PRIu32 " m%d_omega_rpm=%.2f"
                  " m%d_cmd_rpm=%.2f m%d_omega_cmd_rpm=%.2f m%d_position_counts=%" PRId32
                  " m%d_current_a=%.3f m%d_voltage_v=%.3f m%d_pwm=%.4f m%d_status=0x%04x m%d_faults=%s"
                  " m%d_rx_errors=%u m%d_encoder_errors=%u m%d_host_crc_errors=%u m%d_host_header_errors=%u"
                  " m%d_host_bytes_skipped=%u",
                  i, m.port.c_str(), i, (m.lost || !m.link) ? 1 : 0, i, ok ? t_s_ - m.last_valid_s : -1.0, i,
                  tm.time_ms, i, tm.omega_crpm / 100.0, i, last_cmd_rpm_[std::size_t(i)], i,
                  tm.omega_cmd_crpm / 100.0, i, tm.position_counts, i, tm.current_ma / 1000.0, i,
                  tm.voltage_mv / 1000.0, i, tm.duty_x10000 / 10000.0, i, tm.status, i,
                  (tm.status & PROTO_F_MASK) ? fault_bits_text(tm.status).c_str() : "none", i, tm.rx_errors, i,
                  tm.encoder_errors, i, crc, i, hdr, i, skipped);
    out += buf;
  }
  std::snprintf(buf, sizeof buf,
                " imu_age_s=%.3f imu_psi_rad=%.4f imu_r_radps=%.4f pose_age_s=%.3f cam_x_m=%.4f cam_y_m=%.4f "
                "cam_psi_rad=%.4f",
                t_s_ - last_imu_t_s_, last_imu_psi_rad_, last_imu_r_radps_, t_s_ - last_pose_t_s_, last_pose_[0],
                last_pose_[1], last_pose_[2]);
  out += buf;
  if (ros2_) {
    std::snprintf(buf, sizeof buf, " ros2_applied=%ld ros2_refused=%ld ros2_hook_max_us=%.1f", ros2_applied_,
                  ros2_refused_, ros2_hook_us_max_);
    out += buf;
  }
  return out;
}

// Copies a follow trajectory beside the log (…-follow-N.waypoints: CSV, but not named .csv so that globs of the logs miss it), so that auger replay finds the
// waypoints this run used. Returns N, or -1 if it could not be written (the motion goes on).
int Daemon::save_trajectory() {
  const int n = traj_n_++;
  const std::string path = cfg_.log_dir + "/" + run_name_ + "-follow-" + std::to_string(n) + ".waypoints";
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) return -1;
  std::fprintf(f, "t_s,x_m,y_m,psi_rad\n");
  for (const auto& w : waypoints_)
    std::fprintf(f, "%.17g,%.17g,%.17g,%.17g\n", w.t_s, w.eta_p[0], w.eta_p[1], w.eta_p[2]);
  const bool ok = std::fclose(f) == 0;
  return ok ? n : -1;
}

std::string Daemon::status_line() const {
  const auto& eta = controller_->eta_estimate();
  const auto& eta_d = controller_->reference().eta_d;
  char buf[512];
  const std::string fault =
      fault_module_ < 0 ? std::string("none") : std::to_string(fault_module_) + ":" + fault_reason_;
  std::snprintf(buf, sizeof buf,
                "status t_s=%.3f enabled=%d mode=%s x_m=%.4f y_m=%.4f psi_rad=%.4f xd_m=%.4f yd_m=%.4f "
                "psid_rad=%.4f fault=%s loop_dt_s=%.5f loop_jitter_max_s=%.5f arrived=%d",
                t_s_, enabled_ ? 1 : 0, mode_.c_str(), eta[0], eta[1], eta[2], eta_d[0], eta_d[1], eta_d[2],
                fault.c_str(), loop_dt_s_, jitter_max_s_, arrived_ ? 1 : 0);
  return buf;
}

// ---- ROS 2 (docs/ros2.md) ----

// Inputs go through the sockets' own entry points, `vel` and the sensors socket's `pose` and
// `imu` lines (%.17g reproduces every double exactly): every bound and check of those applies
// to ROS 2 messages unchanged, and the 0.5 s dead-man of `vel` to Twist.
void Daemon::ros2_inputs() {
  auger::ros2::Inputs in;
  const double t0 = clock_s(CLOCK_MONOTONIC), c0 = clock_s(CLOCK_THREAD_CPUTIME_ID);
  const bool got = ros2_->poll(in);
  ros2_cycle_us_ = 1e6 * (clock_s(CLOCK_MONOTONIC) - t0);
  ros2_cycle_cpu_us_ = 1e6 * (clock_s(CLOCK_THREAD_CPUTIME_ID) - c0);
  if (!got) return;
  if (in.refused > 0) {
    ros2_refused_ += in.refused - 1;  // ros2_refused() counts the last one
    ros2_refused(in.refusal.data());
  }
  char line[320];
  auto apply = [&](const std::string& answer, const char* what) {
    if (answer.empty() || answer == "ok") {
      ++ros2_applied_;
      return;
    }
    ros2_refused(std::string(what) + ": " + (answer.rfind("error: ", 0) == 0 ? answer.substr(7) : answer));
  };
  if (in.has_vel) {
    std::snprintf(line, sizeof line, "vel %.17g %.17g %.17g", in.u_mps, in.v_mps, in.r_radps);
    apply(command(line), "cmd_vel");
  }
  if (in.has_pose) {
    std::snprintf(line, sizeof line, "pose %.17g %.17g %.17g %.17g %.17g %.17g %.17g", in.pose_t_unix_s, in.x_m, in.y_m,
                  in.psi_rad, in.sx_m, in.sy_m, in.spsi_rad);
    apply(sensor(line), "pose");
  }
  if (in.has_imu) {
    std::snprintf(line, sizeof line, "imu %.17g %.17g %.17g", in.imu_t_unix_s, in.imu_psi_rad, in.imu_r_radps);
    apply(sensor(line), "imu");
  }
}

void Daemon::ros2_refused(const std::string& why) {
  ++ros2_refused_;
  ros2_last_refusal_ = why;
  if (t_s_ - ros2_said_at_s_ < 5.0) {
    ++ros2_unsaid_;
    return;
  }
  std::fprintf(stderr, "augerd: t=%.3f s: ROS 2 input refused: %s", t_s_, why.c_str());
  if (ros2_unsaid_ > 0) std::fprintf(stderr, " (and %ld more refused since the last message)", ros2_unsaid_);
  std::fputc('\n', stderr);
  ros2_said_at_s_ = t_s_;
  ros2_unsaid_ = 0;
}

void Daemon::ros2_publish() {
  auger::ros2::Snapshot& o = ros2_out_;
  o.t_unix_s = t0_mono_s_ + t_s_ + mono_to_unix_s_;
  const auger::Vec3& eta = controller_->eta_estimate();
  const auger::Vec3& zeta = controller_->zeta_estimate();
  for (int i = 0; i < 3; ++i) o.eta[i] = eta[i], o.zeta[i] = zeta[i];
  const auger::Mat6* P = controller_->estimate_covariance();
  o.has_cov = P != nullptr;
  if (P) Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(o.cov) = *P;
  for (std::size_t i = 0; i < 4; ++i) {
    const Module& m = modules_[i];
    auger::ros2::ModuleSnapshot& x = o.module[i];
    x.answering = m.have_tm && !m.lost && m.link;
    x.omega_rpm = m.tm.omega_crpm / 100.0;
    x.cmd_rpm = last_cmd_rpm_[i];
    x.current_a = m.tm.current_ma / 1000.0;
    x.voltage_v = m.tm.voltage_mv / 1000.0;
    x.pwm = m.tm.duty_x10000 / 10000.0;
    x.status = m.tm.status;
    x.rx_errors = m.tm.rx_errors;
    x.encoder_errors = m.tm.encoder_errors;
    x.crc_errors = m.link ? m.link->parser_stats().crc_errors : 0;
    x.header_errors = m.link ? m.link->parser_stats().header_errors : 0;
    x.bytes_skipped = m.link ? m.link->parser_stats().bytes_discarded : 0;
    x.fw[0] = m.identity.fw_major, x.fw[1] = m.identity.fw_minor, x.fw[2] = m.identity.fw_patch;
    std::snprintf(x.port.data(), x.port.size(), "%s", m.port.c_str());
  }
  o.enabled = enabled_;
  std::snprintf(o.mode.data(), o.mode.size(), "%s", mode_.c_str());
  o.fault_module = fault_module_;
  std::snprintf(o.fault_reason.data(), o.fault_reason.size(), "%s", fault_reason_.c_str());
  o.loop_dt_s = loop_dt_s_;
  o.loop_jitter_max_s = jitter_max_s_;
  o.hook_max_us = ros2_hook_us_max_;
  o.inputs_applied = ros2_applied_;
  o.inputs_refused = ros2_refused_;
  std::snprintf(o.last_refusal.data(), o.last_refusal.size(), "%s", ros2_last_refusal_.c_str());
  const double t0 = clock_s(CLOCK_MONOTONIC), c0 = clock_s(CLOCK_THREAD_CPUTIME_ID);
  ros2_->publish(o);
  ros2_cycle_us_ += 1e6 * (clock_s(CLOCK_MONOTONIC) - t0);
  ros2_cycle_cpu_us_ += 1e6 * (clock_s(CLOCK_THREAD_CPUTIME_ID) - c0);
  ros2_sum_cpu_us_ += ros2_cycle_cpu_us_;
  ros2_max_cpu_us_ = std::max(ros2_max_cpu_us_, ros2_cycle_cpu_us_);
  ros2_window_max_us_ = std::max(ros2_window_max_us_, ros2_cycle_us_);
  if (t_s_ - ros2_window_start_s_ >= 1.0) {
    ros2_hook_us_max_ = ros2_window_max_us_;
    ros2_window_max_us_ = 0;
    ros2_window_start_s_ = t_s_;
  }
  ros2_sum_us_ += ros2_cycle_us_;
  ros2_max_all_us_ = std::max(ros2_max_all_us_, ros2_cycle_us_);
  ++ros2_cycles_;
  ros2_cycle_us_ = 0;
}

// ---- the loop ----

void Daemon::run() {
  if (cfg_.realtime_priority > 0) {
    // Fewer late cycles on a busy machine; needs CAP_SYS_NICE (or an rtprio limit), so a
    // refusal is a warning: the loop still runs, with more jitter.
    sched_param sp{};
    sp.sched_priority = cfg_.realtime_priority;
    if (sched_setscheduler(0, SCHED_FIFO, &sp) != 0)
      std::fprintf(stderr, "augerd: warning: SCHED_FIFO priority %d refused (%s); running without\n",
                   cfg_.realtime_priority, std::strerror(errno));
    if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0)
      std::fprintf(stderr, "augerd: warning: mlockall refused (%s)\n", std::strerror(errno));
  }
  const long period_ns = std::lround(cfg_.period_s * 1e9);
  timespec next;
  clock_gettime(CLOCK_MONOTONIC, &next);
  t0_mono_s_ = double(next.tv_sec) + 1e-9 * double(next.tv_nsec);
  for (auto& m : modules_) m.last_valid_s -= t0_mono_s_;
  double prev_s = 0;
  // Period statistics for the exit report.
  long cycles = 0;
  double sum_dt = 0, sum_dt2 = 0, max_dt = 0, min_dt = 1e9, jitter_window_max = 0, window_start = 0;
  std::array<double, 4> zero{};
  while (!g_stop) {
    next.tv_nsec += period_ns;
    while (next.tv_nsec >= 1000000000L) next.tv_nsec -= 1000000000L, ++next.tv_sec;
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr) == EINTR && !g_stop) {
    }
    const double mono = clock_s(CLOCK_MONOTONIC);
    mono_to_unix_s_ = clock_s(CLOCK_REALTIME) - mono;
    t_s_ = mono - t0_mono_s_;
    loop_dt_s_ = t_s_ - prev_s;
    prev_s = t_s_;
    // A stall longer than a period (debugger, overloaded machine): restart the schedule
    // from now instead of running the missed cycles back to back.
    const double late_s = mono - (double(next.tv_sec) + 1e-9 * double(next.tv_nsec));
    if (late_s > cfg_.period_s) clock_gettime(CLOCK_MONOTONIC, &next);
    if (cycles > 0) {
      sum_dt += loop_dt_s_;
      sum_dt2 += loop_dt_s_ * loop_dt_s_;
      max_dt = std::max(max_dt, loop_dt_s_);
      min_dt = std::min(min_dt, loop_dt_s_);
      jitter_window_max = std::max(jitter_window_max, std::fabs(loop_dt_s_ - cfg_.period_s));
      if (t_s_ - window_start >= 1.0) {
        jitter_max_s_ = jitter_window_max;
        jitter_window_max = 0;
        window_start = t_s_;
      }
    }
    ++cycles;

    for (int i = 0; i < 4; ++i) modules_[std::size_t(i)].fresh = false;
    for (int i = 0; i < 4; ++i) pump(modules_[std::size_t(i)], i);
    check_safety();

    commands_->serve([this](const std::string& l) { return command(l); });
    sensors_->serve([this](const std::string& l) { return sensor(l); });
    if (ros2_) ros2_inputs();

    std::array<auger::ScrewTelemetry, 4> tel;
    for (std::size_t i = 0; i < 4; ++i) {
      tel[i].valid = modules_[i].fresh;
      tel[i].omega_rpm = modules_[i].tm.omega_crpm / 100.0;
    }
    const std::array<double, 4>& ctrl_rpm = controller_->step(t_s_, tel, sensors_in_);

    check_arrival();
    std::array<double, 4> cmd_rpm = zero;
    if (enabled_ && mode_ == "spin") {
      if (t_s_ > vel_until_s_) mode_ = "idle";  // dead-man, as for vel
      else {
        const double lim = ctrl_cfg_.allocator.omega_max_rpm;
        cmd_rpm[std::size_t(spin_module_)] = std::clamp(spin_rpm_, -lim, lim);
      }
    } else if (enabled_ && mode_ == "vel") {
      if (t_s_ > vel_until_s_) {
        mode_ = "idle";  // dead-man: the command was not repeated
      } else {
        // Open loop, eq. (4): the core's controller tracks poses only.
        const auger::Vec4 w = auger::kinematic_screw_speeds_rpm(model_, vel_cmd_);
        const double peak = w.cwiseAbs().maxCoeff();
        const double lim = ctrl_cfg_.allocator.omega_max_rpm;
        const double scale = peak > lim ? lim / peak : 1.0;  // keep the direction when saturated
        for (std::size_t i = 0; i < 4; ++i) cmd_rpm[i] = w[int(i)] * scale;
      }
    } else if (enabled_ && (mode_ == "goto" || mode_ == "follow" || mode_ == "hold")) {
      cmd_rpm = ctrl_rpm;
    }
    last_cmd_rpm_ = cmd_rpm;
    send_setpoints(cmd_rpm, enabled_);
    write_log(cmd_rpm);
    if (ros2_) ros2_publish();
    sensors_in_ = auger::SensorInput{};
    ctrl_events_ = 0;
    traj_logged_ = -1;
  }
  // Leave the motors stopped at once rather than after the modules' timeout.
  enabled_ = false;
  send_setpoints(zero, false);
  if (log_) log_->flush();
  event(-1, "exit", "augerd stopped by signal; setpoints 0 sent");
  if (events_) std::fclose(events_);
  if (ros2_ && ros2_cycles_ > 0)
    std::fprintf(stderr,
                 "augerd: ROS 2: %ld inputs applied, %ld refused; the loop spent %.1f us mean, %.1f us max per cycle "
                 "in the bridge's poll and publish (its own CPU time %.1f us mean, %.1f us max)\n",
                 ros2_applied_, ros2_refused_, ros2_sum_us_ / double(ros2_cycles_), ros2_max_all_us_,
                 ros2_sum_cpu_us_ / double(ros2_cycles_), ros2_max_cpu_us_);
  if (cycles > 1) {
    const double n = double(cycles - 1), mean = sum_dt / n;
    std::fprintf(stderr,
                 "augerd: %ld cycles; loop period mean %.4f ms, std %.4f ms, min %.4f ms, max %.4f ms\n", cycles,
                 1e3 * mean, 1e3 * std::sqrt(std::max(0.0, sum_dt2 / n - mean * mean)), 1e3 * min_dt, 1e3 * max_dt);
  }
}

void usage(std::FILE* f) {
  std::fprintf(f,
               "usage: augerd [--config PATH] [--check]\n"
               "  --config PATH  configuration file (default /etc/augerd.toml; docs/daemon.md)\n"
               "  --check        read and check the configuration and the model, then exit\n");
}

}  // namespace
}  // namespace augerd

int main(int argc, char** argv) {
  using namespace augerd;
  std::string config_path = "/etc/augerd.toml";
  bool check_only = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--config" && i + 1 < argc) config_path = argv[++i];
    else if (a == "--check") check_only = true;
    else if (a == "--help" || a == "-h") {
      usage(stdout);
      return kExitOk;
    } else {
      std::fprintf(stderr, "augerd: unknown argument '%s'\n", a.c_str());
      usage(stderr);
      return kExitConfig;
    }
  }
  DaemonConfig cfg;
  std::optional<auger::Model> model;
  try {
    cfg = load_daemon_config(config_path);
    const auger::ModelFile mf = auger::load_model_file(cfg.model_file);
    model = auger::build_model(mf, cfg.terrain);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "augerd: configuration error: %s\n", e.what());
    return kExitConfig;
  }
  if (check_only) {
    std::printf("augerd: %s is valid\n", config_path.c_str());
    return kExitOk;
  }
  struct sigaction sa{};
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
  // A file-size limit reached by the log is a write error to survive, like a full disk.
  std::signal(SIGXFSZ, SIG_IGN);
  try {
    Daemon d(cfg, std::move(*model));
    d.open_modules();
    d.open_sockets();
    d.open_log();
    d.open_ros2();
    std::fprintf(stderr, "augerd: running (commands %s, sensors %s)\n", cfg.commands_socket.c_str(),
                 cfg.sensors_socket.c_str());
    d.run();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "augerd: %s\n", e.what());
    return kExitStartup;
  }
  std::fprintf(stderr, "augerd: stopped\n");
  return kExitOk;
}
