// Model files (TOML, schema 1; docs/model.md): the robot, the terrain sets and the effects in use.
// Unknown keys and unknown effects are errors naming the file and line (ConfigError).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "auger/controller.hpp"
#include "auger/effect.hpp"
#include "auger/model.hpp"

namespace auger {

constexpr int kModelSchema = 1;

struct TerrainEntry {
  TerrainParams params;
  int line = 0;
  std::string comment;  // written before the table (write_model_file); the reader leaves it empty
};

// [control]: controller settings; each key optional, absent ones keep the defaults of
// ControllerConfig (Table 5 gains for the chosen terrain).
struct ControlSection {
  std::optional<Vec3> gamma_per_s, kp, kd, ki, integral_limit;
  std::optional<AllocatorKind> allocator;
  std::optional<AllocationPriority> priority;
  std::optional<double> omega_min_rpm, engage_rpm, sign_hold_rpm;
  std::optional<EstimatorKind> estimator;
};

struct ModelFile {
  std::string path;
  std::string comment;  // written at the top (write_model_file); the reader leaves it empty
  int schema = kModelSchema;
  std::string omega_unit = "rpm";
  std::string frame = "rep103";
  std::optional<RobotParams> robot;  // [robot]
  int robot_line = 0;
  std::optional<double> gantry_mass_kg;  // [gantry] mass_kg: module plus load (Table 2)
  std::vector<TerrainEntry> terrains;    // [terrain.NAME]
  std::vector<EffectConfig> effects;     // [[effect]]
  ControlSection control;                // [control]
  const TerrainEntry* find_terrain(const std::string& name) const;
};

// Parses TOML text; name is what errors call the source. Throws ConfigError.
ModelFile parse_model_file(const std::string& text, const std::string& name);
ModelFile load_model_file(const std::string& path);

// The text of a model file that parse_model_file reads back to the same values, every double to
// the same bits (toml++ writes them with 17 significant digits): schema, omega_unit, frame,
// [robot], [gantry], the terrains, the effects, [control]. The comments (one `#` line per line)
// go before what they belong to. Angles are written in degrees, the value that converts back to
// the same radians (exact for every angle that came from degrees, as any read from a file).
std::string write_model_file(const ModelFile& file);

// Builds the robot model on one terrain with the file's effects; throws ConfigError naming the
// file and line of what is missing or wrong.
Model build_model(const ModelFile& file, const std::string& terrain,
                  const EffectRegistry& registry = EffectRegistry::builtin());

// The controller configuration for a terrain: Table 5 gains of that terrain, the robot's speed
// limit, then the file's [control] overrides.
ControllerConfig controller_config(const ModelFile& file, const std::string& terrain);

}  // namespace auger
