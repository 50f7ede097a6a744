// One cycle of a closed loop on a plant model with ideal screws (the host tests' plant): the
// controller steps on the true pose as the camera's (when `pose`) and the IMU's heading and rate,
// the plant moves under its setpoints for 10 ms, and the screws report them back.
#pragma once

#include <array>

#include "auger/controller.hpp"
#include "auger/dynamics.hpp"

namespace auger::test {

inline std::array<double, 4> closed_loop_cycle(Controller& c, const Model& plant, DynamicsData& dyn, Vec3& eta,
                                               Vec3& zeta, std::array<ScrewTelemetry, 4>& tel, double t_s, bool pose) {
  SensorInput s;
  s.has_pose = pose;
  s.pose = eta;
  s.has_imu_psi = s.has_imu_r = true;
  s.imu_psi_rad = eta.z();
  s.imu_r_radps = zeta.z();
  const std::array<double, 4> sp = c.step(t_s, tel, s);
  const Vec4 omega(sp[0], sp[1], sp[2], sp[3]);
  dynamics_step(plant, dyn, eta, zeta, omega, 0.01);
  for (int i = 0; i < 4; ++i) tel[static_cast<std::size_t>(i)] = {omega[i], true};
  return sp;
}

}  // namespace auger::test
