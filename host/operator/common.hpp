// Small pieces the field tools share (host/operator): argument parsing with errors that name
// the argument, status bits as names, and the socket defaults.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

#include "status_text.hpp"

namespace auger::op {

// Bad usage: the subcommand prints it and exits 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A finite number, the whole argument; else UsageError naming the option and the text.
double parse_number(const std::string& option, const std::string& text);
// The value after argv[i] (advances i); UsageError if there is none.
std::string option_value(int argc, char** argv, int& i);

// Names of the status word's bits (docs/protocol.md): "EN SP" or faults "F_OVERCURRENT+F_SENSOR".
using io::fault_bits_text;  // "none" if no fault bit
using io::state_bits_text;

// Seconds on CLOCK_MONOTONIC.
double now_s();
void sleep_s(double s);

}  // namespace auger::op
