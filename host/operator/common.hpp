// Small pieces the field tools share (host/operator): numbers of positional arguments with errors
// that name them (options go through auger/args.hpp), status bits as names, the clock.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

#include "auger/args.hpp"
#include "augerd_client.hpp"
#include "status_text.hpp"

namespace auger::op {

// Bad usage: the subcommand prints it and exits 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A finite number, the whole argument; else UsageError naming the option and the text.
double parse_number(const std::string& option, const std::string& text);

// Names of the status word's bits (docs/protocol.md): "EN SP" or faults "F_OVERCURRENT+F_SENSOR".
using io::fault_bits_text;  // "none" if no fault bit
using io::state_bits_text;

// The --socket option of the tools that talk to augerd, one entry for their tables.
inline OptionDoc socket_option() {
  return {"--socket", "PATH", std::string("augerd's commands socket (default ") + io::kDefaultCommandsSocket + ")"};
}

// Seconds on CLOCK_MONOTONIC.
double now_s();
void sleep_s(double s);

}  // namespace auger::op
