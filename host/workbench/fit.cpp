// Placeholder: `auger fit` is being written (issue 5).
#include <cstdio>

#include "commands.hpp"

int auger::wb::run_fit(int, char**) {
  std::fprintf(stderr, "auger fit: not implemented yet\n");
  return 2;
}
