// Placeholder: `auger report` is being written (issue 5).
#include <cstdio>

#include "commands.hpp"

int auger::wb::run_report(int, char**) {
  std::fprintf(stderr, "auger report: not implemented yet\n");
  return 2;
}
