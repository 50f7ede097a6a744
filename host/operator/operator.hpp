// The field tools' entry points (host/operator, docs/operator.md); the `auger` front
// (host/auger/main.cpp) lists them. Each takes argv[0] = its name and returns the exit code
// (0 done, 1 a finding, 2 bad usage or input, 3 augerd or a device not reached).
#pragma once

namespace auger::op {

int run_monitor(int argc, char** argv);
int run_teleop(int argc, char** argv);
int run_step(int argc, char** argv);
int run_calib(int argc, char** argv);
int run_replay(int argc, char** argv);

}  // namespace auger::op
