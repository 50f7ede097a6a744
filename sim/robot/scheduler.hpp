// Lock-step scheduler (docs/robot-sim.md): advances the four screw modules and the true robot
// together in simulated time, and every control period (10 ms) collects module telemetry and
// sensor readings, calls the host controller's step with the simulated clock (docs/design.md "Time"),
// sends its setpoints as augerd would, and writes a robot log row (docs/log-format.md).
// Modules: firmware in the loop (sim/simmod.h: the real firmware, setpoints and telemetry over
// the protocol of shared/protocol.h) or ideal speed-controlled screws (first-order lag).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "auger/controller.hpp"
#include "auger/log.hpp"
#include "sensors.hpp"
#include "true_robot.hpp"

struct simmod_t;

namespace auger::sim {

enum class ScrewMode { ideal, fil };

struct SchedulerConfig {
  ScrewMode mode = ScrewMode::ideal;
  double control_period_s = 0.01;   // host loop (100 Hz)
  double coupling_step_s = 0.001;   // modules <-> robot exchange (speed out, load torque in)
  double ideal_tau_s = 0.05;        // ideal screws: first-order lag to the setpoint
  double omega_max_rpm = 23.0;      // ideal screws saturate here (motor rating)
  // firmware in the loop
  std::string elf_path;             // firmware image
  int threads = 1;                  // simmod worker threads
  bool realtime = false;            // pace to the wall clock (the demo)
  std::string pty_dir;              // ptys per module (the demo: augerd drives them)
  bool reset_on_open = true;
  // sensors
  ImuParams imu;
  CameraParams camera;
  std::uint64_t seed = 1;
  // log: pose columns from the camera (a measurement log) or the true pose (truth log)
  bool log_truth = false;
  std::string terrain = "sand";
};

// One control period's record (for tests and metrics).
struct TickRecord {
  double t_s = 0;
  Vec3 eta_true = Vec3::Zero();
  Vec3 eta_ref = Vec3::Zero();
  bool enabled = false;
  Vec4 cmd_rpm = Vec4::Zero();
  Vec4 omega_true_rpm = Vec4::Zero();
  int zone = 0;                        // the field's zone under the body's centre (field.hpp; 0 without one)
  std::array<int, 4> contact_zone{};   // and under each screw's contact
};

class Scheduler {
 public:
  Scheduler(const Model& nominal, const TruthParams& truth, const SchedulerConfig& config);
  ~Scheduler();
  Scheduler(const Scheduler&) = delete;
  Scheduler& operator=(const Scheduler&) = delete;

  // The host controller (not owned; may be null: then no setpoints are sent, e.g. when augerd
  // drives the modules through their ptys).
  void set_controller(Controller* controller) { controller_ = controller; }
  // Without a controller, setpoints from a function of time (open-loop driving, as augerd's `vel`
  // does); returns whether the screws are enabled.
  using CommandSource = std::function<bool(double t_s, Vec4& cmd_rpm)>;
  void set_command_source(CommandSource source) { source_ = std::move(source); }
  // Robot log destination (not owned); metadata `format` and `terrain` only.
  void set_log(std::ostream* out);
  // Called once per control period with the readings delivered in it (null if none).
  using SensorSink = std::function<void(double t_s, const ImuReading* imu, const PoseReading* pose)>;
  void set_sensor_sink(SensorSink sink) { sink_ = std::move(sink); }
  // Called once per control period with its record (a truth log streamed, not kept in memory).
  using TickSink = std::function<void(const TickRecord&)>;
  void set_tick_sink(TickSink sink) { tick_sink_ = std::move(sink); }

  // Advance whole control periods until t_s (simulated seconds from creation).
  void run_until(double t_s);
  // Advance one control period.
  void tick();
  // Stop early (e.g. a signal handler sets it); run_until returns after the current period.
  void request_stop() { stop_ = true; }

  double t_s() const { return t_s_; }
  TrueRobot& robot() { return robot_; }
  const std::vector<TickRecord>& history() const { return history_; }
  void set_keep_history(bool keep) { keep_history_ = keep; }
  simmod_t* modules() { return sim_; }
  // Mean of the true screw speeds over the last coupling step.
  const Vec4& omega_true_rpm() const { return omega_true_; }

 private:
  static void on_byte(void* ctx, int module, std::uint8_t byte, double t_s);
  void advance(double dt_s);
  // The IMU's specific force over the period ending at t_s (body frame, m/s^2).
  Eigen::Vector2d period_specific_force(double t_s);

  SchedulerConfig cfg_;
  TrueRobot robot_;
  Imu imu_;
  Camera camera_;
  Controller* controller_ = nullptr;
  CommandSource source_;
  SensorSink sink_;
  TickSink tick_sink_;
  simmod_t* sim_ = nullptr;
  struct SimModule;  // protocol parser, latest telemetry (host/io's module adapter), setpoint state
  std::vector<std::unique_ptr<SimModule>> links_;
  std::unique_ptr<RobotLogWriter> log_;
  std::vector<double> log_extra_;  // the truth log's ground columns (with a field)
  double t_s_ = 0;
  bool stop_ = false;
  bool keep_history_ = true;
  Vec4 omega_true_ = Vec4::Zero();
  Vec4 target_rpm_ = Vec4::Zero();
  std::array<double, 4> shaft_angle_rad_{};
  std::vector<TickRecord> history_;
  bool have_pose_ = false;
  PoseReading last_pose_{};
  Eigen::Vector2d imu_vw_ = Eigen::Vector2d::Zero();  // the world velocity at the last IMU reading
  double imu_vw_t_s_ = INFINITY;
};

}  // namespace auger::sim
