// Lock-step scheduler: see scheduler.hpp.
#include "scheduler.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <thread>

#include "protocol.h"
#include "simmod.h"
#include "module_adapter.hpp"

namespace auger::sim {

struct Scheduler::SimModule {
  proto_parser_t parser;
  auger::io::ModuleTelemetry tm;  // the latest frame; fresh: one arrived in this control period
  std::uint16_t seq = 0;
  bool cleared = false;           // CLEAR_FAULTS sent once, with the first enabling setpoint
};

Scheduler::Scheduler(const Model& nominal, const TruthParams& truth, const SchedulerConfig& config)
    : cfg_(config),
      robot_(nominal, truth),
      imu_(config.imu, config.seed * 2654435761ULL + 1),
      camera_(config.camera, config.seed * 2654435761ULL + 2) {
  if (!(cfg_.coupling_step_s > 0) || !(cfg_.control_period_s >= cfg_.coupling_step_s))
    throw std::invalid_argument("Scheduler: need 0 < coupling_step_s <= control_period_s");
  if (cfg_.mode == ScrewMode::fil) {
    simmod_config_t sc;
    simmod_config_default(&sc);
    sc.elf_path = cfg_.elf_path.c_str();
    sc.count = 4;
    sc.threads = cfg_.threads;
    sc.realtime = cfg_.realtime ? 1 : 0;
    sc.pty_dir = cfg_.pty_dir.empty() ? nullptr : cfg_.pty_dir.c_str();
    sc.reset_on_open = cfg_.reset_on_open ? 1 : 0;
    sim_ = simmod_create(&sc);
    if (!sim_) throw std::runtime_error("Scheduler: simmod_create failed for " + cfg_.elf_path);
    for (int i = 0; i < 4; ++i) {
      links_.push_back(std::make_unique<SimModule>());
      proto_parser_init(&links_.back()->parser);
      shaft_angle_rad_[static_cast<std::size_t>(i)] = simmod_shaft_angle_rad(sim_, i);
    }
    simmod_set_uart_callback(sim_, &Scheduler::on_byte, this);
  }
}

Scheduler::~Scheduler() {
  if (sim_) simmod_destroy(sim_);
}

void Scheduler::set_log(std::ostream* out) {
  if (!out) {
    log_.reset();
    return;
  }
  std::vector<std::pair<std::string, std::string>> meta{{"format", kRobotLogFormat}, {"terrain", cfg_.terrain}};
  std::vector<std::string> extra;
  // A truth log on a field also records the ground under the robot (a measurement log never does).
  const Field* field = robot_.params().field.get();
  if (cfg_.log_truth && field) {
    meta.emplace_back("field", field->path);
    meta.emplace_back("terrain_ids", terrain_ids_metadata(*field));
    extra = ground_columns();
  }
  log_ = std::make_unique<RobotLogWriter>(*out, meta, extra);
}

void Scheduler::on_byte(void* ctx, int module, std::uint8_t byte, double) {
  auto* self = static_cast<Scheduler*>(ctx);
  SimModule& l = *self->links_.at(static_cast<std::size_t>(module));
  proto_parser_push(&l.parser, byte);
  proto_frame_t f;
  while (proto_parser_pop(&l.parser, &f)) {
    proto_telemetry_t tm;
    if (proto_decode_telemetry(&f, &tm)) l.tm.take(tm);
  }
}

void Scheduler::advance(double dt_s) {
  const double h = dt_s;
  if (sim_) {
    for (int i = 0; i < 4; ++i) simmod_set_load_torque(sim_, i, robot_.load_torque_nm()[i]);
    simmod_step_to(sim_, t_s_ + h);
    // Mean speed over the step from the shaft angle: what moved the robot in it.
    for (int i = 0; i < 4; ++i) {
      const double a = simmod_shaft_angle_rad(sim_, i);
      omega_true_[i] = (a - shaft_angle_rad_[static_cast<std::size_t>(i)]) / h * 60.0 / (2.0 * kPi);
      shaft_angle_rad_[static_cast<std::size_t>(i)] = a;
    }
  } else {
    // Ideal speed-controlled screw: omega' = (target - omega) / tau, exact over the step.
    const double k = 1.0 - std::exp(-h / cfg_.ideal_tau_s);
    const Vec4 start = omega_true_;
    omega_true_ = start + k * (target_rpm_ - start);
    if (cfg_.realtime) std::this_thread::sleep_for(std::chrono::duration<double>(h));
  }
  robot_.step(omega_true_, h);
  t_s_ += h;
  camera_.observe(t_s_, robot_.state().eta);
}

Eigen::Vector2d Scheduler::period_specific_force(double t_s) {
  // The mean over the period, from the change of the world velocity (eq. (5)), turned into the
  // body frame at the period's end, less gravity along the ground: what a MEMS accelerometer's
  // low-pass before its 100 Hz output gives. The instantaneous value at the sampling instant
  // (TrueRobot::specific_force_mps2) aliases the stick-slip of blocking screws: 0.17 m/s^2 on
  // average while a blocked robot stood still (uniform sand, seed 1).
  const TruthState& s = robot_.state();
  const double c = std::cos(s.eta[2]), sn = std::sin(s.eta[2]);
  const Eigen::Vector2d vw(c * s.zeta[0] - sn * s.zeta[1], sn * s.zeta[0] + c * s.zeta[1]);
  Eigen::Vector2d f = robot_.specific_force_mps2();
  if (t_s > imu_vw_t_s_) {
    const Eigen::Vector2d aw = (vw - imu_vw_) / (t_s - imu_vw_t_s_);
    f = Eigen::Vector2d(c * aw.x() + sn * aw.y(), -sn * aw.x() + c * aw.y()) - robot_.gravity_along_ground_body(s.eta[2]);
  }
  imu_vw_ = vw;
  imu_vw_t_s_ = t_s;
  return f;
}

void Scheduler::tick() {
  const double t = t_s_;
  const TruthState& truth = robot_.state();

  // Sensors delivered by now.
  const ImuReading imu = imu_.read(t, truth.eta[2], truth.zeta[2], period_specific_force(t));
  PoseReading pose{};
  bool got_pose = false;
  while (camera_.deliver(t, pose)) got_pose = true;  // keep the newest

  // Telemetry of this period.
  std::array<ScrewTelemetry, 4> tel{};
  for (std::size_t i = 0; i < 4; ++i) {
    if (sim_) {
      tel[i] = links_[i]->tm.controller_input();
    } else {
      tel[i].valid = true;
      tel[i].omega_rpm = std::round(omega_true_[static_cast<int>(i)] * 100.0) / 100.0;  // 0.01 rpm
    }
  }

  Vec4 cmd = Vec4::Zero();
  bool enabled = false;
  const bool commanding = controller_ || source_;
  if (controller_) {
    const SensorInput in = sensor_input(imu, got_pose ? &pose : nullptr);
    const auto& sp = controller_->step(t, tel, in);
    for (int i = 0; i < 4; ++i) cmd[i] = sp[static_cast<std::size_t>(i)];
    enabled = controller_->enabled();
  } else if (source_) {
    enabled = source_(t, cmd);
  }
  if (commanding) {
    if (sim_) {
      for (int i = 0; i < 4; ++i) {
        SimModule& l = *links_[static_cast<std::size_t>(i)];
        // The controller's setpoints are finite (it latches a fault otherwise); saturated to the wire.
        const bool clear = enabled && !l.cleared;
        l.cleared = l.cleared || clear;
        std::uint8_t buf[PROTO_MAX_FRAME];
        const std::size_t n = auger::io::encode_setpoint(++l.seq, cmd[i], enabled, clear, buf);
        simmod_uart_send(sim_, i, buf, n);
      }
    } else {
      for (int i = 0; i < 4; ++i)
        target_rpm_[i] = enabled ? std::clamp(cmd[i], -cfg_.omega_max_rpm, cfg_.omega_max_rpm) : 0.0;
    }
  }
  if (sink_) sink_(t, &imu, got_pose ? &pose : nullptr);

  if (log_) {
    RobotSample r;
    r.t_s = t;
    for (std::size_t i = 0; i < 4; ++i) {
      if (sim_) auger::io::log_telemetry(links_[i]->tm, i, r);
      r.omega_rpm[i] = cfg_.log_truth ? omega_true_[static_cast<int>(i)] : tel[i].omega_rpm;
      if (commanding) r.cmd_rpm[i] = cmd[static_cast<int>(i)];
    }
    if (cfg_.log_truth) {
      r.x_m = truth.eta[0];
      r.y_m = truth.eta[1];
      r.psi_rad = wrap_angle(truth.eta[2]);
    } else if (got_pose) {
      r.x_m = pose.pose[0];
      r.y_m = pose.pose[1];
      r.psi_rad = pose.pose[2];
    }
    r.imu_psi_rad = imu.psi_rad;
    r.imu_r_radps = imu.r_radps;
    r.imu_ax_mps2 = imu.ax_mps2;
    r.imu_ay_mps2 = imu.ay_mps2;
    if (controller_ && enabled) auger::io::log_reference(controller_->reference().eta_d, r);
    if (cfg_.log_truth && robot_.params().field) {
      ground_values(*robot_.params().field, robot_.centre_zone(truth), robot_.contact_zones(truth), log_extra_);
      log_->write(r, log_extra_);
    } else {
      log_->write(r);
    }
  }
  if (keep_history_ || tick_sink_) {
    TickRecord rec;
    rec.t_s = t;
    rec.eta_true = truth.eta;
    rec.eta_ref = controller_ ? controller_->reference().eta_d : truth.eta;
    rec.enabled = enabled;
    rec.cmd_rpm = cmd;
    rec.omega_true_rpm = omega_true_;
    rec.zone = robot_.centre_zone(truth);
    rec.contact_zone = robot_.contact_zones(truth);
    if (tick_sink_) tick_sink_(rec);
    if (keep_history_) history_.push_back(rec);
  }

  for (auto& l : links_) l->tm.fresh = false;
  // Advance the modules and the robot through the period in coupling steps.
  const int n = std::max(1, static_cast<int>(std::lround(cfg_.control_period_s / cfg_.coupling_step_s)));
  const double h = cfg_.control_period_s / n;
  for (int k = 0; k < n; ++k) advance(h);
}

void Scheduler::run_until(double t_end_s) {
  stop_ = false;
  while (t_s_ < t_end_s - 1e-9 && !stop_) tick();
}

}  // namespace auger::sim
