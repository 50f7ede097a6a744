// Placeholder: `auger merge` is being written (issue 5).
#include <cstdio>

#include "commands.hpp"

int auger::wb::run_merge(int, char**) {
  std::fprintf(stderr, "auger merge: not implemented yet\n");
  return 2;
}
