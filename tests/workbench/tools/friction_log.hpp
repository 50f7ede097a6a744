// A log for the report and text-output tests: 80 s of manual-style driving of the nominal sand
// model (the paper's Table 3) with a 12 N dry friction along x that the nominal model does not
// have, pose at 20 Hz with 3 mm / 5 mrad noise, IMU heading every row.
#pragma once

#include <random>
#include <sstream>
#include <string>

#include "auger/dynamics.hpp"
#include "auger/model.hpp"

namespace tools_test {

inline std::string dry_friction_log(const std::string& terrain = "sand") {
  using namespace auger;
  const Model m = make_model(RobotParams{}, TerrainParams{"sand", 0.812, 0.247, 560.33, 320.08, 11.46});
  DynamicsData data(m);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n01(0, 1);
  Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
  std::ostringstream os;
  os.precision(10);
  os << "# format: auger-robot-log v1\n# terrain: " << terrain << "\n"
     << "t_s,omega_rpm_0,omega_rpm_1,omega_rpm_2,omega_rpm_3,x_m,y_m,psi_rad,imu_psi_rad\n";
  const double dt = 0.01;
  for (int k = 0; k < 8000; ++k) {
    const double t = k * dt;
    // Forward, sideways, turning, combined: 10 s each, twice.
    const int phase = static_cast<int>(t / 10) % 4;
    const Vec3 body = phase == 0 ? Vec3(0.05, 0, 0) : phase == 1 ? Vec3(0, 0.06, 0)
                    : phase == 2 ? Vec3(0, 0, 0.15) : Vec3(0.03, -0.03, -0.1);
    const Vec4 omega = kinematic_screw_speeds_rpm(m, body);
    if (k % 5 == 0) {
      os << t << ',' << omega[0] << ',' << omega[1] << ',' << omega[2] << ',' << omega[3] << ','
         << eta.x() + 0.003 * n01(rng) << ',' << eta.y() + 0.003 * n01(rng) << ','
         << wrap_angle(eta.z() + 0.005 * n01(rng)) << ',' << wrap_angle(eta.z() + 0.005 * n01(rng)) << '\n';
    } else {
      os << t << ',' << omega[0] << ',' << omega[1] << ',' << omega[2] << ',' << omega[3] << ",,,,"
         << wrap_angle(eta.z() + 0.005 * n01(rng)) << '\n';
    }
    dynamics_step(m, data, eta, zeta, omega, dt);
    zeta.x() -= 0.01 * 12.0 / 29.0 * (zeta.x() > 0 ? 1 : zeta.x() < 0 ? -1 : 0);  // 12 N dry friction along x
  }
  return os.str();
}

}  // namespace tools_test
