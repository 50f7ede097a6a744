// The `auger` command-line tool is one binary with subcommands: the workbench, the field tools,
// import/export (each a library in its own directory, exporting its entry points) and augerd's
// client (client.cpp). main.cpp registers them all; only this front includes this header.
#pragma once

#include <vector>

namespace auger::cli {

struct Subcommand {
  const char* name;     // `auger NAME ...`
  const char* summary;  // one line for `auger --help`; the usage is the subcommand's own --help
  // argv[0] is the subcommand's name. Exit codes: 0 done, 1 the command ran and reports a
  // failure (a test failed, augerd answered an error), 2 bad usage or bad input, 3 augerd or a
  // device could not be reached.
  int (*run)(int argc, char** argv);
};

std::vector<Subcommand> client_subcommands();     // host/auger/client.cpp: augerd's sockets

}  // namespace auger::cli
