// The model workbench's subcommands (docs/workbench.md).
#include "commands.hpp"
#include "subcommand.hpp"

std::vector<auger::cli::Subcommand> auger::cli::workbench_subcommands() {
  using namespace auger::wb;
  return {
      {"compare", "LOG [--model FILE] [--json]", "the model against a log: open loop, segments, IMU heading, one step ahead, noise floor, where it fails", run_compare},
      {"diagnose", "LOG [--model FILE] [--only ID,...] [--threads N] [--json]", "which physical effect is missing: fit every library effect, rank them", run_diagnose},
      {"explain", "LOG... [--model FILE] [--out MODEL] [--max-effects N] [--json]", "the whole loop: add effects jointly until what remains is noise, or say what is left", run_explain},
      {"fit", "LOG --add EFFECT[,EFFECT...] [--out MODEL] [--model FILE] [--json]", "re-identify with effects added, error before and after, write a model file", run_fit},
      {"effects", "[--json]", "the effect library: identifiers, parameters, what each means", run_effects},
      {"identify", "GANTRY_LOG... [--confidence P] [--json]", "sigma and D from gantry logs, eqs. (15)-(17), with confidence intervals", run_identify},
      {"merge", "ROBOT_LOG CAMERA_LOG [--out LOG] [--max-shift S] [--json]", "align a pose log from another computer by t0_unix_s and IMU/camera yaw rate", run_merge},
      {"report", "LOG --out DIR [--model FILE] [--effect ID] [--no-diagnose] [--json]", "a self-contained HTML report with plots", run_report},
  };
}
