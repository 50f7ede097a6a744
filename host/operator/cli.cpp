// Placeholder until the field tools land (issue 6): no subcommands yet.
#include "subcommand.hpp"

std::vector<auger::cli::Subcommand> auger::cli::operator_subcommands() { return {}; }
