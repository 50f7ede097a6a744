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
#include "workbench.hpp"

namespace auger::wb {

namespace {

const CommandLine kCli{
    "auger explain",
    "LOG... [--model FILE] [--out MODEL] [--max-effects N] [--beam N]\n"
    "                     [--only ID,...] [--threads N] [--json] [--progress | --quiet]",
    "The loop compare -> diagnose -> fit --add -> diagnose ... in one command: at every step each\n"
    "library effect is fitted jointly with the effects chosen so far and the paper's parameters;\n"
    "an effect that no longer pays for itself is dropped; near ties are carried along; it stops\n"
    "when what remains is noise (held-out error at the noise floor, residuals white and\n"
    "independent of the inputs) or no candidate is significant, and says what is left.\n"
    "Several logs of one robot are explained together (effects shared, the paper's parameters\n"
    "per terrain).\n",
    {kModelOption,
     {"--out", "MODEL", "write the final model file there"},
     {"--max-effects", "N", "at most N effects added (default 4; 1 .. 10)"},
     {"--beam", "N", "near ties carried along (default 2; 1 .. 6)"},
     {"--only", "ID,...", "consider only these effects"},
     {"--threads", "N", "threads for the fits (default 2; 1 .. 64)"},
     {"--json", "", "one JSON object on stdout"},
     {"--progress", "", "also a line per candidate fitted on stderr (default: a line per step, none with --json)"},
     {"--quiet", "", "no progress lines"}},
    ""};

// "1.23" for a channel the log has, "-" otherwise.
std::string cell(double v) {
  if (!std::isfinite(v)) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, v < 10 ? "%.2f" : "%.1f", v);
  return buf;
}

}  // namespace

int run_explain(int argc, char** argv) {
  Args a;
  if (const int rc = kCli.parse_or_answer(argc, argv, a); rc >= 0) return rc;
  if (a.positional.empty()) return kCli.print_usage(stderr), 2;
  auto count = [&](const char* opt, int dflt, int lo, int hi, int& out) {
    if (!a.has(opt)) {
      out = dflt;
      return true;
    }
    const std::string v = a.get(opt);
    char* end = nullptr;
    const long n = std::strtol(v.c_str(), &end, 10);
    if (v.empty() || *end != '\0' || n < lo || n > hi) {
      std::fprintf(stderr, "auger explain: %s: '%s' is not a whole number from %d to %d\n", opt, v.c_str(), lo, hi);
      return false;
    }
    out = static_cast<int>(n);
    return true;
  };
  ExplainOptions o;
  if (!count("--max-effects", 4, 1, 10, o.max_effects) || !count("--beam", 2, 1, 6, o.beam) ||
      !count("--threads", 2, 1, 64, o.threads))
    return 2;
  o.only = split_ids(a.get("--only"));
  for (const auto& id : o.only) {
    bool known = false;
    for (const auto& le : effect_library()) known |= le.id == id;
    if (!known) {
      std::fprintf(stderr, "auger explain: unknown effect '%s' (auger effects lists them)\n", id.c_str());
      return 2;
    }
  }
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
    for (const auto& d : logs) {
      models.push_back(choose_model(d, a.get("--model")));
      // The model as given must predict numbers before minutes of search start from it (a
      // model of NaN scores a "perfect" 0).
      const CompareResult given = compare(d, models.back());
      require_noise_floor(d, given.noise_floor);
      require_finite(d, given.segments_err, models.back(), "segments of 25 s (the model as given)");
      const std::string w = terrain_warning(d, models.back());
      if (!w.empty()) warnings.push_back(logs.size() > 1 ? d.path + ": " + w : w);
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
    const std::string next = out.empty() ? "auger explain" + logs_arg + " --out MODEL.toml, then auger compare" +
                                               logs_arg.substr(0, logs_arg.find(' ', 1)) + " --model MODEL.toml"
                                         : "auger compare" + std::string(" ") + a.positional.front() + " --model " + out;
    if (a.has("--json")) {
      Json j;
      j.begin_object();
      j.begin_array("logs");
      for (std::size_t i = 0; i < r.logs.size(); ++i) {
        j.begin_object().str("log", r.logs[i]).str("model", models[i].source).str("terrain", models[i].terrain);
        j.channels("noise_floor", r.noise_floor[i], logs[i].active).end_object();
      }
      j.end_array();
      j.begin_array("effects");
      for (const auto& id : r.effects) j.str(nullptr, id);
      j.end_array();
      j.begin_array("steps");
      for (const auto& s : r.steps) {
        j.begin_object().num("step", s.index).str("added", s.added);
        j.begin_array("dropped");
        for (const auto& d : s.dropped) j.str(nullptr, d);
        j.end_array().begin_array("effects");
        for (const auto& e : s.effects) j.str(nullptr, e);
        j.end_array();
        j.channels("heldout_ratio", s.heldout_ratio, r.active).num("heldout_combined", s.heldout_combined);
        j.num("delta_bic", s.delta_bic).boolean("flagged", s.flagged).boolean("paper_params_held", s.paper_held);
        j.num("split", s.split);
        if (s.second_opinion) {
          j.begin_object("second_opinion").num("refused_heldout", s.refused_heldout).num("refused_from", s.refused_from);
          j.begin_array("splits");
          for (std::size_t k = 0; k < s.split_heldout.size(); ++k)
            j.begin_object().num("split", static_cast<double>(k + 2)).num("heldout_combined", s.split_heldout[k])
                .num("before", s.split_from[k]).num("delta_bic", s.split_delta_bic[k]).end_object();
          j.end_array().end_object();
        }
        json_fitted(j, "fitted", s.fitted);
        j.begin_array("alternatives");
        for (const auto& c : s.alternatives) {
          j.begin_object().str("effect", c.fitted.effect).num("heldout_ratio", c.heldout_ratio).num("delta_bic", c.delta_bic);
          j.str("tell_apart", c.tell_apart).end_object();
        }
        j.end_array().end_object();
      }
      j.end_array();
      j.begin_object("final");
      j.channels("ratio", r.final_ratio, r.active).channels("heldout_ratio", r.final_heldout, r.active);
      json_fitted(j, "fitted", r.final_fitted);
      j.begin_array("residual_tests");
      for (std::size_t i = 0; i < r.tests.size(); ++i) {
        j.begin_object().str("log", r.logs[i]).boolean("white", r.tests[i].white).boolean("independent", r.tests[i].independent);
        j.str("summary", describe_residual_tests(r.tests[i])).end_object();
      }
      j.end_array();
      j.str("model_file", out);
      j.end_object();
      j.begin_array("removed");
      for (const auto& x : r.removed)
        j.begin_object().str("effect", x.effect).str("why", x.why).num("contribution", x.contribution).end_object();
      j.end_array();
      j.boolean("outside_library", r.outside_library);
      if (r.outside_library) j.channels("library_ratio", r.library_ratio, r.active);
      j.begin_array("discovered");
      for (const auto& g : r.discovered) {
        j.begin_object().str("channel", g.channel).begin_array("terms");
        for (const auto& d : g.terms) {
          j.begin_object().str("dof", d.dof).str("form", d.form).begin_array("inputs");
          for (const auto& in : d.inputs) j.str(nullptr, in);
          j.end_array().num("coefficient", d.coefficient).str("unit", d.unit).num("uncertainty", d.uncertainty);
          j.num("contribution", d.contribution).str("description", d.description).end_object();
        }
        j.end_array().channels("ratio_after", g.ratio_after, r.active).end_object();
      }
      j.end_array();
      j.str("verdict_kind", r.verdict_kind).str("verdict", r.verdict);
      json_windows(j, "where", r.where);
      j.num("structures_fitted", r.structures_tried);
      j.str("next", next);
      j.begin_array("warnings");
      for (const auto& w : warnings) j.str(nullptr, w);
      j.end_array();
      j.end_object();
      std::printf("%s\n", j.text().c_str());
      return 0;
    }
    std::printf("explain: %zu log%s, %.1f s in all\n", logs.size(), logs.size() > 1 ? "s" : "", seconds);
    for (std::size_t i = 0; i < logs.size(); ++i) {
      std::printf("  %s: %s, %.1f s; model: %s; noise floor", logs[i].path.c_str(), logs[i].gantry ? "gantry" : "robot",
                  logs[i].duration_s(), models[i].source.c_str());
      for (int c = 0; c < kChannels; ++c)
        if (logs[i].active[static_cast<std::size_t>(c)])
          std::printf(" %s %.3g %s", channel_name(c), r.noise_floor[i][static_cast<std::size_t>(c)], channel_unit(c));
      std::printf("\n");
    }
    std::printf("\nheld-out error per channel, in multiples of the noise floor (1.00 = only noise left):\n");
    std::printf("step  %-26s", "effect added");
    for (int c = 0; c < kChannels; ++c)
      if (r.active[static_cast<std::size_t>(c)]) std::printf(" %8s", channel_name(c));
    std::printf("  delta BIC\n");
    for (const auto& s : r.steps) {
      std::printf("%4d  %-26s", s.index, s.added.empty() ? "(the model as given)" : ("+ " + s.added).c_str());
      for (int c = 0; c < kChannels; ++c)
        if (r.active[static_cast<std::size_t>(c)]) std::printf(" %8s", cell(s.heldout_ratio[static_cast<std::size_t>(c)]).c_str());
      if (s.index > 0) std::printf("  %9.1f%s", s.delta_bic, s.flagged ? "  FLAGGED" : "");
      std::printf("\n");
      for (const auto& d : s.dropped) std::printf("      - %s dropped: it no longer pays for itself\n", d.c_str());
      if (s.second_opinion) {
        std::printf("      (refused by the held-out segments alone: %.2f against %.2f before; taken because it\n"
                    "      passes on the log's two other splits, each holding out another third of the segments:\n     ",
                    s.refused_heldout, s.refused_from);
        for (std::size_t k = 0; k < s.split_heldout.size(); ++k)
          std::printf(" split %zu: %.2f against %.2f, delta BIC %.1f%s", k + 2, s.split_heldout[k], s.split_from[k],
                      s.split_delta_bic[k], k + 1 < s.split_heldout.size() ? ";" : ".\n");
        std::printf("      Held-out errors from here on are split %d's)\n", s.split);
      }
      if (s.paper_held && s.index > 0 && !r.steps[static_cast<std::size_t>(s.index - 1)].paper_held)
        std::printf("      (the paper's parameters held at its values: refitted, they ran to the end of their range)\n");
      for (const auto& c : s.alternatives)
        std::printf("      near tie: %s (held-out %s, delta BIC %.1f); the experiment that tells them apart: %s\n",
                    c.fitted.effect.c_str(), times_noise(c.heldout_ratio).c_str(), c.delta_bic, c.tell_apart.c_str());
    }
    std::printf("Each step refits every effect chosen so far and the paper's parameters jointly with the candidate;\n"
                "a candidate is taken when it gains more than 10 in BIC and lowers the held-out error by 2 %%, the\n"
                "lowest held-out error first (a fit with a value at or beyond its physical range counted 15 %% worse).\n"
                "Where the paper's parameters run to the end of their range, the structure is fitted with them held\n"
                "at the paper's values too, and the one with the lower held-out error is taken. Where the held-out\n"
                "segments alone refuse the candidate that gains most in BIC, it is taken if it passes on both other\n"
                "splits of the log (each holding out another third of its segments).\n");
    std::printf("\nfinal model, refitted on every segment; error as `auger compare --model` computes it (segments of\n"
                "25 s, multiples of the noise floor):");
    for (int c = 0; c < kChannels; ++c)
      if (r.active[static_cast<std::size_t>(c)])
        std::printf("  %s %s", channel_name(c), cell(r.final_ratio[static_cast<std::size_t>(c)]).c_str());
    std::printf("\n");
    for (const auto& e : r.final_fitted) {
      std::printf("  %s: %s\n", e.effect.c_str(), e.description.c_str());
      print_fitted(stdout, e, "    ");
    }
    for (const auto& x : r.removed)
      std::printf("  left out by the final checks: %s: %s\n", x.effect.c_str(), x.why.c_str());
    if (!r.discovered.empty()) {
      std::printf("discovered terms (no library effect has them; docs/workbench.md \"Discovered terms\"):\n");
      for (const auto& g : r.discovered) {
        for (const auto& d : g.terms)
          std::printf("  %s: %s = %.4g +- %.2g %s (changes the prediction by %.2f times the noise floor)\n",
                      d.dof.c_str(), d.form.c_str(), d.coefficient, d.uncertainty, d.unit.c_str(), d.contribution);
        std::printf("    error with the %s terms so far:", g.channel.c_str());
        for (int c = 0; c < kChannels; ++c)
          if (r.active[static_cast<std::size_t>(c)])
            std::printf("  %s %s", channel_name(c), cell(g.ratio_after[static_cast<std::size_t>(c)]).c_str());
        std::printf("\n");
      }
    }
    std::printf("residual tests:");
    for (std::size_t i = 0; i < r.tests.size(); ++i)
      std::printf(" %s%s", r.tests.size() > 1 ? (r.logs[i] + ": ").c_str() : "", describe_residual_tests(r.tests[i]).c_str());
    std::printf("\n\nverdict: %s\n", r.verdict.c_str());
    if (r.verdict_kind != "noise" && !r.where.empty()) {
      std::printf("where the model fails most (5 s windows):\n");
      for (const auto& w : r.where)
        std::printf("  t %7.1f - %7.1f s  %-7s  RMS %s = %s\n", w.t_start_s, w.t_end_s, channel_name(w.dof),
                    with_unit(w.rms, channel_unit(w.dof), 3).c_str(), times_noise(w.ratio_to_noise).c_str());
    }
    if (!out.empty()) std::printf("model file written: %s\n", out.c_str());
    std::printf("next: %s\n", next.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger explain: %s\n", e.what());
    return 2;
  }
}

}  // namespace auger::wb
