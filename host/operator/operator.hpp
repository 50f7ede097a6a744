// The field tools' entry points (host/operator, docs/operator.md); cli.cpp lists them for
// `auger`. Each takes argv[0] = its name and returns the exit code of subcommand.hpp.
#pragma once

namespace auger::op {

int run_monitor(int argc, char** argv);
int run_teleop(int argc, char** argv);
int run_step(int argc, char** argv);
int run_calib(int argc, char** argv);
int run_replay(int argc, char** argv);

}  // namespace auger::op
