// explain's output (docs/workbench.md "explain", "Output"): the JSON object and the text a person
// reads, from the engine's ExplainResult. `auger explain` (explain_cmd.cpp) parses, runs and writes.
#include "explain_out.hpp"

#include <cmath>
#include <cstdio>

#include "cli_text.hpp"

namespace auger::wb {

namespace {

// "1.23" for a channel the log has, "-" otherwise.
std::string cell(double v) {
  if (!std::isfinite(v)) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, v < 10 ? "%.2f" : "%.1f", v);
  return buf;
}

}  // namespace


void print_explain_json(const ExplainResult& r, const std::vector<Dataset>& logs, const std::vector<TerrainChoice>& models,
                        const std::string& out, const std::string& next, const std::vector<std::string>& warnings) {
  Json j;
  j.begin_object();
  j.begin_array("logs");
  for (std::size_t i = 0; i < r.logs.size(); ++i) {
    j.begin_object().str("log", r.logs[i]).str("model", models[i].model.source);
    json_terrain(j, models[i]);
    j.channels("noise_floor", r.noise_floor[i], logs[i].active);
    j.channels("segment_floor", r.segment_floor[i], logs[i].active).end_object();
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
    j.begin_object()
        .str("effect", x.effect)
        .str("why", x.why)
        .num("contribution", x.contribution)
        .boolean("unconfirmed", x.unconfirmed)
        .end_object();
  j.end_array();
  j.begin_array("stand_ins");
  for (const auto& x : r.stand_ins) {
    j.begin_object().str("effect", x.effect).str("why", x.why).num("contribution", x.contribution);
    j.channels("ratio_with", x.ratio_with, r.active).channels("ratio_without", x.ratio_without, r.active).end_object();
  }
  j.end_array();
  j.begin_array("near_ties");
  for (const auto& t : r.near_ties) {
    j.begin_object().str("effect", t.effect).begin_array("with");
    for (const auto& w : t.with) j.str(nullptr, w);
    j.end_array().str("tell_apart", t.tell_apart).end_object();
  }
  j.end_array();
  j.boolean("outside_library", r.outside_library);
  if (r.outside_library) j.channels("library_ratio", r.library_ratio, r.active);
  j.begin_array("discovered");
  // A term's object opened with where it acts, its form, inputs, coefficient and unit.
  auto term_head = [&j](const TermText& t) -> Json& {
    j.begin_object().str("dof", t.dof).str("form", t.form).begin_array("inputs");
    for (const auto& in : t.inputs) j.str(nullptr, in);
    return j.end_array().num("coefficient", t.coefficient).str("unit", t.unit);
  };
  for (const auto& g : r.discovered) {
    j.begin_object().str("channel", g.channel).begin_array("terms");
    for (const auto& d : g.terms) {
      term_head(d).num("uncertainty", d.uncertainty);
      j.num("contribution", d.contribution).str("description", d.description).begin_array("alternatives");
      for (const auto& a : d.alternatives) {
        term_head(a).num("ratio", a.ratio);
        j.str("description", a.description).str("tell_apart", a.tell_apart).end_object();
      }
      j.end_array().end_object();
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
}

void print_explain_text(const ExplainResult& r, const std::vector<Dataset>& logs, const std::vector<TerrainChoice>& models,
                        double seconds) {
std::printf("explain: %zu log%s, %.1f s in all\n", logs.size(), logs.size() > 1 ? "s" : "", seconds);
for (std::size_t i = 0; i < logs.size(); ++i) {
  std::printf("  %s: %s, %.1f s; model: %s; noise floor", logs[i].path.c_str(), logs[i].gantry ? "gantry" : "robot",
              logs[i].duration_s(), models[i].model.source.c_str());
  for (int c = 0; c < kChannels; ++c)
    if (logs[i].active[static_cast<std::size_t>(c)])
      std::printf(" %s %.3g %s", channel_name(c), r.noise_floor[i][static_cast<std::size_t>(c)], channel_unit(c));
  std::printf("\n    %s\n", terrain_text(models[i]).c_str());
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
            "splits of the log (each holding out another third of its segments). The final model keeps an\n"
            "effect only when it changes the prediction by 0.5 times the noise floor, its parameters are\n"
            "identified and 3-fold cross-validation confirms it; where no library effect fits in form, the\n"
            "missing term is sought in a dictionary (docs/workbench.md \"Discovered terms\").\n");
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
for (const auto& x : r.stand_ins)
  std::printf("  a possible stand-in, not a finding: %s: %s (with it %.2f times the noise floor at most, %.2f "
              "without)\n",
              x.effect.c_str(), x.why.c_str(), largest_finite(x.ratio_with), largest_finite(x.ratio_without));
if (!r.discovered.empty()) {
  std::printf("discovered terms (no library effect has them; docs/workbench.md \"Discovered terms\"):\n");
  for (const auto& g : r.discovered) {
    for (const auto& d : g.terms) {
      std::printf("  %s: %s = %.4g +- %.2g %s (changes the prediction by %.2f times the noise floor)\n",
                  d.dof.c_str(), d.form.c_str(), d.coefficient, d.uncertainty, d.unit.c_str(), d.contribution);
      for (const auto& a : d.alternatives)
        std::printf("    or as well %s: %s = %.4g %s (%.2f times the noise floor with it): %s\n", a.dof.c_str(),
                    a.form.c_str(), a.coefficient, a.unit.c_str(), a.ratio, a.tell_apart.c_str());
    }
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
}

}  // namespace auger::wb
