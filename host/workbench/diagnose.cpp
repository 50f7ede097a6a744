// `auger diagnose LOG [--model FILE] [--only ID,...] [--json]`: which physical effect is missing
// (docs/workbench.md).
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>

#include "auger/args.hpp"
#include "checks.hpp"
#include "cli_text.hpp"
#include "commands.hpp"
#include "terrain.hpp"
#include "workbench.hpp"

namespace auger::wb {

namespace {

// What a researcher runs after this verdict.
std::string next_command(const Dataset& d, const DiagnoseResult& r, const std::string& model) {
  const std::string log = typed(d.path), model_arg = model.empty() ? "" : " --model " + typed(model);
  if (r.candidates.empty() || !r.significant)
    return "auger report " + log + model_arg + " --out report (the plots; nothing is missing)";
  const Candidate& best = r.candidates.front();
  const bool explained = r.verdict.rfind("nothing in the library", 0) != 0;
  if (!explained)
    return "auger explain " + log + model_arg + " (several effects together), then look at the windows above with "
           "auger report " + log + model_arg + " --out report";
  std::string s = "auger fit " + log + model_arg + " --add " + best.fitted.effect + " --out fitted.toml";
  if (best.near_tie) s += " (or run the experiment named above to settle the near tie first)";
  return s + "; or auger explain " + log + model_arg + " to add effects until only noise is left";
}

const CommandLine kCli{
    "auger diagnose",
    "LOG [--model FILE] [--terrain NAME|auto] [--only ID,...] [--threads N] [--json]",
    "Fits every library effect (auger effects) by simulation error over training segments, judges\n"
    "it on held-out segments, ranks by BIC with an effective sample size; says whether anything is\n"
    "missing, what, and where the model fails. Progress on stderr for long logs.\n",
    {kModelOption,
     kTerrainOption,
     {"--only", "ID,...", "fit only these effects"},
     {"--threads", "N", "threads for the fits (default 2; 1 .. 64)"},
     {"--json", "", "one JSON object on stdout"},
     {"--progress", "", "a line per candidate on stderr (default: for logs over 300 s)"},
     {"--quiet", "", "no progress lines"}},
    ""};

}  // namespace

int run_diagnose(int argc, char** argv) {
  Args a;
  if (const int rc = kCli.parse_or_answer(argc, argv, a); rc >= 0) return rc;
  if (a.positional.size() != 1) return kCli.print_usage(stderr), 2;
  try {
    Dataset d = load_dataset(a.positional[0]);
    require_fit_data(d, "diagnose");
    const std::string model_arg = a.has("--model") ? " --model " + typed(a.get("--model")) : "";
    const TerrainChoice tc = choose_terrain(d, a.get("--model"), a.get("--terrain"), "diagnose", model_arg);
    DiagnoseOptions o;
    o.only = split_ids(a.get("--only"));
    long threads = 0;
    if (!known_effects("auger diagnose", o.only) || !a.whole("auger diagnose", "--threads", o.threads, 1, 64, threads))
      return 2;
    o.threads = static_cast<int>(threads);
    o.progress = a.has("--progress") || (!a.has("--quiet") && d.duration_s() > 300);
    const DiagnoseResult r = diagnose(d, tc.model, o);
    require_noise_floor(d, r.noise_floor);
    require_finite(d, r.nominal, r.model, "segments (the nominal model)");
    std::vector<std::string> warnings = tc.warnings;
    if (const std::string w = unchecked_warning(d); !w.empty()) warnings.push_back(w);
    const std::string better = terrain_next(d, tc, "diagnose", model_arg);
    const std::string next = (better.empty() ? "" : better + "; or ") + next_command(d, r, a.get("--model"));
    if (a.has("--json")) {
      Json j;
      j.begin_object();
      j.str("log", d.path).str("kind", d.gantry ? "gantry" : "robot").str("model", r.model.source);
      json_terrain(j, tc);
      j.channels("noise_floor", r.noise_floor, d.active);
      j.channels("segment_floor", r.segment_floor, d.active);
      j.channels("nominal_rms", r.nominal.rms, d.active);
      j.channels("nominal_ratio", r.nominal.ratio_to_noise, d.active);
      j.num("nominal_heldout_ratio", r.nominal_heldout_ratio).num("nominal_all_ratio", r.nominal_all_ratio).num("n", r.n).num("n_eff", r.n_eff);
      j.boolean("significant", r.significant).str("verdict", r.verdict);
      j.begin_array("candidates");
      for (const auto& c : r.candidates) {
        j.begin_object().str("effect", c.fitted.effect);
        j.begin_object("params");
        for (const auto& p : c.fitted.params) j.num(p.name.c_str(), p.value);
        j.end_object().begin_object("params_sigma");
        for (const auto& p : c.fitted.params) j.num(p.name.c_str(), p.sigma);
        j.end_object();
        j.str("description", c.fitted.description).num("delta_bic", c.delta_bic);
        j.channels("heldout_rms", c.heldout_rms, d.active).num("heldout_ratio", c.heldout_ratio);
        j.boolean("near_tie", c.near_tie);
        if (!c.tell_apart.empty()) j.str("tell_apart", c.tell_apart);
        // Flags of the candidate's parameters, and (diagnose --model) of the model's effects
        // refitted with it, as "effect.parameter".
        j.begin_object("flags");
        for (const auto& p : c.fitted.params)
          if (!p.flag.empty()) j.str(p.name.c_str(), p.flag);
        for (const auto& fe : c.refitted)
          for (const auto& p : fe.params)
            if (!p.flag.empty()) j.str((fe.effect + "." + p.name).c_str(), p.flag);
        j.end_object().boolean("flagged", c.flagged).boolean("implausible", c.implausible);
        if (!c.refitted.empty()) json_fitted(j, "refitted", c.refitted);
        j.str("rank_group", rank_group_id(rank_group(c, r.nominal_heldout_ratio)));
        j.end_object();
      }
      j.end_array();
      j.str("ranking_rule", kRankingRule);
      json_windows(j, "where", r.where);
      j.begin_array("warnings");
      for (const auto& w : warnings) j.str(nullptr, w);
      j.end_array();
      j.str("next", next);
      j.end_object();
      std::printf("%s\n", j.text().c_str());
      print_warnings("diagnose", warnings);
      return 0;
    }
    print_warnings("diagnose", warnings);
    std::printf("log %s: %s, %.1f s; model: %s\n%s\n", d.path.c_str(), d.gantry ? "gantry" : "robot", d.duration_s(),
                r.model.source.c_str(), terrain_text(tc).c_str());
    std::printf("noise floor (estimated from the data):");
    for (int c = 0; c < kChannels; ++c)
      if (d.active[static_cast<std::size_t>(c)])
        std::printf("  %s %s", channel_name(c), with_unit(r.noise_floor[static_cast<std::size_t>(c)], channel_unit(c), 3).c_str());
    std::printf("\n%s error (segments of 25 s):\n", r.refits_model ? "the model's" : "the nominal model's");
    for (int c = 0; c < kChannels; ++c)
      if (d.active[static_cast<std::size_t>(c)])
        std::printf("  %-8s RMS %s = %s\n", channel_name(c),
                    with_unit(r.nominal.rms[static_cast<std::size_t>(c)], channel_unit(c), 3).c_str(),
                    times_noise(r.nominal.ratio_to_noise[static_cast<std::size_t>(c)]).c_str());
    std::printf("held-out error (the segments the fits never see, RMS over channels): %.3f times the noise floor; "
                "over every segment %.3f\n",
                r.nominal_heldout_ratio, r.nominal_all_ratio);
    std::printf("\n%s\n", r.verdict.c_str());
    if (!tc.better.empty())
      std::printf("  but the paper's parameters for terrain '%s' explain this log clearly better than those of '%s': "
                  "the candidates below may stand in for the terrain (%s)\n",
                  tc.better.c_str(), tc.model.terrain.c_str(), better.c_str());
    std::string rule = kRankingRule;
    rule.replace(rule.find("; ") + 1, 1, "\n  ");
    std::printf("\nranking: %s.\n  delta BIC: the change of the Bayesian information criterion against the %s\n"
                "  (negative = better), with the effective sample size (n_eff %.0f of %.0f residuals).\n",
                rule.c_str(), r.refits_model ? "model as given" : "nominal model", r.n_eff, r.n);
    std::printf("\nrank  effect                  delta BIC   held-out error\n"
                "                                          (times the noise floor)\n");
    int rank = 0;
    bool first_group = true;
    RankGroup group = RankGroup::kImproves;
    for (const auto& c : r.candidates) {
      const RankGroup g = heading_group(rank_group(c, r.nominal_heldout_ratio));
      if (first_group || g != group) std::printf("  -- %s --\n", rank_group_words(g));
      first_group = false;
      group = g;
      ++rank;
      std::printf("%4d  %-22s %10.1f   %8.3f%s%s\n", rank, c.fitted.effect.c_str(), c.delta_bic, c.heldout_ratio,
                  c.implausible && g == RankGroup::kImproves ? "   implausible" : "", c.near_tie ? "   near tie" : "");
      if (rank <= 3 || c.flagged || c.near_tie) {
        if (rank <= 3) std::printf("      %s\n", c.fitted.description.c_str());
        if (rank <= 3 || c.flagged) print_fitted(stdout, c.fitted, "      ");
        for (const auto& m : c.refitted)
          if (any_flagged(m)) {
            std::printf("      refitted with it: %s\n", m.effect.c_str());
            print_fitted(stdout, m, "        ");
          }
        if (!c.tell_apart.empty())
          std::printf("      cannot be told apart from its neighbour in this log; the experiment that would: %s\n",
                      c.tell_apart.c_str());
      }
    }
    std::printf("\nworst 5 s windows of what remains (%s):\n",
                r.significant ? "after the best candidate" : "of the model as given");
    for (const auto& w : r.where)
      std::printf("  t %7.1f - %7.1f s  %-7s  RMS %s = %s\n", w.t_start_s, w.t_end_s, channel_name(w.dof),
                  with_unit(w.rms, channel_unit(w.dof), 3).c_str(), times_noise(w.ratio_to_noise).c_str());
    std::printf("\nnext: %s\n", next.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger diagnose: %s\n", e.what());
    return 2;
  }
}

}  // namespace auger::wb
