// `auger identify GANTRY_LOG... [--json]`: sigma and D from gantry logs, eqs. (15)-(17), per
// terrain and axis, with confidence intervals (identify_gantry.cpp does the work).
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>
#include <vector>

#include "auger/args.hpp"
#include "auger/log.hpp"
#include "cli_text.hpp"
#include "commands.hpp"
#include "identify.hpp"
#include "workbench.hpp"

namespace auger::wb {
namespace {

const CommandLine kCli{
    "auger identify",
    "GANTRY_LOG... [--confidence P] [--json]",
    "sigma (eqs. (15)-(16), least squares on force_n) and D (eq. (17), steady-state velocity) per\n"
    "terrain and axis (metadata `terrain`, `axis`), with confidence intervals.\n",
    {{"--confidence", "P", "the intervals' confidence (default 0.95; in (0, 1))"},
     {"--json", "", "one JSON object on stdout"}},
    ""};

int identify_usage(std::FILE* f, int code) {
  kCli.print_usage(f);
  return code;
}

const char* sigma_name(const std::string& axis) { return axis == "longitudinal" ? "sigma_long" : "sigma_lat"; }
const char* drag_name(const std::string& axis) { return axis == "longitudinal" ? "D_x" : "D_y"; }

void json_estimate(Json& j, const char* name, const Estimate& e, const char* unit) {
  j.begin_object(name);
  j.num("value", e.value).num("se", e.se).str("unit", unit);
  j.begin_array("ci").num(nullptr, e.lo).num(nullptr, e.hi).end_array();
  j.num("n_eff", e.n_eff).str("ci_method", e.ci_method);
  j.end_object();
}

}  // namespace

int run_identify(int argc, char** argv) {
  bool json = false;
  IdentifyOptions options;
  std::vector<std::string> files;
  Args args;
  if (const int rc = kCli.parse_or_answer(argc, argv, args); rc >= 0) return rc;
  json = args.has("--json");
  if (!args.number_in("auger identify", "--confidence", options.confidence, 0, 1, options.confidence)) return 2;
  files = args.positional;
  if (files.empty()) return identify_usage(stderr, 2);

  std::vector<GantryData> logs;
  std::vector<GantryIdentification> results;
  try {
    for (const auto& f : files) logs.push_back(read_gantry_data(f));
    results = identify_gantry(logs, options);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger identify: %s\n", e.what());
    return 2;
  }

  // A warning about the steady velocities scattering points at an effect D absorbed.
  bool scatter = false;
  for (const auto& r : results) scatter = scatter || !r.warnings.empty();
  const std::string next =
      scatter ? "auger diagnose " + typed(files.front()) + " (the warnings above: which effect the rail run shows)"
              : "put the values into a model file's [terrain.NAME] (docs/model.md), then auger compare LOG --model FILE";
  if (json) {
    Json j;
    j.begin_object().str("command", "identify").num("confidence", options.confidence);
    j.begin_array("groups");
    for (const auto& r : results) {
      j.begin_object().str("terrain", r.terrain).str("axis", r.axis).num("mass_kg", r.mass_kg);
      j.begin_array("files");
      for (const auto& f : r.files) j.str(nullptr, f);
      j.end_array();
      j.num("n_samples", static_cast<double>(r.n_samples));
      json_estimate(j, sigma_name(r.axis), r.sigma, "N/rpm");
      json_estimate(j, drag_name(r.axis), r.D, "N/(m/s)");
      j.num("force_residual_rms_n", r.force_residual_rms_n);
      j.begin_array("pieces");
      for (const auto& p : r.pieces) {
        j.begin_object().str("file", p.file).num("t_start_s", p.t_start_s).num("t_end_s", p.t_end_s);
        j.num("drive_rpm", p.drive_rpm).num("tau_n", p.tau_n).num("velocity_mps", p.velocity_mps);
        j.end_object();
      }
      j.end_array();
      j.begin_array("warnings");
      for (const auto& w : r.warnings) j.str(nullptr, w);
      j.end_array().end_object();
    }
    j.end_array().str("next", next).end_object();
    std::printf("%s\n", j.text().c_str());
  } else {
    const int pct = static_cast<int>(options.confidence * 100 + 0.5);
    std::printf("auger identify: %zu log(s), %zu group(s); eqs. (15)-(16) for sigma, (17) for D\n\n",
                logs.size(), results.size());
    std::printf("%-12s %-12s %-10s %12s %27s  %-8s %s\n", "terrain", "axis", "parameter", "estimate",
                (std::to_string(pct) + " % interval").c_str(), "unit", "basis");
    for (const auto& r : results) {
      std::printf("%-12s %-12s %-10s %12.5g   [%11.5g, %11.5g]  %-8s %zu samples, n_eff %.0f\n",
                  r.terrain.c_str(), r.axis.c_str(), sigma_name(r.axis), r.sigma.value, r.sigma.lo,
                  r.sigma.hi, "N/rpm", r.n_samples, r.sigma.n_eff);
      std::printf("%-12s %-12s %-10s %12.5g   [%11.5g, %11.5g]  %-8s %zu steady pieces\n", "", "",
                  drag_name(r.axis), r.D.value, r.D.lo, r.D.hi, "N/(m/s)", r.pieces.size());
    }
    std::printf("\nIntervals: sigma: %s.\n", results.front().sigma.ci_method.c_str());
    for (const auto& r : results)
      std::printf("D (%s, %s): %s.\n", r.terrain.c_str(), r.axis.c_str(), r.D.ci_method.c_str());
    for (const auto& r : results)
      for (const auto& w : r.warnings) std::fprintf(stderr, "auger identify: warning: %s\n", w.c_str());
    std::printf("\nnext: %s\n", next.c_str());
  }
  return 0;
}

}  // namespace auger::wb
