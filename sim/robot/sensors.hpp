// Simulated sensors (docs/robot-sim.md): an IMU (heading, yaw rate: white noise + constant
// bias) and an external camera (pose at a fixed rate, first-order Gauss-Markov "coloured" noise,
// latency, bursty dropouts). Seeded; the same seed gives the same readings.
#pragma once

#include <cstdint>
#include <deque>
#include <random>

#include "auger/model.hpp"

namespace auger::sim {

struct ImuParams {
  double psi_noise_rad = 0.005;    // white, per sample
  double r_noise_radps = 0.003;    // white, per sample
  double psi_bias_rad = 0.01;      // constant heading offset (mounting, magnetic)
  double r_bias_radps = 0.002;     // constant gyro bias
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
};

struct PoseReading {
  double t_capture_s, t_deliver_s;
  Vec3 pose;       // x_m, y_m, psi_rad
  Vec3 std_dev;    // what the camera reports as its standard deviation
};

class Imu {
 public:
  Imu(const ImuParams& p, std::uint64_t seed) : p_(p), rng_(seed) {}
  ImuReading read(double t_s, double psi_true_rad, double r_true_radps);

 private:
  ImuParams p_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> n01_{0.0, 1.0};
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

}  // namespace auger::sim
