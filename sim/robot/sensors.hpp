// Simulated sensors (docs/robot-sim.md): an IMU (heading, yaw rate: white noise + constant
// bias; body-frame acceleration: white noise + a wandering bias) and an external camera (pose at a fixed rate, first-order Gauss-Markov "coloured" noise,
// latency, bursty dropouts). Seeded; the same seed gives the same readings.
#pragma once

#include <cmath>
#include <cstdint>
#include <deque>
#include <random>

#include "auger/controller.hpp"
#include "auger/model.hpp"

namespace auger::sim {

struct ImuParams {
  double psi_noise_rad = 0.005;    // white, per sample
  double r_noise_radps = 0.003;    // white, per sample
  double psi_bias_rad = 0.01;      // constant heading offset (mounting, magnetic)
  double r_bias_radps = 0.002;     // constant gyro bias
  // The accelerometer (body x, y; docs/robot-sim.md "Sensors"): a consumer MEMS part such as a
  // BMI088 or BNO085 has a noise density of 150-190 ug/sqrt(Hz) and a bias of some 20-50 mg
  // after calibration that wanders with temperature. White noise of 150 ug/sqrt(Hz) over the
  // 50 Hz band of 100 Hz samples: 1.47e-3 * sqrt(50) = 0.0104 m/s^2 per sample. A bias of
  // 0.03 / -0.02 m/s^2 (3 / 2 mg) at the start, then a random walk of 5e-4 m/s^2 per sqrt(s)
  // (0.012 m/s^2 after 10 min: more drift than a part at constant temperature shows).
  double acc_noise_mps2 = 0.0104;  // white, per sample
  double acc_bias_x_mps2 = 0.03, acc_bias_y_mps2 = -0.02;
  double acc_bias_walk_mps2_per_sqrt_s = 5e-4;
};

struct CameraParams {
  double rate_hz = 20.0;
  double latency_s = 0.03;         // capture to delivery
  Vec3 noise_std = Vec3(0.003, 0.003, 0.005);  // stationary std of the coloured noise (m, m, rad)
  double noise_corr_s = 0.3;       // correlation time of that noise
  double p_drop_start = 0.02;      // per frame: a dropout burst starts ...
  double p_drop_end = 0.3;         // ... and ends (Gilbert two-state model)
};

struct ImuReading {
  double t_s;
  double psi_rad, r_radps;
  double ax_mps2, ay_mps2;  // specific force, body frame
};

struct PoseReading {
  double t_capture_s, t_deliver_s;
  Vec3 pose;       // x_m, y_m, psi_rad
  Vec3 std_dev;    // what the camera reports as its standard deviation
};

class Imu {
 public:
  // The accelerometer draws from its own generator, so that the heading's and rate's readings
  // of a seed are those of before it had one.
  Imu(const ImuParams& p, std::uint64_t seed)
      : p_(p), rng_(seed), rng_acc_(seed ^ 0xacce1u), bias_acc_(p.acc_bias_x_mps2, p.acc_bias_y_mps2) {}
  // f_true_mps2: the true specific force at the IMU in the body frame (TrueRobot::specific_force_mps2).
  ImuReading read(double t_s, double psi_true_rad, double r_true_radps, const Eigen::Vector2d& f_true_mps2);

 private:
  ImuParams p_;
  std::mt19937_64 rng_, rng_acc_;
  std::normal_distribution<double> n01_{0.0, 1.0};
  Eigen::Vector2d bias_acc_;
  double last_t_s_ = NAN;
};

class Camera {
 public:
  Camera(const CameraParams& p, std::uint64_t seed) : p_(p), rng_(seed) {}
  // Called with the true pose at time t_s (at least as often as the frame rate): captures the
  // frames due by t_s (unless dropped) into the delivery queue.
  void observe(double t_s, const Vec3& eta_true);
  // Pops the frames delivered by t_s; false if none.
  bool deliver(double t_s, PoseReading& out);

 private:
  CameraParams p_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> n01_{0.0, 1.0};
  std::uniform_real_distribution<double> u01_{0.0, 1.0};
  double next_capture_s_ = 0.0;
  double last_t_s_ = 0.0;
  bool dropping_ = false;
  Vec3 colour_ = Vec3::Zero();
  bool colour_init_ = false;
  std::deque<PoseReading> queue_;
};

// The readings as the controller (and KinematicVelocity) take them; pose may be null (none
// delivered). The pose's time is its capture time: the camera's latency.
SensorInput sensor_input(const ImuReading& imu, const PoseReading* pose);

}  // namespace auger::sim
