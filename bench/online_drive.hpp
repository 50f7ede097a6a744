// Driving data for the online estimator from the core's own model (eqs. (5)-(7), dynamics.hpp):
// screw speeds held for random 0.3-1 s spans (random body velocities through eq. (3), within
// 23 rpm), the true velocity with white noise as the "fused" velocity, and the terrain switched
// at a known time. Used by bench/online_bench.cpp and tests/host/test_online_estimator.cpp.
#pragma once

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "auger/controller.hpp"
#include "auger/dynamics.hpp"
#include "auger/kinematic_velocity.hpp"
#include "auger/model.hpp"
#include "auger/online_estimator.hpp"

namespace auger {

struct OnlineDriveOptions {
  double change_at_s = std::nan("");  // the terrain switches here (NaN: never)
  Vec3 velocity_sd = Vec3(0.002, 0.002, 0.005);  // noise of the velocity fed to the estimator
  bool forward_only = false;  // one-DOF driving: u only
  double hold_min_s = 0.3, hold_max_s = 1.0;
  unsigned seed = 1;
};

class OnlineDrive {
 public:
  static constexpr double kDt = 0.01;  // augerd's period

  // Both models must outlive the drive.
  OnlineDrive(const Model& before, const Model& after, const OnlineDriveOptions& o)
      : before_(before), after_(after), o_(o), rng_(o.seed), data_(before) {}

  // Advances one cycle; omega_rpm held over it, zeta_meas the noisy velocity at its end.
  void next() {
    if (t_s_ >= hold_until_s_) {
      std::uniform_real_distribution<double> u(-1, 1), h(o_.hold_min_s, o_.hold_max_s);
      Vec3 cmd(0.08 * u(rng_), o_.forward_only ? 0.0 : 0.08 * u(rng_), o_.forward_only ? 0.0 : 0.4 * u(rng_));
      if (std::fabs(cmd[0]) < 0.02 && o_.forward_only) cmd[0] = 0.05;
      omega_rpm = kinematic_screw_speeds_rpm(before_, cmd);
      const double peak = omega_rpm.cwiseAbs().maxCoeff();
      if (peak > 23.0) omega_rpm *= 23.0 / peak;
      hold_until_s_ = t_s_ + h(rng_);
    }
    dynamics_step(truth(), data_, eta_, zeta_, omega_rpm, kDt, 4);
    t_s_ += kDt;
    std::normal_distribution<double> n(0, 1);
    for (int k = 0; k < 3; ++k) zeta_meas[k] = zeta_[k] + o_.velocity_sd[k] * n(rng_);
  }
  const Model& truth() const { return changed() ? after_ : before_; }
  bool changed() const { return t_s_ >= o_.change_at_s; }
  double t_s() const { return t_s_; }
  const Vec3& zeta_true() const { return zeta_; }
  const Vec3& eta_true() const { return eta_; }  // the pose (the online effects read the heading)

  Vec4 omega_rpm = Vec4::Zero();
  Vec3 zeta_meas = Vec3::Zero();

 private:
  const Model& before_;
  const Model& after_;
  OnlineDriveOptions o_;
  std::mt19937 rng_;
  DynamicsData data_;
  Vec3 eta_ = Vec3::Zero(), zeta_ = Vec3::Zero();
  double t_s_ = 0, hold_until_s_ = 0;
};

// Closed loop on the core's model (issue 29 point 3 at the model's level, not with the firmware):
// the controller, configured for `configured`, tracks 0.5 m squares (10 s a side) while the truth
// is `before` and then `after` from change_at_s; a camera pose (2 mm, 2 mrad) every third cycle
// and the IMU (heading 5 mrad, rate 5 mrad/s) every cycle, ideal screws. With `online` the
// estimator runs on the controller's EKF velocity and its parameters go into the controller's
// model as augerd does (host/augerd/online_link.cpp). velocity kTrueVelocity: on the true
// velocity with 0.5 mm/s of noise instead (what a velocity independent of the model would give);
// kKinematicVelocity: on KinematicVelocity's (the camera and IMU alone, no terrain model) with
// the drag held at the configured values (drag_prior_rel_sd 0.01), as augerd's
// velocity = "kinematic". The tracking error is the true pose against the reference eq. (18),
// from 5 s on.
struct TrackingRun {
  double rms_m = 0, rms_rad = 0;  // position and heading error, RMS
  std::uint64_t changes = 0;
  Vec5 used = Vec5::Zero();  // the controller's terrain at the end
};

enum VelocitySource : int { kEkfVelocity = 0, kTrueVelocity = 1, kKinematicVelocity = 2 };

inline TrackingRun online_tracking_run(const Model& before, const Model& after, double change_at_s,
                                       const Model& configured, const ControllerConfig& cc, bool online,
                                       double seconds, unsigned seed, int velocity = kEkfVelocity) {
  const bool true_velocity = velocity == kTrueVelocity;
  KinematicVelocity kin;
  constexpr double dt = 0.01;
  Model model = configured;  // the controller's, updated in place
  Controller c(model, cc);
  c.reset(Vec3::Zero());
  std::vector<Waypoint> w;
  const Vec3 corners[4] = {Vec3(0.5, 0, 0), Vec3(0.5, 0.5, 0), Vec3(0, 0.5, 0), Vec3(0, 0, 0)};
  for (int k = 0; 10.0 * k < seconds; ++k) w.push_back({10.0 * k, corners[k % 4]});
  c.set_waypoints(w);
  c.set_enabled(true);
  OnlineConfig oc;
  oc.enabled = online;
  if (true_velocity) oc.velocity_sd = Vec3(0.0005, 0.0005, 0.00125);
  if (velocity == kKinematicVelocity) {
    // The kinematic filter's velocity error here: 4-6 mm/s RMS in u and v (its own SD 5.7 mm/s).
    // The drag held at the configured values: slow tracking identifies sigma / D only.
    oc.velocity_sd = Vec3(0.006, 0.006, 0.005);
    oc.drag_prior_rel_sd = 0.01;
  }
  OnlineEstimator est(configured, oc);
  DynamicsData data(before);
  Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, 1);
  std::array<double, 4> sp{};
  std::array<ScrewTelemetry, 4> tel{};
  double sum_m2 = 0, sum_rad2 = 0;
  long counted = 0;
  for (long k = 0; k * dt < seconds; ++k) {
    const double t_s = k * dt;
    const Vec4 omega_rpm(sp[0], sp[1], sp[2], sp[3]);
    dynamics_step(t_s >= change_at_s ? after : before, data, eta, zeta, omega_rpm, dt, 4);
    SensorInput s;
    s.has_pose = k % 3 == 0;
    s.pose = eta + Vec3(0.002 * n(rng), 0.002 * n(rng), 0.002 * n(rng));
    s.pose_cov = Mat3::Identity() * 4e-6;
    s.has_imu_psi = s.has_imu_r = true;
    s.imu_psi_rad = wrap_angle(eta.z() + 0.005 * n(rng));
    s.imu_r_radps = zeta.z() + 0.005 * n(rng);
    for (int i = 0; i < 4; ++i) tel[std::size_t(i)] = {sp[std::size_t(i)], true};
    sp = c.step(t_s + dt, tel, s);
    // The EKF's velocity (as augerd), the true one with 0.5 mm/s of noise (a velocity sensor
    // independent of the model), or the kinematic filter's.
    const Vec3 v_kin = kin.step(s, dt);
    const Vec3 v = true_velocity                    ? Vec3(zeta + Vec3(0.0005 * n(rng), 0.0005 * n(rng), 0.00125 * n(rng)))
                   : velocity == kKinematicVelocity ? v_kin
                                                    : c.zeta_estimate();
    if (online && v.allFinite()) est.step(omega_rpm, v, dt);
    if (online && est.applied_changed()) set_terrain_parameters(model, est.control_parameters());
    if (t_s >= 5.0) {
      const Vec3 e = eta - c.reference().eta_d;
      sum_m2 += e.head<2>().squaredNorm();
      sum_rad2 += wrap_angle(e.z()) * wrap_angle(e.z());
      ++counted;
    }
  }
  TrackingRun r;
  r.rms_m = std::sqrt(sum_m2 / double(std::max(1L, counted)));
  r.rms_rad = std::sqrt(sum_rad2 / double(std::max(1L, counted)));
  r.changes = est.changes();
  r.used << model.terrain.sigma_long, model.terrain.sigma_lat, model.terrain.D_x, model.terrain.D_y, model.terrain.D_psi;
  return r;
}

}  // namespace auger
