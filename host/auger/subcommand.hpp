// The `auger` command-line tool is one binary with subcommands (docs/design.md: workbench, control
// client, operator tools). Each group lives in its own directory and hands its subcommands to
// main.cpp through one of the functions below, so groups are added without touching each other.
#pragma once

#include <vector>

namespace auger::cli {

struct Subcommand {
  const char* name;     // `auger NAME ...`
  const char* usage;    // arguments, e.g. "LOG [--model FILE] [--json]"
  const char* summary;  // one line for `auger --help`
  // argv[0] is the subcommand's name. Exit codes: 0 done, 1 the command ran and reports a
  // failure (a test failed, augerd answered an error), 2 bad usage or bad input, 3 augerd or a
  // device could not be reached.
  int (*run)(int argc, char** argv);
};

std::vector<Subcommand> client_subcommands();     // host/auger/client.cpp: augerd's sockets
std::vector<Subcommand> workbench_subcommands();  // host/workbench/: the model workbench
std::vector<Subcommand> operator_subcommands();   // host/operator/: field tools
std::vector<Subcommand> interop_subcommands();    // host/interop/: import, export

}  // namespace auger::cli
