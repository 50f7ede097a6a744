// The log generator's parts (log_gen.hpp): the hidden effects (log_gen_effects.cpp), the robot's
// run and its sensors (log_gen_robot.cpp), the gantry's (log_gen_gantry.cpp), and the ideal screws,
// encoders and truth file both use (log_gen.cpp).
#pragma once

#include <string>
#include <vector>

#include "log_gen.hpp"
#include "true_gantry.hpp"
#include "true_robot.hpp"

namespace auger::sim::loggen {

constexpr double kTick_s = 0.01;     // log rows and screw commands (the host loop, 100 Hz)
constexpr double kCouple_s = 0.001;  // screw lag <-> robot exchange, as the scheduler does

// ---- the hidden effects (log_gen_effects.cpp) ----

// The effect's parameters and doc; throws std::invalid_argument naming the known ids.
const EffectInfo& info_of(const std::string& id);
// Parameter value of the effect, its default if not given.
double param(const EffectSpec& e, const std::string& name);
// The effect's physics applied to the robot's truth (run_s: the run's length), and to the
// gantry's (rail_m: the rail's length); effects that act on the sensors change nothing here.
void apply_robot_effect(const EffectSpec& e, double run_s, TruthParams& tp, Model& truth_model);
void apply_gantry_effect(const EffectSpec& e, bool lateral, double rail_m, GantryTruthParams& gp);
// The effects to apply ("none" entries dropped).
std::vector<EffectSpec> active_effects(const LogGenConfig& cfg);
// The effect of that id among effects, or null.
const EffectSpec* find_effect(const std::vector<EffectSpec>& effects, const std::string& id);

// ---- ideal screws and encoders (log_gen.cpp) ----

// Ideal speed-controlled screw over one coupling step: omega' = (target - omega) / tau, exact.
// Returns the mean speed over the step (what moves the robot and turns the shaft).
Vec4 ideal_screw_step(Vec4& omega_rpm, const Vec4& target_rpm, double tau_s, double h_s);
// Encoder: counts of a shaft angle (in revolutions); the speed reported for a 10 ms window is
// the count difference (docs/model-notes.md: 48 counts per motor revolution, ~369:1), in 0.01 rpm.
double encoder_rpm(double rev_prev, double rev_now, double counts_per_rev);

}  // namespace auger::sim::loggen
