// Placeholder: `auger effects` is being written (issue 5).
#include <cstdio>

#include "commands.hpp"

int auger::wb::run_effects(int, char**) {
  std::fprintf(stderr, "auger effects: not implemented yet\n");
  return 2;
}
