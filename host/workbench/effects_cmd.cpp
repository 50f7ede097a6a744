// `auger effects [--json]`: the effect library (docs/workbench.md has the same table).
#include <cmath>
#include <cstdio>
#include <string>

#include "auger/args.hpp"
#include "auger/input_limits.hpp"
#include "commands.hpp"
#include "workbench.hpp"

namespace auger::wb {

namespace {

const CommandLine kCli{"auger effects", "[--json]", "The effect library: identifiers, parameters, units.\n",
                       {{"--json", "", "one JSON object on stdout"}}, ""};

}  // namespace

int run_effects(int argc, char** argv) {
  Args a;
  if (const int rc = kCli.parse_or_answer(argc, argv, a); rc >= 0) return rc;
  if (!a.positional.empty()) {
    std::fprintf(stderr, "auger effects: takes no file or argument, got %s\n", quote_input(a.positional[0]).c_str());
    return kCli.print_usage(stderr), 2;
  }
  const auto lib = effect_library();
  if (a.has("--json")) {
    Json j;
    j.begin_object().begin_array("effects");
    for (const auto& e : lib) {
      j.begin_object().str("id", e.id).str("summary", e.summary).boolean("needs_imu", e.needs_imu);
      j.begin_array("params");
      for (const auto& p : e.params) {
        j.begin_object().str("name", p.name).str("unit", p.unit).str("doc", p.doc);
        j.num("default", p.default_value).boolean("required", p.required).num("lower", p.lower).num("upper", p.upper);
        j.boolean("integer", p.integer).num("physical_lower", p.physical_lower).num("physical_upper", p.physical_upper);
        j.end_object();
      }
      j.end_array().end_object();
    }
    j.end_array().end_object();
    std::printf("%s\n", j.text().c_str());
    return 0;
  }
  std::printf("The effect library: each effect's parameters with their unit and physical range (a fit outside\n"
              "it, at its end, or with an uncertainty larger than the value is flagged by diagnose, fit, explain).\n\n");
  for (const auto& e : lib) {
    std::printf("%s%s\n    %s\n", e.id.c_str(), e.needs_imu ? "  (needs an IMU heading)" : "", e.summary.c_str());
    for (const auto& p : e.params) {
      const std::string unit = p.unit.empty() || p.unit == "-" ? "" : " " + p.unit;
      char range[96] = "";
      if (std::isfinite(p.physical_lower) || std::isfinite(p.physical_upper))
        std::snprintf(range, sizeof range, "%g to %g%s", p.physical_lower, p.physical_upper, unit.c_str());
      else if (p.integer)
        std::snprintf(range, sizeof range, "%g to %g (whole numbers)", p.lower, p.upper);
      std::printf("    %-18s %-14s %-26s %s\n", p.name.c_str(), p.unit.empty() ? "-" : p.unit.c_str(), range, p.doc.c_str());
    }
  }
  std::printf("\nnext: auger diagnose LOG (fits every one of them to a log and ranks them)\n");
  return 0;
}

}  // namespace auger::wb
