// Placeholder: `auger compare` is being written (issue 5).
#include <cstdio>

#include "commands.hpp"

int auger::wb::run_compare(int, char**) {
  std::fprintf(stderr, "auger compare: not implemented yet\n");
  return 2;
}
