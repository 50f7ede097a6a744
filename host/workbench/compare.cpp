// `auger compare LOG [--model FILE] [--json]`: the model against a log (docs/workbench.md).
#include <cstdio>
#include <string>

#include "auger/args.hpp"
#include "checks.hpp"
#include "cli_text.hpp"
#include "commands.hpp"
#include "workbench.hpp"

namespace auger::wb {
namespace {

// The variants as rows' columns: RMS with units, then the same as multiples of the noise floor.
struct Variant {
  const char* name;
  const ErrorStats* e;
};

void print_table(const Dataset& d, const std::vector<Variant>& vs, bool ratios) {
  char cell[64];
  auto row = [&](const char* first, auto text_of) {
    std::string line = "  ";
    std::snprintf(cell, sizeof cell, "%-9s", first);
    line += cell;
    for (const auto& v : vs) {
      std::snprintf(cell, sizeof cell, "  %-20s", text_of(v).c_str());
      line += cell;
    }
    while (!line.empty() && line.back() == ' ') line.pop_back();
    std::printf("%s\n", line.c_str());
  };
  row("channel", [](const Variant& v) { return std::string(v.name); });
  for (int c = 0; c < kChannels; ++c) {
    const auto cc = static_cast<std::size_t>(c);
    if (!d.active[cc]) continue;
    row(channel_name(c), [&](const Variant& v) {
      return ratios ? ratio_cell(v.e->ratio_to_noise[cc]) : with_unit(v.e->rms[cc], channel_unit(c));
    });
  }
}

void json_stats(Json& j, const char* key, const ErrorStats& e, const Dataset& d) {
  j.begin_object(key);
  j.channels("rms", e.rms, d.active);
  j.channels("ratio_to_noise", e.ratio_to_noise, d.active);
  j.end_object();
}

// Worse than logs without a missing effect (docs/workbench.md "Calibration of significant").
bool beyond_noise(const ErrorStats& e) {
  for (double r : e.ratio_to_noise)
    if (r > 1.3) return true;
  return false;
}

const CommandLine kCli{
    "auger compare",
    "LOG [--model FILE] [--json]",
    "The model run from the log's screw speeds: open loop (Table 4), re-initialised every 25 s\n"
    "(the headline), IMU heading (Fig. 9), one step ahead; errors per DOF and as multiples of the\n"
    "noise floor estimated from the log; worst 5 s windows; error by regime; the next command to run.\n",
    {kModelOption,
     {"--json", "", "one JSON object on stdout"}},
    ""};

}  // namespace

int run_compare(int argc, char** argv) {
  Args a;
  if (const int rc = kCli.parse_or_answer(argc, argv, a); rc >= 0) return rc;
  if (a.positional.size() != 1) return kCli.print_usage(stderr), 2;
  try {
    const Dataset d = load_dataset(a.positional[0]);
    const CompareResult r = compare(d, choose_model(d, a.get("--model")));
    require_noise_floor(d, r.noise_floor);
    require_finite(d, r.open_loop_err, r.model, "the open-loop run");
    require_finite(d, r.segments_err, r.model, "segments of 25 s");
    std::vector<std::string> warnings;
    if (const std::string w = terrain_warning(d, r.model); !w.empty()) warnings.push_back(w);
    const std::string model_arg = a.has("--model") ? " --model " + typed(a.get("--model")) : "";
    const std::string next =
        beyond_noise(r.segments_err)
            ? "auger diagnose " + typed(d.path) + model_arg + " (which effect is missing), or auger explain " +
                  typed(d.path) + model_arg + " (effects added until only noise is left)"
            : "auger report " + typed(d.path) + model_arg +
                  " --out report (the plots; the model is within 1.3 times the noise floor in every channel)";
    if (a.has("--json")) {
      Json j;
      j.begin_object();
      j.str("log", d.path).str("kind", d.gantry ? "gantry" : "robot").str("model", r.model.source);
      j.str("terrain", r.model.terrain);
      j.num("duration_s", d.duration_s()).num("samples", static_cast<double>(d.size()));
      j.channels("noise_floor", r.noise_floor, d.active);
      j.channels("segment_floor", r.segment_floor, d.active);
      const NoiseColour& nc = r.noise_colour;
      j.begin_object("noise_colour").num("factor", nc.factor).num("pairs", static_cast<double>(nc.samples));
      j.num("anchor_share", nc.anchor_share).num("anchor_windows", static_cast<double>(nc.anchor_windows));
      j.boolean("applied", nc.applied).num("frame_s", nc.whiten.frame_s).begin_array("ar");
      for (double a : nc.whiten.ar) j.num(nullptr, a);
      j.end_array().end_object();
      json_stats(j, "open_loop", r.open_loop_err, d);
      json_stats(j, "segments", r.segments_err, d);
      if (d.active[kImuPsi]) json_stats(j, "imu_heading", r.imu_heading_err, d);
      json_stats(j, "one_step", r.one_step_err, d);
      json_windows(j, "worst", r.worst);
      json_windows(j, "windows", r.windows);
      j.begin_array("regimes");
      for (const auto& g : r.regimes) {
        j.begin_object().str("kind", g.kind).str("label", g.label).num("seconds", g.seconds);
        j.channels("rms", g.rms, d.active).channels("ratio_to_noise", g.ratio_to_noise, d.active);
        j.end_object();
      }
      j.end_array();
      j.begin_array("warnings");
      for (const auto& w : warnings) j.str(nullptr, w);
      j.end_array();
      j.str("next", next);
      j.end_object();
      std::printf("%s\n", j.text().c_str());
      print_warnings("compare", warnings);
      return 0;
    }
    print_warnings("compare", warnings);
    std::printf("log %s: %s, %.1f s, %zu samples\nmodel: %s\n", d.path.c_str(), d.gantry ? "gantry" : "robot",
                d.duration_s(), d.size(), r.model.source.c_str());
    std::printf("noise floor (estimated from the data):");
    for (int c = 0; c < kChannels; ++c)
      if (d.active[static_cast<std::size_t>(c)])
        std::printf("  %s %s", channel_name(c), with_unit(r.noise_floor[static_cast<std::size_t>(c)], channel_unit(c), 3).c_str());
    if (r.noise_colour.applied) {
      std::printf("\n  the camera's noise is coloured: x, y, psi are %.2f times their sample-to-sample spread (from %zu "
                  "camera / IMU heading pairs while not turning); its filter for the residual tests: AR(%zu) per %.3g s frame,",
                  r.noise_colour.factor, r.noise_colour.samples, r.noise_colour.whiten.ar.size(), r.noise_colour.whiten.frame_s);
      for (double a : r.noise_colour.whiten.ar) std::printf(" %.3f", a);
      std::printf("\n  each segment's start is anchored on 2 s of poses, whose mean keeps %.0f %% of that noise's "
                  "variance (%zu windows):\n  a perfect model leaves x %s, y %s; the multiples below are of these",
                  100 * r.noise_colour.anchor_share, r.noise_colour.anchor_windows,
                  with_unit(r.segment_floor[kX], "m", 3).c_str(), with_unit(r.segment_floor[kY], "m", 3).c_str());
    }
    std::vector<Variant> vs = {{"open loop (Table 4)", &r.open_loop_err}, {"segments of 25 s", &r.segments_err}};
    if (d.active[kImuPsi]) vs.push_back({"IMU heading (Fig. 9)", &r.imu_heading_err});
    vs.push_back({"one step ahead", &r.one_step_err});
    std::printf("\n\nRMS error of the model (segments of 25 s is the headline figure):\n");
    print_table(d, vs, false);
    std::printf("\nthe same as multiples of the noise floor (1.00 = only noise left):\n");
    print_table(d, vs, true);
    std::printf("\nworst 5 s windows (each simulated from its own measured start pose):\n");
    for (const auto& w : r.worst)
      std::printf("  t %7.1f - %7.1f s  %-7s  RMS %s = %s\n", w.t_start_s, w.t_end_s, channel_name(w.dof),
                  with_unit(w.rms, channel_unit(w.dof), 3).c_str(), times_noise(w.ratio_to_noise).c_str());
    std::printf("\nerror by regime, as multiples of the noise floor (segments of 25 s):\n  %-9s %-22s %9s",
                "kind", "regime", "duration");
    for (int c = 0; c < kChannels; ++c)
      if (d.active[static_cast<std::size_t>(c)]) std::printf("  %8s", channel_name(c));
    std::printf("\n");
    for (const auto& g : r.regimes) {
      std::printf("  %-9s %-22s %7.1f s", g.kind.c_str(), g.label.c_str(), g.seconds);
      for (int c = 0; c < kChannels; ++c)
        if (d.active[static_cast<std::size_t>(c)])
          std::printf("  %8s", ratio_cell(g.ratio_to_noise[static_cast<std::size_t>(c)]).c_str());
      std::printf("\n");
    }
    std::printf("\nnext: %s\n", next.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger compare: %s\n", e.what());
    return 2;
  }
}

}  // namespace auger::wb
