// The field tools as subcommands of `auger` (docs/operator.md).
#include "operator.hpp"
#include "subcommand.hpp"

std::vector<auger::cli::Subcommand> auger::cli::operator_subcommands() {
  return {
      {"monitor", "[--socket PATH] [--period S]", "live view of the modules, pose and loop (ncurses; q quits)",
       auger::op::run_monitor},
      {"teleop", "[--socket PATH] [--joystick DEV]", "drive by keyboard or joystick through augerd (dead-man)",
       auger::op::run_teleop},
      {"step", "MODULE RPM [--duration S] [--port DEV | --socket PATH] [--out CSV] [--plot SVG]",
       "velocity step of one module, summarised against the firmware's criteria", auger::op::run_step},
      {"calib", "--ports P0,P1,P2,P3 [--sensors PATH] | --check-motion [--socket PATH]",
       "check/fix direction signs and counts per revolution; commissioning check", auger::op::run_calib},
      {"replay", "LOG... [--config FILE] [--model FILE]",
       "rerun the estimator and controller on an augerd log, report differences", auger::op::run_replay},
  };
}
