// `auger import` and `auger export` (docs/formats.md).
#include "interop.hpp"
#include "subcommand.hpp"

std::vector<auger::cli::Subcommand> auger::cli::interop_subcommands() {
  return {
      {"import", "SOURCE --out LOG [--map FILE] [--terrain NAME] [--list-topics]",
       "a ROS 2 bag (sqlite3 or MCAP) or another program's CSV into a robot log", auger::interop::run_import},
      {"export", "LOG --mcap OUT.mcap [--model FILE]",
       "a robot log as MCAP (Foxglove, PlotJuggler), with the model's prediction on request", auger::interop::run_export},
  };
}
