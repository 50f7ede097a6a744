// A gantry run generated inside the tests from a known sigma and D (eqs. (11)-(14)), written
// independently of the workbench and of the simulator: the module's speed follows its setpoint
// with a first-order lag, the load cell reads the traction force plus white noise and an AR(1)
// rig vibration, and the position is integrated exactly and read with noise.
#pragma once

#include <cmath>
#include <random>
#include <sstream>
#include <string>

#include "identify.hpp"

namespace tools_test {

struct GantryTruth {
  std::string axis = "longitudinal";
  std::string terrain = "sand";
  double sigma = 0.812, D = 529.95, mass_kg = 16;
  double force_white_n = 1.0, force_vibration_n = 3.0, vibration_rho = 0.9;
  double position_noise_m = 0.0008, omega_noise_rpm = 0.2;
  int reps = 4;
  double drive_s = 6.0, rest_s = 1.0;
};

inline auger::wb::GantryData make_gantry(const GantryTruth& tr, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0, 1);
  auger::wb::GantryData g;
  g.file = "generated-" + tr.axis + "-" + std::to_string(seed);
  g.axis = tr.axis;
  g.terrain = tr.terrain;
  g.mass_kg = tr.mass_kg;
  g.mass_from_log = true;
  const double dt = 0.01, lag_s = 0.1;
  // B_x = [-1, -1], B_y = [-1, 1] (eqs. (12), (14)): the setpoints that give drive = 2 w.
  const double s1 = tr.axis == "longitudinal" ? -1 : 1;
  double t = 0, w = 0, v = 0, x = 0, vib = 0;
  int dir = 1;
  for (int rep = 0; rep < tr.reps; ++rep) {
    for (double speed : {5.0, 10.0, 20.0}) {
      for (int phase = 0; phase < 2; ++phase) {
        const double w_cmd = phase == 0 ? 0 : speed * dir;
        const int steps = static_cast<int>(std::lround((phase == 0 ? tr.rest_s : tr.drive_s) / dt));
        for (int k = 0; k < steps; ++k) {
          w += (w_cmd - w) * (1 - std::exp(-dt / lag_s));
          const double drive = 2 * w;
          const double tau = tr.sigma * drive;
          // eq. (11) stepped exactly over dt with tau held.
          const double a = std::exp(-tr.D / tr.mass_kg * dt), v_ss = tau / tr.D;
          x += v_ss * dt + (v - v_ss) * (1 - a) * tr.mass_kg / tr.D;
          v = v_ss + (v - v_ss) * a;
          vib = tr.vibration_rho * vib + std::sqrt(1 - tr.vibration_rho * tr.vibration_rho) * tr.force_vibration_n * n01(rng);
          t += dt;
          const double om0 = -w + tr.omega_noise_rpm * n01(rng);
          const double om1 = s1 * w + tr.omega_noise_rpm * n01(rng);
          g.t_s.push_back(t);
          g.drive_rpm.push_back(-om0 + s1 * om1);
          g.force_n.push_back(tau + vib + tr.force_white_n * n01(rng));
          g.position_m.push_back(x + tr.position_noise_m * n01(rng));
        }
      }
      dir = -dir;  // back and forth along the rail, as on a real gantry
    }
  }
  return g;
}

// The same run as a gantry log file's text (for the command-line tests).
inline std::string gantry_log_text(const auger::wb::GantryData& g) {
  std::ostringstream os;
  os.precision(10);
  os << "# format: auger-gantry-log v1\n# axis: " << g.axis << "\n# terrain: " << g.terrain
     << "\n# mass_kg: " << g.mass_kg << "\nt_s,omega_rpm_0,omega_rpm_1,force_n,position_m\n";
  const double s1 = g.axis == "longitudinal" ? -1 : 1;
  for (std::size_t i = 0; i < g.t_s.size(); ++i) {
    // Split the drive back into two screw speeds with B . omega = drive.
    const double w = g.drive_rpm[i] / 2;
    os << g.t_s[i] << ',' << -w << ',' << s1 * w << ',' << g.force_n[i] << ',' << g.position_m[i] << '\n';
  }
  return os.str();
}

}  // namespace tools_test
