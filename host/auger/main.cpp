// auger: the project's command-line tool. `auger --help` lists the subcommands;
// `auger SUBCOMMAND --help` explains one.
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "auger/version.hpp"
#include "commands.hpp"  // host/workbench
#include "interop.hpp"   // host/interop
#include "operator.hpp"  // host/operator
#include "ros2_keys.hpp"  // host/ros2_keys
#include "subcommand.hpp"

namespace {

// Every subcommand, registered here and only here: the groups below the front export their
// entry points and know nothing of this table.
std::vector<auger::cli::Subcommand> all_subcommands() {
  std::vector<auger::cli::Subcommand> all = {
      // The model workbench (docs/workbench.md).
      {"compare", "the model against a log: open loop, segments, IMU heading, one step ahead, noise floor, where it fails",
       auger::wb::run_compare},
      {"diagnose", "which physical effect is missing: fit every library effect, rank them", auger::wb::run_diagnose},
      {"explain", "the whole loop: add effects jointly until what remains is noise, or say what is left",
       auger::wb::run_explain},
      {"fit", "re-identify with effects added, error before and after, write a model file", auger::wb::run_fit},
      {"effects", "the effect library: identifiers, parameters, what each means", auger::wb::run_effects},
      {"identify", "sigma and D from gantry logs, eqs. (15)-(17), with confidence intervals",
       auger::wb::run_identify},
      {"merge", "align a pose log from another computer by t0_unix_s and IMU/camera yaw rate", auger::wb::run_merge},
      {"report", "a self-contained HTML report with plots", auger::wb::run_report},
      // The field tools (docs/operator.md).
      {"monitor", "live view of the modules, pose and loop (ncurses; q quits)", auger::op::run_monitor},
      {"teleop", "drive by keyboard or joystick through augerd (dead-man)", auger::op::run_teleop},
      {"step", "velocity step of one module, summarised against the firmware's criteria", auger::op::run_step},
      {"calib", "check/fix direction signs and counts per revolution; commissioning check", auger::op::run_calib},
      {"replay", "rerun the estimator and controller on an augerd log, report differences", auger::op::run_replay},
      // Data in and out of other tools (docs/formats.md).
      {"import", "a ROS 2 bag (sqlite3 or MCAP) or another program's CSV into a robot log",
       auger::interop::run_import},
      {"export", "a robot log as MCAP (Foxglove, PlotJuggler), with the model's prediction on request",
       auger::interop::run_export},
      // augerd's ROS 2 interface (docs/ros2.md).
      {"ros2-keys", "the DDS Security keystore: who may command the robot over ROS 2 (openssl)",
       auger::ros2_keys::run},
  };
  for (const auto& s : auger::cli::client_subcommands()) all.push_back(s);
  return all;
}

// The subcommands' options and usage are each subcommand's own (`auger NAME --help`), written
// once; this list names them.
int usage(std::FILE* f, int code) {
  std::fprintf(f, "usage: auger SUBCOMMAND [ARGS...]   (auger SUBCOMMAND --help: its usage; --version)\n\n");
  for (const auto& s : all_subcommands()) std::fprintf(f, "  auger %-9s %s\n", s.name, s.summary);
  return code;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage(stderr, 2);
  const std::string name = argv[1];
  if (name == "--help" || name == "-h" || name == "help") return usage(stdout, 0);
  if (name == "--version") return auger::print_version("auger"), 0;
  for (const auto& s : all_subcommands()) {
    if (name != s.name) continue;
    // --version for every subcommand here, in one place (each one's --help is its own).
    for (int i = 2; i < argc; ++i)
      if (std::strcmp(argv[i], "--version") == 0) return auger::print_version(("auger " + name).c_str()), 0;
    return s.run(argc - 1, argv + 1);
  }
  std::fprintf(stderr, "auger: unknown subcommand '%s'\n", name.c_str());
  return usage(stderr, 2);
}
