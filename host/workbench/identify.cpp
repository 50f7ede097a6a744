// Placeholder: `auger identify` is being written (issue 5).
#include <cstdio>

#include "commands.hpp"

int auger::wb::run_identify(int, char**) {
  std::fprintf(stderr, "auger identify: not implemented yet\n");
  return 2;
}
