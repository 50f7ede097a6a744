// The terrain a subcommand analyses a log with, and what every output says about it
// (docs/workbench.md "Terrain"): the log's `# terrain:`, `--terrain NAME`, or `--terrain auto`
// (the paper's table terrain whose nominal model fits the log best). A log that names no terrain
// is analysed with sand, never in silence; and where another table terrain's nominal model fits
// the log clearly better than the one used, the output says so and names the command to run.
#pragma once

#include <string>
#include <vector>

#include "auger/args.hpp"
#include "workbench.hpp"

namespace auger::wb {

inline const OptionDoc kTerrainOption{
    "--terrain", "NAME|auto",
    "the terrain's parameters to use: NAME instead of the log's `# terrain:`;\n"
    "auto: the table terrain whose nominal model fits the log best\n"
    "(docs/workbench.md \"Terrain\")"};

// A table terrain's nominal model on the log: its error over segments of 25 s (compare's
// headline), the RMS over channels of the multiples of the noise floor.
struct TerrainFit {
  std::string terrain;
  double ratio = 0;
};

struct TerrainChoice {
  ModelChoice model;
  std::string from;               // "log", "log_unknown" (not in the model), "--terrain", "auto", "assumed" (the log names none)
  std::vector<TerrainFit> fits;   // the tables' terrains (the model file's with --model --terrain auto)
  std::string better;             // a table terrain fitting clearly better than the one used, or ""
  std::vector<std::string> warnings;  // for stderr and the JSON's `warnings`, in words
};

// A table terrain's nominal model fits "clearly better" with an error this much lower.
constexpr double kTerrainClearlyBetter = 0.8;

// The model for data as --model (model_path) and --terrain (option: "", a name or "auto") ask;
// data.terrain is set to the terrain used when the option chose it, so that a model file written
// for the log loads back for it. Throws std::runtime_error for a name the tables (or the model
// file) lack. `command` and `args` make the command the warning names: "auger COMMAND LOG ARGS".
TerrainChoice choose_terrain(Dataset& data, const std::string& model_path, const std::string& option,
                             const std::string& command, const std::string& args = "");

// The JSON's terrain fields: `terrain`, `terrain_from`, `terrain_fits` ({terrain: ratio}).
void json_terrain(Json& j, const TerrainChoice& t);

// The text's terrain line: "terrain: sand (assumed: the log names none)", then the tables'
// terrains' fits where they were computed.
std::string terrain_text(const TerrainChoice& t);

// The next command when another terrain fits clearly better ("" if none): the same command with
// --terrain NAME.
std::string terrain_next(const Dataset& data, const TerrainChoice& t, const std::string& command,
                         const std::string& args = "");

}  // namespace auger::wb
