// augerd's loop (daemon.hpp): modules in, safety, sockets, the core's step, setpoints out, log.
#include "daemon.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <stdexcept>

#include <sched.h>
#include <sys/mman.h>

#include "auger/effect.hpp"
#include "auger/model_file.hpp"
#include "clock.hpp"
#include "auger/log.hpp"

namespace augerd {
namespace {


// What the commands socket answers at once to a connection without a slot (LineServerOptions).
bool priority_command(const std::string& line) {
  const auto f = auger::daemon::split_fields(line);
  return !f.empty() && (f[0] == "stop" || f[0] == "status");
}

}  // namespace

Daemon::Daemon(const DaemonConfig& cfg, auger::Model model)
    : cfg_(cfg),
      model_(std::move(model)),
      ctrl_cfg_(cfg.controller),
      bus_(cfg.ports, cfg.baud, cfg.identity_timeout_s, cfg.telemetry_timeout_s,
           [this](int m, const std::string& reason, const std::string& detail) { fault(m, reason, detail); },
           [this](int m, const std::string& what, const std::string& action) {
             // The module whose fault stopped the robot answers again (same id, valid telemetry):
             // `status` no longer names a fault that has passed (another module still silent is
             // named instead); the robot stays stopped until `enable`, the event log keeps both.
             if (what == "answers-again" && m == fault_module_) {
               fault_module_ = bus_.first_not_answering();
               fault_reason_ = fault_module_ >= 0 ? "not-answering" : "none";
             }
             event(m, what, action);
           }) {
  controller_ = std::make_unique<auger::Controller>(model_, ctrl_cfg_);
  online_kin_ = auger::KinematicVelocity(cfg.online_kin);
  if (cfg.online.enabled) {
    const auger::ModelFile& mf = cfg.model;
    online_ = std::make_unique<auger::OnlineEstimator>(model_, cfg.online,
                                                       auger::online_effect_params(mf, auger::EffectRegistry::builtin()));
    for (const auto& t : mf.terrains) terrains_.push_back(t.params);
    applied_terrain_ = cfg.terrain;
  }
}

Daemon::~Daemon() = default;

void Daemon::open_sockets() {
  auto gid = [](const std::string& group) {
    const std::optional<long> g = socket_gid(group);
    if (!g) throw std::runtime_error("no group named '" + group + "'");
    return *g;
  };
  LineServerOptions o;
  o.idle_timeout_s = cfg_.idle_timeout_s;
  o.mode = cfg_.commands_mode;
  o.gid = gid(cfg_.commands_group);
  o.priority_allows = priority_command;  // `stop` always gets through (docs/daemon.md)
  commands_ = std::make_unique<LineServer>(cfg_.commands_socket, o);
  LineServerOptions s;
  s.idle_timeout_s = cfg_.idle_timeout_s;
  s.mode = cfg_.sensors_mode;
  s.gid = gid(cfg_.sensors_group);
  sensors_ = std::make_unique<LineServer>(cfg_.sensors_socket, s);
}

void Daemon::open_log() {
  t0_unix_s_ = clock_s(CLOCK_REALTIME);
  char stamp[32];
  const std::time_t now = std::time(nullptr);
  std::tm tm_utc;
  gmtime_r(&now, &tm_utc);
  std::strftime(stamp, sizeof stamp, "%Y%m%dT%H%M%SZ", &tm_utc);
  run_name_ = std::string("augerd-") + stamp;
  char t0[64];
  std::snprintf(t0, sizeof t0, "%.6f", t0_unix_s_);
  DataLogConfig lc;
  lc.dir = cfg_.log_dir;
  lc.run = run_name_;
  lc.metadata = {{"format", auger::kRobotLogFormat},
                 {"terrain", cfg_.terrain},
                 {"t0_unix_s", t0},
                 {"writer", "augerd"},
                 {"run", run_name_}};
  lc.rotate_bytes = cfg_.log_rotate_bytes;
  lc.flush_interval_s = cfg_.log_flush_interval_s;
  lc.fsync_interval_s = cfg_.log_fsync_interval_s;
  lc.mcap = cfg_.log_mcap;
  if (online_) lc.more_columns = auger::daemon::online_columns();
  if (cfg_.controller.effect_feedforward)
    for (const std::string& c : auger::daemon::feedforward_columns()) lc.more_columns.push_back(c);
  log_ = std::make_unique<DataLog>(lc);
  log_->open();
  std::fprintf(stderr, "augerd: logging to %s\n", log_->first_path().c_str());
  event(-1, "start", "augerd started, robot stopped; data log " + log_->first_path());
}

void Daemon::event(int module, const std::string& what, const std::string& action) {
  if (!log_) return;
  const double wall = t0_unix_s_ + t_s_;
  const std::time_t sec = std::time_t(wall);
  std::tm tm_utc;
  gmtime_r(&sec, &tm_utc);
  char stamp[40];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%S", &tm_utc);
  const std::string mod = module >= 0 ? std::to_string(module) : "-";
  char head[160];
  std::snprintf(head, sizeof head, "%s.%03dZ t_s=%.3f module=%s port=%s event=", stamp,
                int((wall - double(sec)) * 1000), t_s_, mod.c_str(), port_of(module).c_str());
  log_->event(head + what + " action=\"" + action + "\"");
}

void Daemon::fault(int module, const std::string& reason_token, const std::string& detail) {
  const bool first = fault_module_ < 0 && fault_reason_ == "none";
  // A later fault of the module that stopped the robot says what it is now (a port that failed,
  // then a module of another id on it: `wrong-id`, not the old `port-error`).
  if (first || enabled_ || (module >= 0 && module == fault_module_)) {
    fault_module_ = module;
    fault_reason_ = reason_token;
  }
  // Every event is printed; `status` keeps the one that stopped the robot.
  if (module >= 0)
    std::fprintf(stderr, "augerd: t=%.3f s: module %d (%s): %s; all screws stopped until `enable`\n", t_s_, module,
                 port_of(module).c_str(), detail.c_str());
  else
    std::fprintf(stderr, "augerd: t=%.3f s: %s; all screws stopped until `enable`\n", t_s_, detail.c_str());
  event(module, reason_token,
        detail + (enabled_ ? std::string("; stopped all screws (was ") + mode_name(mode_) + "), waiting for enable"
                           : "; already stopped, waiting for enable"));
  enabled_ = false;
  arrived_ = false;
  ++motion_epoch_;
  enter(Mode::stopped);
  disable_controller();
}

// The estimator's gate (docs/daemon.md "Safety"): one event when a run of rejected camera poses
// begins and one when the poses agree again, so a stream of wrong poses cannot flood the log.
void Daemon::pose_gate_events() {
  if (!sensors_in_.has_pose) return;
  char what[240];
  if (controller_->pose_rejected()) {
    ++poses_rejected_;
    if (reject_run_n_++ > 0) return;
    reject_run_t0_s_ = t_s_;
    std::snprintf(what, sizeof what,
                  "camera pose %.3f m %.3f m %.3f rad rejected: %.3g standard deviations from the estimate (gate %.3g); "
                  "estimate kept; a fault follows if every pose disagrees for %.3g s",
                  sensors_in_.pose[0], sensors_in_.pose[1], sensors_in_.pose[2], controller_->pose_distance(),
                  std::sqrt(ctrl_cfg_.ekf.pose_gate_d2), ctrl_cfg_.ekf.pose_reject_fault_s);
    event(-1, "pose-rejected", what);
  } else if (reject_run_n_ > 0) {
    std::snprintf(what, sizeof what, "camera poses agree with the estimate again after %ld rejected over %.2f s",
                  reject_run_n_, t_s_ - reject_run_t0_s_);
    event(-1, "pose-accepted", what);
    reject_run_n_ = 0;
  }
}

// What each mode sends (docs/daemon.md "The loop"; the rule is auger_contract's, which `auger
// replay` applies too): here only what is augerd's own, `enable` and the dead-man.
std::array<double, 4> Daemon::setpoints(const std::array<double, 4>& ctrl_rpm) {
  if (!enabled_) return {};
  // vel and spin expire into idle unless repeated (the dead-man).
  if ((mode_ == Mode::vel || mode_ == Mode::spin) && t_s_ > vel_until_s_) enter(Mode::idle);
  auger::daemon::MotionInput in;
  in.mode = mode_;
  in.vel = vel_cmd_;
  in.spin_module = spin_module_;
  in.spin_rpm = spin_rpm_;
  return auger::daemon::mode_setpoints(in, ctrl_rpm, model_, ctrl_cfg_.allocator.omega_max_rpm);
}

void Daemon::write_log(const std::array<double, 4>& cmd_rpm) {
  auger::RobotSample s;
  s.t_s = t_s_;
  for (int i = 0; i < 4; ++i) {
    const Module& m = bus_.module(i);
    const auto k = std::size_t(i);
    s.cmd_rpm[k] = cmd_rpm[k];
    if (!m.lost) auger::io::log_telemetry(m.tm, k, s);
  }
  if (sensors_in_.has_pose) {
    s.x_m = sensors_in_.pose[0];
    s.y_m = sensors_in_.pose[1];
    s.psi_rad = sensors_in_.pose[2];
  }
  if (sensors_in_.has_imu_psi) s.imu_psi_rad = sensors_in_.imu_psi_rad;
  if (sensors_in_.has_imu_r) s.imu_r_radps = sensors_in_.imu_r_radps;
  if (sensors_in_.has_imu_acc) s.imu_ax_mps2 = sensors_in_.imu_ax_mps2, s.imu_ay_mps2 = sensors_in_.imu_ay_mps2;
  if (controller_->enabled()) auger::io::log_reference(controller_->reference().eta_d, s);
  s.loop_dt_s = loop_dt_s_;
  // The replay columns (auger_contract's LogRow names them).
  auger::daemon::LogRow row;
  row.mode = double(auger::daemon::mode_code(mode_));
  row.ctrl_events = double(ctrl_events_);
  row.ctrl_enabled = controller_->enabled() ? 1.0 : 0.0;
  row.alloc_nullspace = ctrl_cfg_.allocator.kind == auger::AllocatorKind::null_space ? 1.0 : 0.0;
  // A goto's goal on the row it came; a follow file by its number.
  if ((ctrl_events_ & auger::daemon::kEvWaypoints) && traj_logged_ < 0) {
    row.goal_x_m = goal_[0];
    if (!std::isnan(row.goal_x_m)) row.goal_y_m = goal_[1], row.goal_psi_rad = goal_[2];
  }
  if (traj_logged_ >= 0) row.traj_n = double(traj_logged_);
  row.tm_fresh_0 = bus_.module(0).tm.fresh ? 1.0 : 0.0;
  row.tm_fresh_1 = bus_.module(1).tm.fresh ? 1.0 : 0.0;
  row.tm_fresh_2 = bus_.module(2).tm.fresh ? 1.0 : 0.0;
  row.tm_fresh_3 = bus_.module(3).tm.fresh ? 1.0 : 0.0;
  if (sensors_in_.has_pose) {
    row.pose_sx_m = pose_sd_[0];
    row.pose_sy_m = pose_sd_[1];
    row.pose_spsi_rad = pose_sd_[2];
    row.pose_capture_t_s = sensors_in_.pose_t_s;
  }
  if (mode_ == Mode::vel) row.vel_u_mps = vel_cmd_[0], row.vel_v_mps = vel_cmd_[1], row.vel_r_radps = vel_cmd_[2];
  if (mode_ == Mode::spin) row.spin_module = double(spin_module_), row.spin_rpm = spin_rpm_;
  const auto& eta = controller_->eta_estimate();
  row.xe_m = eta[0];
  row.ye_m = eta[1];
  row.psie_rad = eta[2];
  static thread_local std::vector<double> extra;
  auger::daemon::log_row_values(row, extra);
  if (online_) {
    const std::size_t n = extra.size();
    extra.resize(n + auger::daemon::online_columns().size());
    online_values(extra.data() + n);
  }
  if (cfg_.controller.effect_feedforward) {
    const auger::Vec3& ff_n = controller_->effect_feedforward_n();
    extra.insert(extra.end(), ff_n.data(), ff_n.data() + 3);
  }
  log_->write(s, extra);
}

void Daemon::run(volatile const std::sig_atomic_t* stop) {
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
  bus_.start_clock(t0_mono_s_);
  double prev_s = 0;
  // Period statistics for the exit report.
  long cycles = 0;
  double sum_dt = 0, sum_dt2 = 0, max_dt = 0, min_dt = 1e9, jitter_window_max = 0, window_start = 0;
  // The cycle's own work, from its wake-up to its end: the wall time includes being preempted,
  // the loop thread's CPU time does not, so a long period with a short CPU time is the machine's
  // doing (no SCHED_FIFO, another process), not the loop's.
  double work_wall_max_s = 0, work_cpu_max_s = 0, work_cpu_sum_s = 0;
  long work_over_period = 0;  // cycles whose own CPU time exceeded the period
  while (!*stop) {
    next.tv_nsec += period_ns;
    while (next.tv_nsec >= 1000000000L) next.tv_nsec -= 1000000000L, ++next.tv_sec;
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr) == EINTR && !*stop) {
    }
    const double mono = clock_s(CLOCK_MONOTONIC);
    const double cpu0_s = clock_s(CLOCK_THREAD_CPUTIME_ID);
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

    bus_.pump(t_s_, enabled_);
    commands_->serve(t_s_, [this](const std::string& l) { return command(l); });
    sensors_->serve(t_s_, [this](const std::string& l) -> std::optional<std::string> { return sensor(l); });
    follow_loaded();
    if (ros2_) ros2_inputs();
    take_queued_pose();

    std::array<auger::ScrewTelemetry, 4> tel;
    for (int i = 0; i < 4; ++i) tel[std::size_t(i)] = bus_.module(i).tm.controller_input();
    const std::array<double, 4>& ctrl_rpm = controller_->step(t_s_, tel, sensors_in_);
    pose_gate_events();
    if (online_) online_step(tel);
    // The controller refused its own state (an estimate that diverged): a fault like a module's.
    if (!controller_->fault().empty() && !estimator_fault_reported_) {
      estimator_fault_reported_ = true;
      fault(-1, "estimator", controller_->fault());
    }

    check_arrival();
    const std::array<double, 4> cmd_rpm = setpoints(ctrl_rpm);
    bus_.send(t_s_, cmd_rpm, enabled_);
    write_log(cmd_rpm);
    if (ros2_) ros2_publish();
    sensors_in_ = auger::SensorInput{};
    ctrl_events_ = 0;
    traj_logged_ = -1;
    if (cycles > 1) {  // the first cycle's one-off set-up is not the loop's work
      const double cpu_s = clock_s(CLOCK_THREAD_CPUTIME_ID) - cpu0_s;
      work_wall_max_s = std::max(work_wall_max_s, clock_s(CLOCK_MONOTONIC) - mono);
      work_cpu_max_s = std::max(work_cpu_max_s, cpu_s);
      work_cpu_sum_s += cpu_s;
      if (cpu_s > cfg_.period_s) ++work_over_period;
    }
  }
  // Leave the motors stopped at once rather than after the modules' timeout.
  enabled_ = false;
  bus_.send(t_s_, std::array<double, 4>{}, false);
  event(-1, "exit", "augerd stopped by signal; setpoints 0 sent");
  log_->close();
  ros2_report();
  if (cycles > 1) {
    const double n = double(cycles - 1), mean = sum_dt / n;
    std::fprintf(stderr,
                 "augerd: %ld cycles; loop period mean %.4f ms, std %.4f ms, min %.4f ms, max %.4f ms\n", cycles,
                 1e3 * mean, 1e3 * std::sqrt(std::max(0.0, sum_dt2 / n - mean * mean)), 1e3 * min_dt, 1e3 * max_dt);
    std::fprintf(stderr,
                 "augerd: cycle work: longest %.3f ms wall, %.3f ms CPU; mean %.3f ms CPU; %ld cycles over the period "
                 "in CPU\n",
                 1e3 * work_wall_max_s, 1e3 * work_cpu_max_s, 1e3 * work_cpu_sum_s / n, work_over_period);
  }
  const DataLog::Stats ls = log_->stats();
  std::fprintf(stderr,
               "augerd: log: %llu rows written, %llu lost, %llu files, %llu write failures; %llu fdatasync, longest "
               "%.1f ms, mean %.1f ms\n",
               static_cast<unsigned long long>(ls.rows_written), static_cast<unsigned long long>(ls.rows_lost),
               static_cast<unsigned long long>(ls.files), static_cast<unsigned long long>(ls.failures),
               static_cast<unsigned long long>(ls.fsyncs), 1e3 * ls.fsync_max_s,
               ls.fsyncs ? 1e3 * ls.fsync_total_s / double(ls.fsyncs) : 0.0);
}

}  // namespace augerd
