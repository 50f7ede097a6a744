// Batch log generator (docs/robot-sim.md "auger-sim-log"): the true robot (or one screw module on
// the identification gantry) driven open loop by ideal speed-controlled screws along a scripted
// trajectory, with hidden effects, written as a robot or gantry log (docs/log-format.md) whose only
// metadata are format and terrain (gantry: also axis and mass_kg, which the format requires).
// The truth (pose, velocity, where the effect acts) goes to a separate file the tests read and
// the workbench never sees.
#pragma once

#include <cstdint>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "auger/model.hpp"

namespace auger::sim {

// One hidden effect: its id (the workbench library's identifier, or "none", or one outside the
// library) and parameters by name. Unknown ids or parameters are errors (std::invalid_argument).
struct EffectSpec {
  std::string id = "none";
  std::map<std::string, double> params;
};
// Parses "ID" or "ID:name=value,name=value"; throws std::invalid_argument naming the bad part.
EffectSpec parse_effect_spec(const std::string& text);
// The ids the generator knows (robot and gantry), with their parameters and defaults.
struct EffectInfo {
  std::string id;
  bool robot, gantry;
  std::vector<std::pair<std::string, double>> params;  // name, default
  std::string doc;
};
const std::vector<EffectInfo>& known_effects();

enum class Trajectory { single_dof, manual };
enum class GantryAxis { none, longitudinal, lateral };

struct LogGenConfig {
  std::string terrain = "sand";
  std::uint64_t seed = 1;
  double seconds = 150.0;
  Trajectory trajectory = Trajectory::manual;
  GantryAxis gantry = GantryAxis::none;
  // Hidden effects, applied together (none: the truth is the nominal model). A gantry log takes
  // at most one.
  std::vector<EffectSpec> effects;
  // The robot's base physics (robot logs): false, the nominal linear model (no Coriolis terms,
  // the model's yaw time constant, no blocking); true, the physical robot the firmware-in-the-loop
  // chain drives (Coriolis terms, the real lever arms' yaw time constant, blocking of screws
  // slower than blocking_rpm on sand).
  bool physical_base = false;
  double blocking_rpm = 1.5;
  // Camera (robot) or ToF sensor (gantry): white Gaussian noise, so the tests know what they
  // injected. The robot's pose comes at pose_rate_hz (other rows empty).
  Vec3 pose_noise = Vec3(0.003, 0.003, 0.005);  // m, m, rad
  double pose_rate_hz = 20.0;
  double imu_psi_noise_rad = 0.005, imu_r_noise_radps = 0.003;
  double gantry_position_noise_m = 0.002;       // VL53L0X-like
  double gantry_force_noise_n = 0.5;            // force-torque sensor
  // Encoders: counts per screw revolution (48 counts x ~369:1, docs/model-notes.md "Hardware facts");
  // the measured speed is counts per 10 ms window, reported in 0.01 rpm (telemetry omega_crpm).
  double counts_per_rev = 48.0 * 369.0;
  double ideal_tau_s = 0.05;                    // ideal screws' first-order lag (scheduler's)
  double omega_max_rpm = 23.0;
  double size_segment_s = 25.0;                 // effect-size report: base re-initialised this often
};

// What one run produced, sampled every 10 ms (the log's rows).
struct TruthRow {
  double t_s;
  Vec3 eta, zeta;
  bool acting;  // the hidden effect acts here (soft patch: a contact on it; terrain change: after)
};
struct LogGenResult {
  std::vector<TruthRow> truth;
  // RMS over the run of (truth with the effect - base truth), the base re-initialised to the
  // truth every size_segment_s: how much the effect moves the robot (x, y in m, psi in rad).
  Vec3 effect_rms = Vec3::Zero();
  std::vector<std::string> notes;  // resolved parameters (e.g. where the soft patch lies)
};

// Runs the generator and writes the log to out. nominal: the model file's robot on the terrain
// (robot) or the gantry module (gantry_mass_kg, sigma, D of the terrain).
LogGenResult generate_robot_log(const Model& nominal, const LogGenConfig& config, std::ostream& out);
LogGenResult generate_gantry_log(const TerrainParams& terrain, double mass_kg, const LogGenConfig& config,
                                 std::ostream& out);

// Writes the truth as CSV (t_s, x_m, y_m, psi_rad, u_mps, v_mps, r_radps, acting).
void write_truth(const LogGenResult& result, std::ostream& out);

}  // namespace auger::sim
