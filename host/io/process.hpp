// Running another program without a shell: an argument vector (posix_spawnp), so no user
// string is ever interpreted by a shell. Used by the gnuplot driver and `auger ros2-keys`.
#pragma once

#include <string>
#include <vector>

namespace auger::io {

// Runs exe (searched in PATH) with args, stdin from /dev/null, stdout and stderr to the given
// files (created 0600, truncated; the same path for both appends them together). The exit
// status as waitpid gives it, or -1 if it could not be started.
int run_program(const std::string& exe, const std::vector<std::string>& args, const std::string& out_path,
                const std::string& err_path);
// Whether that status is a normal exit with code 0.
bool program_succeeded(int status);

}  // namespace auger::io
