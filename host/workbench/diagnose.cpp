// `auger diagnose LOG [--model FILE] [--only ID,...] [--json]`: which physical effect is missing
// (docs/workbench.md).
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>

#include "args.hpp"
#include "checks.hpp"
#include "commands.hpp"
#include "workbench.hpp"

namespace auger::wb {

std::vector<std::string> split_ids(const std::string& text) {
  std::vector<std::string> ids;
  std::stringstream ss(text);
  std::string id;
  while (std::getline(ss, id, ','))
    if (!id.empty()) ids.push_back(id);
  return ids;
}

int run_diagnose(int argc, char** argv) {
  Args a;
  if (!parse_args(argc, argv, {"--json", "--help", "--progress", "--quiet"}, {"--model", "--only", "--threads"}, a))
    return 2;
  if (a.has("--help") || a.positional.size() != 1) {
    std::fprintf(a.has("--help") ? stdout : stderr,
                 "usage: auger diagnose LOG [--model FILE] [--only ID,...] [--threads N] [--json]\n"
                 "  fits every library effect (auger effects) by simulation error over training segments,\n"
                 "  judges it on held-out segments, ranks by BIC with an effective sample size; says whether\n"
                 "  anything is missing, what, and where the model fails. Progress on stderr for long logs.\n");
    return a.has("--help") ? 0 : 2;
  }
  try {
    const Dataset d = load_dataset(a.positional[0]);
    require_fit_data(d, "diagnose");
    DiagnoseOptions o;
    o.only = split_ids(a.get("--only"));
    for (const auto& id : o.only) {
      bool known = false;
      for (const auto& le : effect_library()) known |= le.id == id;
      if (!known) {
        std::fprintf(stderr, "auger diagnose: unknown effect '%s' (auger effects lists them)\n", id.c_str());
        return 2;
      }
    }
    if (a.has("--threads")) {
      const std::string t = a.get("--threads");
      char* end = nullptr;
      const long n = std::strtol(t.c_str(), &end, 10);
      if (end == t.c_str() || *end != '\0' || n < 1 || n > 256) {
        std::fprintf(stderr, "auger diagnose: --threads '%s' is not a number of threads in 1..256\n", t.c_str());
        return 2;
      }
      o.threads = int(n);
    }
    o.progress = a.has("--progress") || (!a.has("--quiet") && d.duration_s() > 300);
    const DiagnoseResult r = diagnose(d, choose_model(d, a.get("--model")), o);
    require_noise_floor(d, r.noise_floor);
    require_finite(d, r.nominal, r.model, "segments (the nominal model)");
    if (a.has("--json")) {
      Json j;
      j.begin_object();
      j.str("log", d.path).str("kind", d.gantry ? "gantry" : "robot").str("model", r.model.source);
      j.channels("noise_floor", r.noise_floor, d.active);
      j.channels("nominal_rms", r.nominal.rms, d.active);
      j.channels("nominal_ratio", r.nominal.ratio_to_noise, d.active);
      j.num("nominal_heldout_ratio", r.nominal_heldout_ratio).num("n", r.n).num("n_eff", r.n_eff);
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
        j.end_object();
      }
      j.end_array();
      json_windows(j, "where", r.where);
      j.end_object();
      std::printf("%s\n", j.text().c_str());
      return 0;
    }
    std::printf("log %s: %s, %.1f s; model: %s\n", d.path.c_str(), d.gantry ? "gantry" : "robot", d.duration_s(),
                r.model.source.c_str());
    std::printf("noise floor:");
    for (int c = 0; c < kChannels; ++c)
      if (d.active[static_cast<std::size_t>(c)])
        std::printf("  %s %.3g %s", channel_name(c), r.noise_floor[static_cast<std::size_t>(c)], channel_unit(c));
    std::printf("\nnominal error (segments):");
    for (int c = 0; c < kChannels; ++c)
      if (d.active[static_cast<std::size_t>(c)])
        std::printf("  %s %.3g (%.2fx)", channel_name(c), r.nominal.rms[static_cast<std::size_t>(c)],
                    r.nominal.ratio_to_noise[static_cast<std::size_t>(c)]);
    std::printf("\n\n%s\n\nrank  effect                 delta_BIC  held-out (x noise)  near tie\n", r.verdict.c_str());
    int rank = 0;
    for (const auto& c : r.candidates) {
      std::printf("%4d  %-22s %10.1f  %8.2f            %s\n", ++rank, c.fitted.effect.c_str(), c.delta_bic,
                  c.heldout_ratio, c.near_tie ? "yes" : "");
      if (rank <= 3) {
        std::printf("      %s\n      ", c.fitted.description.c_str());
        for (const auto& p : c.fitted.params)
          std::printf(" %s = %.4g +- %.2g %s;", p.name.c_str(), p.value, p.sigma, p.unit.c_str());
        std::printf("\n");
        if (!c.tell_apart.empty()) std::printf("      to tell apart: %s\n", c.tell_apart.c_str());
      }
    }
    std::printf("\nworst 5 s windows of what remains:\n");
    for (const auto& w : r.where)
      std::printf("  t %7.1f - %7.1f s  %-7s  %.1fx noise\n", w.t_start_s, w.t_end_s, channel_name(w.dof),
                  w.ratio_to_noise);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger diagnose: %s\n", e.what());
    return 2;
  }
}

}  // namespace auger::wb
