// `auger explain LOG... [--model FILE] [--out MODEL] [--max-effects N] [--beam N] [--json]`: the
// workbench's whole loop in one command (docs/workbench.md "explain").
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <string>

#include "auger/args.hpp"
#include "checks.hpp"
#include "cli_text.hpp"
#include "commands.hpp"
#include "explain_out.hpp"
#include "terrain.hpp"
#include "workbench.hpp"

namespace auger::wb {

namespace {

const CommandLine kCli{
    "auger explain",
    "LOG... [--model FILE] [--terrain NAME|auto] [--out MODEL] [--max-effects N] [--beam N]\n"
    "                     [--only ID,...] [--threads N] [--json] [--progress | --quiet]",
    "The loop compare -> diagnose -> fit --add -> diagnose ... in one command: at every step each\n"
    "library effect is fitted jointly with the effects chosen so far and the paper's parameters;\n"
    "an effect that no longer pays for itself is dropped; near ties are carried along; it stops\n"
    "when what remains is noise (the error at the noise floor on the held-out segments and over\n"
    "the whole log, residuals white and independent of the inputs) or no candidate is\n"
    "significant, and says what is left.\n"
    "Several logs of one robot are explained together (effects shared, the paper's parameters\n"
    "per terrain).\n",
    {kModelOption,
     kTerrainOption,
     {"--out", "MODEL", "write the final model file there"},
     {"--max-effects", "N", "at most N effects added (default 4; 1 .. 10)"},
     {"--beam", "N", "near ties carried along (default 2; 1 .. 6)"},
     {"--only", "ID,...", "consider only these effects"},
     {"--threads", "N", "threads for the fits (default 2; 1 .. 64)"},
     {"--json", "", "one JSON object on stdout"},
     {"--progress", "", "also a line per candidate fitted on stderr (default: a line per step, none with --json)"},
     {"--quiet", "", "no progress lines"}},
    ""};

}  // namespace

int run_explain(int argc, char** argv) {
  Args a;
  if (const int rc = kCli.parse_or_answer(argc, argv, a); rc >= 0) return rc;
  if (a.positional.empty()) return kCli.print_usage(stderr), 2;
  ExplainOptions o;
  long max_effects = 0, beam = 0, threads = 0;
  const char* who = "auger explain";
  if (!a.whole(who, "--max-effects", 4, 1, 10, max_effects) || !a.whole(who, "--beam", 2, 1, 6, beam) ||
      !a.whole(who, "--threads", 2, 1, 64, threads))
    return 2;
  o.max_effects = static_cast<int>(max_effects);
  o.beam = static_cast<int>(beam);
  o.threads = static_cast<int>(threads);
  o.only = split_ids(a.get("--only"));
  if (!known_effects(who, o.only)) return 2;
  try {
    std::vector<Dataset> logs;
    std::vector<ModelChoice> models;
    double seconds = 0;
    for (const auto& path : a.positional) {
      logs.push_back(load_dataset(path));
      require_fit_data(logs.back(), "explain");
      seconds += logs.back().duration_s();
    }
    std::vector<std::string> warnings;
    std::vector<TerrainChoice> terrains;
    for (auto& d : logs) {
      const TerrainChoice tc = choose_terrain(d, a.get("--model"), a.get("--terrain"), "explain",
                                              a.has("--model") ? " --model " + typed(a.get("--model")) : "");
      models.push_back(tc.model);
      terrains.push_back(tc);
      // The model as given must predict numbers before minutes of search start from it (a
      // model of NaN scores a "perfect" 0).
      const CompareResult given = compare(d, models.back());
      require_noise_floor(d, given.noise_floor);
      require_finite(d, given.segments_err, models.back(), "segments of 25 s (the model as given)");
      std::vector<std::string> ws = tc.warnings;
      if (const std::string w = unchecked_warning(d); !w.empty()) ws.push_back(w);
      for (const auto& w : ws) warnings.push_back(logs.size() > 1 ? d.path + ": " + w : w);
    }
    print_warnings("explain", warnings);
    o.progress = a.has("--progress") || (!a.has("--quiet") && !a.has("--json"));
    o.progress_detail = a.has("--progress");
    const ExplainResult r = explain(logs, models, o);
    // Numbers, or nothing is written (a model of NaN would load and mislead).
    for (std::size_t i = 0; i < logs.size() && i < r.noise_floor.size(); ++i) require_noise_floor(logs[i], r.noise_floor[i]);
    for (int c = 0; c < kChannels; ++c)
      if (r.active[static_cast<std::size_t>(c)] && !std::isfinite(r.final_ratio[static_cast<std::size_t>(c)]))
        throw std::runtime_error(std::string("the explained model predicts no finite ") + channel_name(c) +
                                 " for the logs: nothing written");
    for (const auto& e : r.final_fitted)
      for (const auto& p : e.params)
        if (!std::isfinite(p.value))
          throw std::runtime_error("the fit of " + e.effect + " gave " + p.name + " = " + std::to_string(p.value) +
                                   ": nothing written");
    const std::string out = a.get("--out");
    if (!out.empty()) {
      std::ofstream f(out);
      if (!(f << r.model_toml)) {
        f.close();
        std::remove(out.c_str());  // no half-written model left behind
        std::fprintf(stderr, "auger explain: cannot write %s\n", out.c_str());
        return 2;
      }
      f.close();
      try {
        choose_model(logs.front(), out);  // it must load back
      } catch (...) {
        std::remove(out.c_str());  // a file that does not load back is not left behind
        throw;
      }
    } else {
      parse_model_file(r.model_toml, "(explained model)");
    }
    std::string logs_arg;
    for (const auto& p : a.positional) logs_arg += " " + p;
    std::string better;
    for (std::size_t i = 0; i < logs.size(); ++i)
      if (const std::string b = terrain_next(logs[i], terrains[i], "explain", ""); !b.empty() && better.empty()) better = b;
    const std::string next = (better.empty() ? "" : better + "; or ") + (out.empty() ? "auger explain" + logs_arg + " --out MODEL.toml, then auger compare" +
                                               logs_arg.substr(0, logs_arg.find(' ', 1)) + " --model MODEL.toml"
                                         : "auger compare" + std::string(" ") + a.positional.front() + " --model " + out);
    if (a.has("--json")) {
      print_explain_json(r, logs, terrains, out, next, warnings);
      return 0;
    }
    print_explain_text(r, logs, terrains, seconds);
    if (!out.empty()) std::printf("model file written: %s\n", out.c_str());
    std::printf("next: %s\n", next.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger explain: %s\n", e.what());
    return 2;
  }
}

}  // namespace auger::wb
