// `auger compare LOG [--model FILE] [--json]`: the model against a log (docs/workbench.md).
#include <cstdio>
#include <string>

#include "args.hpp"
#include "checks.hpp"
#include "commands.hpp"
#include "workbench.hpp"

namespace auger::wb {
namespace {

void print_stats(const char* what, const ErrorStats& e, const Dataset& d) {
  std::printf("  %-22s", what);
  for (int c = 0; c < kChannels; ++c) {
    if (!d.active[static_cast<std::size_t>(c)]) continue;
    const double rms = e.rms[static_cast<std::size_t>(c)];
    // A variant may not apply to a channel (the IMU-heading run has no separate IMU error).
    if (!(rms == rms)) {
      std::printf("  %s -", channel_name(c));
      continue;
    }
    std::printf("  %s %.4g %s (%.2fx)", channel_name(c), rms, channel_unit(c),
                e.ratio_to_noise[static_cast<std::size_t>(c)]);
  }
  std::printf("\n");
}

void json_stats(Json& j, const char* key, const ErrorStats& e, const Dataset& d) {
  j.begin_object(key);
  j.channels("rms", e.rms, d.active);
  j.channels("ratio_to_noise", e.ratio_to_noise, d.active);
  j.end_object();
}

}  // namespace

int run_compare(int argc, char** argv) {
  Args a;
  if (!parse_args(argc, argv, {"--json", "--help"}, {"--model"}, a)) return 2;
  if (a.has("--help") || a.positional.size() != 1) {
    std::fprintf(a.has("--help") ? stdout : stderr,
                 "usage: auger compare LOG [--model FILE] [--json]\n"
                 "  the model run from the log's screw speeds: open loop (Table 4), re-initialised every\n"
                 "  25 s (the headline), IMU heading (Fig. 9), one step ahead; errors per DOF and as\n"
                 "  multiples of the noise floor estimated from the log; worst 5 s windows; error by regime.\n");
    return a.has("--help") ? 0 : 2;
  }
  try {
    const Dataset d = load_dataset(a.positional[0]);
    const CompareResult r = compare(d, choose_model(d, a.get("--model")));
    require_noise_floor(d, r.noise_floor);
    require_finite(d, r.open_loop_err, r.model, "the open-loop run");
    require_finite(d, r.segments_err, r.model, "segments of 25 s");
    if (a.has("--json")) {
      Json j;
      j.begin_object();
      j.str("log", d.path).str("kind", d.gantry ? "gantry" : "robot").str("model", r.model.source);
      j.num("duration_s", d.duration_s()).num("samples", static_cast<double>(d.size()));
      j.channels("noise_floor", r.noise_floor, d.active);
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
      j.end_object();
      std::printf("%s\n", j.text().c_str());
      return 0;
    }
    std::printf("log %s: %s, %.1f s, %zu samples\nmodel: %s\n", d.path.c_str(), d.gantry ? "gantry" : "robot",
                d.duration_s(), d.size(), r.model.source.c_str());
    std::printf("noise floor (from the data):");
    for (int c = 0; c < kChannels; ++c)
      if (d.active[static_cast<std::size_t>(c)])
        std::printf("  %s %.3g %s", channel_name(c), r.noise_floor[static_cast<std::size_t>(c)], channel_unit(c));
    std::printf("\nRMS error (x noise floor):\n");
    print_stats("open loop", r.open_loop_err, d);
    print_stats("segments of 25 s", r.segments_err, d);
    if (d.active[kImuPsi]) print_stats("IMU heading (Fig. 9)", r.imu_heading_err, d);
    print_stats("one step ahead", r.one_step_err, d);
    std::printf("worst 5 s windows:\n");
    for (const auto& w : r.worst)
      std::printf("  t %7.1f - %7.1f s  %-7s  %.3g %s  %.1fx noise\n", w.t_start_s, w.t_end_s, channel_name(w.dof),
                  w.rms, channel_unit(w.dof), w.ratio_to_noise);
    std::printf("error by regime (x noise floor, segments of 25 s):\n");
    for (const auto& g : r.regimes) {
      std::printf("  %-9s %-22s %7.1f s", g.kind.c_str(), g.label.c_str(), g.seconds);
      for (int c = 0; c < kChannels; ++c)
        if (d.active[static_cast<std::size_t>(c)])
          std::printf("  %s %.2fx", channel_name(c), g.ratio_to_noise[static_cast<std::size_t>(c)]);
      std::printf("\n");
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger compare: %s\n", e.what());
    return 2;
  }
}

}  // namespace auger::wb
