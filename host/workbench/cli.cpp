// Placeholder until the workbench lands (issue 5): no subcommands yet.
#include "subcommand.hpp"

std::vector<auger::cli::Subcommand> auger::cli::workbench_subcommands() { return {}; }
