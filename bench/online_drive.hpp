// Driving data for the online estimator from the core's own model (eqs. (5)-(7), dynamics.hpp):
// screw speeds held for random 0.3-1 s spans (random body velocities through eq. (3), within
// 23 rpm), the true velocity with white noise as the "fused" velocity, and the terrain switched
// at a known time. Used by bench/online_bench.cpp and tests/host/test_online_estimator.cpp.
#pragma once

#include <algorithm>
#include <cmath>
#include <random>

#include "auger/dynamics.hpp"
#include "auger/model.hpp"

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

}  // namespace auger
