// `auger fit LOG --add EFFECT[,EFFECT...] [--out MODEL] [--model FILE] [--json]`: re-identify
// the paper's parameters with effects added, error before and after (docs/workbench.md).
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>

#include "auger/args.hpp"
#include "auger/term_form.hpp"
#include "checks.hpp"
#include "cli_text.hpp"
#include "commands.hpp"
#include "terrain.hpp"
#include "workbench.hpp"

namespace auger::wb {

namespace {

const CommandLine kCli{
    "auger fit",
    "LOG --add EFFECT[,EFFECT...] [--add-term DOF:FORM[,DOF:FORM...]] [--hold PARAM[,...]] [--out MODEL]\n"
    "                 [--model FILE] [--terrain NAME|auto] [--threads N] [--json]",
    "Re-identifies sigma and D (eqs. (15)-(17)) together with the effects added, prints the error\n"
    "per channel before and after (also as multiples of the noise floor), writes a model file.\n",
    {{"--add", "EFFECT[,EFFECT...]", "the effects to add (auger effects lists them); paper_params: the\n"
      "paper's parameters alone"},
     {"--add-term", "DOF:FORM[,...]", "discovered terms to fit as well (auger explain proposes them;\n"
      "docs/workbench.md \"Discovered terms\"), e.g. yaw:v_mps or screw_2:neg(omega_rpm)"},
     {"--hold", "PARAM[,PARAM...]", "paper_params' parameters kept at the model's values (e.g. D_x,D_y,D_psi,\n"
      "as augerd's online estimate holds the drag)"},
     {"--out", "MODEL", "write the fitted model file there"},
     kModelOption,
     kTerrainOption,
     {"--threads", "N", "threads for the fits (default 2; 1 .. 64)"},
     {"--json", "", "one JSON object on stdout"},
     {"--progress", "", "progress lines on stderr"}},
    ""};

}  // namespace

int run_fit(int argc, char** argv) {
  Args a;
  if (const int rc = kCli.parse_or_answer(argc, argv, a); rc >= 0) return rc;
  if (a.positional.size() != 1) return kCli.print_usage(stderr), 2;
  const std::vector<std::string> ids = split_ids(a.get("--add"));
  std::vector<std::pair<std::string, std::string>> terms;
  for (const std::string& spec : split_ids(a.get("--add-term"))) {
    const auto colon = spec.find(':');
    try {
      if (colon == std::string::npos) throw std::invalid_argument("'" + spec + "' is not DOF:FORM");
      const TermForm f(spec.substr(0, colon), spec.substr(colon + 1));
      terms.push_back({f.dof_text(), f.form_text()});
    } catch (const std::invalid_argument& e) {
      std::fprintf(stderr, "auger fit: --add-term: %s\n", e.what());
      return 2;
    }
  }
  if (ids.empty() && terms.empty()) {
    std::fprintf(stderr, "auger fit: --add EFFECT[,EFFECT...] is required (auger effects lists them)\n");
    return 2;
  }
  if (!known_effects("auger fit", ids)) return 2;
  long threads = 0;
  if (!a.whole("auger fit", "--threads", 2, 1, 64, threads)) return 2;
  try {
    Dataset d = load_dataset(a.positional[0]);
    require_fit_data(d, "fit");
    std::string added = a.has("--add") ? " --add " + a.get("--add") : "";
    if (a.has("--add-term")) added += " --add-term '" + a.get("--add-term") + "'";
    const std::string model_arg = a.has("--model") ? " --model " + typed(a.get("--model")) : "";
    const TerrainChoice tc = choose_terrain(d, a.get("--model"), a.get("--terrain"), "fit", model_arg + added);
    const FitResult r = fit(d, tc.model, ids, a.has("--progress"), terms, split_ids(a.get("--hold")),
                              static_cast<int>(threads));
    // Numbers, or nothing is written (a model of NaN would load and mislead).
    require_noise_floor(d, r.noise_floor);
    require_finite(d, r.err_before, r.before, "segments, before");
    require_finite(d, r.err_after, r.after, "segments, with the effects fitted");
    for (const auto& e : r.effects)
      for (const auto& p : e.params)
        if (!std::isfinite(p.value))
          throw std::runtime_error("the fit of " + e.effect + " gave " + p.name + " = " + std::to_string(p.value) +
                                   ": nothing written");
    std::vector<std::string> warnings = tc.warnings;
    if (const std::string w = unchecked_warning(d); !w.empty()) warnings.push_back(w);
    // The file must load back and give the same model (checked here, not assumed).
    const std::string out = a.get("--out");
    if (!out.empty()) {
      std::ofstream f(out);
      if (!(f << r.model_toml)) {
        std::remove(out.c_str());
        std::fprintf(stderr, "auger fit: cannot write %s\n", out.c_str());
        return 2;
      }
      f.close();
      try {
        choose_model(d, out);
      } catch (...) {
        std::remove(out.c_str());  // a file that does not load back is not left behind
        throw;
      }
    } else {
      parse_model_file(r.model_toml, "(fitted model)");
    }
    bool flagged = false, beyond = false;
    for (const auto& e : r.effects) flagged = flagged || any_flagged(e);
    for (double x : r.err_after.ratio_to_noise) beyond = beyond || x > 1.3;
    const std::string log = typed(d.path), model_file = out.empty() ? "fitted.toml" : typed(out);
    std::string next;
    const std::string terrain_arg = tc.from == "--terrain" || tc.from == "auto" ? " --terrain " + tc.model.terrain : "";
    if (out.empty()) next = "auger fit " + log + model_arg + terrain_arg + added + " --out fitted.toml (write the model file)";
    else if (beyond) next = "auger diagnose " + log + " --model " + model_file + " (what is still missing)";
    else next = "auger compare " + log + " --model " + model_file + " (the error after, as above), or load it in augerd";
    if (const std::string better = terrain_next(d, tc, "fit", model_arg + added); !better.empty())
      next = better + "; or " + next;
    if (flagged)
      next = "check the flagged values above (an effect the log cannot identify: drop it or record the experiment "
             "that excites it); then " + next;
    if (a.has("--json")) {
      Json j;
      j.begin_object().str("log", d.path);
      json_terrain(j, tc);
      j.channels("noise_floor", r.noise_floor, d.active);
      j.channels("segment_floor", r.segment_floor, d.active);
      j.begin_object("before").channels("rms", r.err_before.rms, d.active).channels("ratio", r.err_before.ratio_to_noise, d.active).end_object();
      j.begin_object("after").channels("rms", r.err_after.rms, d.active).channels("ratio", r.err_after.ratio_to_noise, d.active).end_object();
      json_fitted(j, "effects", r.effects);
      j.str("model_file", out.empty() ? "" : out);
      j.begin_array("warnings");
      for (const auto& w : warnings) j.str(nullptr, w);
      j.end_array();
      j.str("next", next);
      j.end_object();
      std::printf("%s\n", j.text().c_str());
      print_warnings("fit", warnings);
      return 0;
    }
    print_warnings("fit", warnings);
    std::printf("log %s; model before: %s\n%s\n", d.path.c_str(), r.before.source.c_str(), terrain_text(tc).c_str());
    std::printf("RMS error per channel (segments of 25 s), and as a multiple of the noise floor:\n");
    std::printf("  %-8s  %-34s  %s\n", "channel", "before", "after");
    for (int c = 0; c < kChannels; ++c) {
      const auto cc = static_cast<std::size_t>(c);
      if (!d.active[cc]) continue;
      auto both = [&](const ErrorStats& e) {
        return with_unit(e.rms[cc], channel_unit(c)) + " = " + ratio_cell(e.ratio_to_noise[cc]) + " times noise";
      };
      std::printf("  %-8s  %-34s  %s\n", channel_name(c), both(r.err_before).c_str(), both(r.err_after).c_str());
    }
    std::printf("\nfitted (value +- one standard uncertainty):\n");
    for (const auto& e : r.effects) {
      std::printf("  %s: %s\n", e.effect.c_str(), e.description.c_str());
      print_fitted(stdout, e, "    ");
    }
    if (!out.empty()) std::printf("\nmodel file written: %s\n", out.c_str());
    else std::printf("\nthe model file (not written; --out FILE writes it):\n%s", r.model_toml.c_str());
    std::printf("\nnext: %s\n", next.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger fit: %s\n", e.what());
    return 2;
  }
}

}  // namespace auger::wb
