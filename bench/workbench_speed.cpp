// Workbench speed (docs/benchmarks.md, "Model workbench"): `compare` against just parsing the
// log, and `diagnose`, on logs given on the command line (made with auger-sim-log, see
// docs/benchmarks.md for the commands). Prints a markdown table row per log.
#include <chrono>
#include <cstdio>
#include <string>

#include "auger/args.hpp"
#include "workbench.hpp"

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) {
  using namespace auger::wb;
  const auger::CommandLine cli{
      "workbench_speed", "[--diagnose] LOG...",
      "`compare` against just parsing each log, and with --diagnose `diagnose` too; a markdown\n"
      "table row per log (docs/benchmarks.md).\n",
      {{"--diagnose", "", "time diagnose on each log too"}},
      ""};
  auger::Args args;
  if (const int rc = cli.parse_or_answer(argc, argv, args); rc >= 0) return rc;
  if (args.positional.empty()) {
    cli.print_usage(stderr);
    return 2;
  }
  const bool diag = args.has("--diagnose");
  std::printf("| log | rows | parse (load_dataset) | compare incl. parse | ratio | diagnose incl. parse |\n|---|---|---|---|---|---|\n");
  for (const std::string& path : args.positional) {
    // Best of three for the parse and compare times (the machine is shared).
    double parse_s = 1e9, compare_s = 1e9;
    std::size_t rows = 0;
    for (int rep = 0; rep < 3; ++rep) {
      auto t0 = std::chrono::steady_clock::now();
      const Dataset d = load_dataset(path);
      parse_s = std::min(parse_s, seconds_since(t0));
      rows = d.size();
      t0 = std::chrono::steady_clock::now();
      const Dataset d2 = load_dataset(path);
      const CompareResult r = compare(d2, choose_model(d2));
      compare_s = std::min(compare_s, seconds_since(t0));
      if (r.segments_err.n[kX] == 0) return 1;
    }
    std::string diag_text = "-";
    if (diag) {
      const auto t0 = std::chrono::steady_clock::now();
      const Dataset d = load_dataset(path);
      const DiagnoseResult r = diagnose(d, choose_model(d));
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.2f s (%zu candidates)", seconds_since(t0), r.candidates.size());
      diag_text = buf;
    }
    std::printf("| %s | %zu | %.3f s | %.3f s | %.2fx | %s |\n", path.c_str(), rows, parse_s, compare_s,
                compare_s / parse_s, diag_text.c_str());
  }
  return 0;
}
