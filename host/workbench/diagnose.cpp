// Placeholder: `auger diagnose` is being written (issue 5).
#include <cstdio>

#include "commands.hpp"

int auger::wb::run_diagnose(int, char**) {
  std::fprintf(stderr, "auger diagnose: not implemented yet\n");
  return 2;
}
