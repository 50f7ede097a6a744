// Synthetic logs for the workbench engine's unit tests (test_workbench_engine.cpp,
// test_workbench_explain.cpp), made with the host model itself (not the simulator): a mixed drive
// of the screws, the camera and IMU with noise, coloured camera noise, and the nominal model.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "workbench.hpp"

namespace auger::wb::test {

inline const TerrainParams kSand{"sand", 0.812, 0.247, 560.33, 320.08, 11.46};

// Screw speeds of a mixed drive: pieces of forward, lateral, yaw and combined motion with
// ramps (or steps) and stops (rpm), piece length piece_s.
Vec4 drive_profile(double t, double piece_s = 4.0, bool ramps = true);

struct SynthOptions {
  double seconds = 60;
  double pose_noise_m = 0.003, psi_noise_rad = 0.005, imu_noise_rad = 0.005;
  int pose_every = 5;          // 20 Hz poses in a 100 Hz log
  double pose_delay_s = 0;     // poses show the state this much earlier
  bool gaps = true;            // a 1 s gap without poses every 20 s
  bool steps = false;          // speeds step (from rest at t = 0 straight to the first piece's)
  double drive_scale = 1;      // drive_profile's speeds times this (a slow drive: a robot that stalls)
  bool speed_sweep = false;    // each 4 s piece's speeds also times 0.15-1 (golden-ratio steps): many steady speeds
  unsigned seed = 1;
  std::function<Vec4(double)> drive;  // screw speeds (rpm) at t in place of drive_profile's, if set
};

// A log of the host model `truth` driven by drive_profile, noise added.
Dataset synth(const Model& truth, const SynthOptions& o);

// Camera noise that wanders (first-order Gauss-Markov, correlation corr_s, stationary std 3 mm /
// 5 mrad), plus a second such process of correlation corr2_s (0: none) of half that std, added to
// the poses of a synthetic log; returns the std of what was added per channel.
Vec3 add_camera_colour(Dataset& d, unsigned seed, double corr_s, double corr2_s);

// The paper's model on sand, as `choose_model` gives it for a log without a model file.
ModelChoice nominal();
// The nominal model with these effects.
ModelChoice with_effects(std::vector<std::shared_ptr<const Effect>> effects);
const EffectRegistry::Entry& entry(const char* id);

// Parameter values for an effect to make data with: a clear but plausible size from each
// parameter's typical value (the registry's fitting metadata), so a new effect gets one too.
std::vector<double> test_values(const EffectRegistry::Entry& e, double duration_s);

// A fitted parameter of explain's final model, NaN if it is not there.
double param_of(const ExplainResult& r, const std::string& effect, const std::string& name);
// A parameter of a fitted effect, NaN if it has none of that name.
double value_of(const FittedEffect& e, const std::string& name);

}  // namespace auger::wb::test
