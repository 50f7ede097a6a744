// `auger import`: the bag and CSV reader is Python (python/auger_interop, on the `rosbags` library:
// docs/design.md), so that ROS 2 bags need no ROS; this front runs it in the project's venv with the
// user's arguments as an argument vector (execv: no shell ever sees them), so the user has one
// tool. The Python side parses the options and prints its own usage and errors.
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "interop.hpp"

namespace auger::interop {

int run_import(int argc, char** argv) {
  // AUGER_PYTHON: a Python with python/requirements.txt and python/ on its path (e.g. another
  // venv); otherwise the venv that `make venv` made in this build folder.
  const char* env = std::getenv("AUGER_PYTHON");
  const std::string python = env && *env ? env : AUGER_VENV_PYTHON;
  if (access(python.c_str(), X_OK) != 0) {
    std::fprintf(stderr,
                 "auger import: needs the project's Python environment, but %s %s (%s).\n"
                 "Run `make venv` in the source tree (or set AUGER_PYTHON to a Python that has "
                 "python/requirements.txt and python/ on its path).\n",
                 env && *env ? "AUGER_PYTHON" : "the venv's Python", python.c_str(), std::strerror(errno));
    return 2;
  }
  std::vector<char*> args;
  std::string p = python, m = "-m", mod = "auger_interop", sub = "import";
  for (std::string* s : {&p, &m, &mod, &sub}) args.push_back(s->data());
  for (int i = 1; i < argc; ++i) args.push_back(argv[i]);
  args.push_back(nullptr);
  std::fflush(nullptr);
  execv(python.c_str(), args.data());
  std::fprintf(stderr, "auger import: cannot run %s: %s\n", python.c_str(), std::strerror(errno));
  return 2;
}

}  // namespace auger::interop
