// `auger report LOG --out DIR [--model FILE] [--effect ID] [--no-diagnose] [--explain] [--json]`:
// one self-contained HTML page (DIR/index.html: interactive time plots by dygraphs and SVG by
// gnuplot inlined, inline CSS, no external reference) with what compare, diagnose, fit and
// explain find (the engine, workbench.hpp). The sections are in report_sections.cpp.
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>
#include <vector>

#include "auger/args.hpp"
#include "checks.hpp"
#include "cli_text.hpp"
#include "commands.hpp"
#include "report.hpp"
#include "report_online.hpp"
#include "terrain.hpp"

namespace auger::wb {
namespace {

const char* kStyle =
    "body{font-family:sans-serif;max-width:1100px;margin:0 auto 2em;padding:0 1em;color:#222}"
    "nav{position:sticky;top:0;background:#fff;padding:0.4em 0;border-bottom:1px solid #ddd;z-index:20}"
    "nav a{margin-right:1em}h2{margin-top:1.2em}"
    "table{border-collapse:collapse;margin:0.5em 0 1em}td,th{border:1px solid #ccc;padding:2px 6px;"
    "text-align:right;font-size:90%;vertical-align:top}th{background:#f3f3f3}td.l,th.l{text-align:left}"
    "tr.group td{background:#eef3f8;font-weight:bold}"
    "figure{margin:0.5em 0}figcaption{font-size:85%;color:#555}svg{max-width:100%;height:auto}"
    ".warn{color:#a40}.flag{color:#b00;font-weight:bold}.verdict{font-size:105%}"
    ".next code{background:#f3f3f3;padding:1px 4px}";

const CommandLine kCli{
    "auger report",
    "LOG --out DIR [--model FILE] [--terrain NAME|auto] [--effect ID] [--no-diagnose] [--explain] [--json]",
    "Writes DIR/index.html, one self-contained page (opens offline): measured vs model for x, y,\n"
    "psi and the path; the error over time with the worst windows; diagnose's candidates; the\n"
    "model before and after the best effect is fitted, with the effect's own curves.\n",
    {{"--out", "DIR", "the report's directory (created if missing)"},
     kModelOption,
     kTerrainOption,
     {"--effect", "ID", "fit this effect rather than diagnose's best"},
     {"--no-diagnose", "", "leave out diagnose's candidates"},
     {"--explain", "", "the steps of auger explain, and its model as the one after"},
     {"--json", "", "one JSON object on stdout"}},
    "Time plots zoom and pan together (dygraphs, Debian libjs-dygraphs); the path and the\n"
    "candidates are drawn by gnuplot ($AUGER_GNUPLOT or gnuplot on PATH; Debian gnuplot-nox).\n"};

int report_usage(std::FILE* f, int code) {
  kCli.print_usage(f);
  return code;
}

std::vector<int> active_channels(const Dataset& d) {
  std::vector<int> c;
  for (int k = 0; k < kChannels; ++k)
    if (d.active[static_cast<std::size_t>(k)]) c.push_back(k);
  return c;
}

// The output directory: created (with any missing parents) for this report if it does not
// exist; a report that fails leaves nothing behind (what it created is removed, a directory that
// existed keeps what it had: the page is written last, in one piece).
struct OutputDir {
  explicit OutputDir(const std::string& p) : path(p) {}
  std::filesystem::path path;
  std::filesystem::path created;  // the topmost directory this report created, empty if none
  bool done = false;
  // false with `why` set if it cannot be made a directory.
  bool make(std::string& why) {
    namespace fs = std::filesystem;
    std::error_code ec;
    fs::path top;
    for (fs::path p = fs::absolute(path, ec); !ec && !p.empty() && !fs::exists(p, ec); p = p.parent_path()) {
      top = p;
      if (p == p.parent_path()) break;
    }
    fs::create_directories(path, ec);
    if (!top.empty() && fs::is_directory(top)) created = top;
    if (ec || !fs::is_directory(path)) {
      why = ec ? ec.message() : "a file of that name exists";
      return false;
    }
    return true;
  }
  ~OutputDir() {
    std::error_code ec;
    if (!done && !created.empty()) std::filesystem::remove_all(created, ec);
  }
};

}  // namespace

int run_report(int argc, char** argv) {
  Args a;
  if (const int rc = kCli.parse_or_answer(argc, argv, a); rc >= 0) return rc;
  if (a.positional.size() != 1 || !a.has("--out")) return report_usage(stderr, 2);
  const std::string out_dir = a.get("--out");
  const bool json = a.has("--json");
  const bool progress = isatty(STDERR_FILENO);
  auto step = [&](const char* what) {
    if (progress) std::fprintf(stderr, "auger report: %s\n", what);
  };
  const std::string effect_arg = a.get("--effect");
  if (!effect_arg.empty()) {
    bool known = false;
    for (const auto& le : effect_library()) known |= le.id == effect_arg;
    if (!known) {
      std::fprintf(stderr, "auger report: unknown effect '%s' (auger effects lists them)\n", effect_arg.c_str());
      return 2;
    }
  }

  try {
    Dataset d = load_dataset(a.positional[0]);  // bad input first: exit 2 naming the line
    const bool search = !a.has("--no-diagnose") || a.has("--effect") || a.has("--explain");
    if (search) require_fit_data(d, "report");
    const std::string model_path = a.get("--model");
    const std::string out_arg = " --out " + typed(out_dir) + (model_path.empty() ? "" : " --model " + typed(model_path));
    const TerrainChoice tc = choose_terrain(d, model_path, a.get("--terrain"), "report", out_arg);
    const ModelChoice& mc = tc.model;
    Gnuplot gp;  // then a missing gnuplot or dygraphs, before the work
    ChartSet charts;
    OutputDir dir(out_dir);
    std::string why;
    if (!dir.make(why)) {
      std::fprintf(stderr, "auger report: cannot create directory '%s': %s\n", out_dir.c_str(), why.c_str());
      return 2;
    }
    step("compare");
    Findings f(d);
    f.cmp = compare(d, mc);
    require_noise_floor(d, f.cmp.noise_floor);
    require_finite(d, f.cmp.segments_err, mc, "segments of 25 s");
    f.chans = active_channels(d);
    f.warnings = tc.warnings;
    if (const std::string w = unchecked_warning(d); !w.empty()) f.warnings.push_back(w);
    f.terrain = terrain_text(tc);
    print_warnings("report", f.warnings);
    if (!a.has("--no-diagnose")) {
      step("diagnose (every library effect)");
      DiagnoseOptions o;
      o.progress = progress;
      f.dg = diagnose(d, mc, o);
      f.have_diag = true;
    }
    if (a.has("--explain")) {
      step("explain (effects added until only noise is left; the slow part)");
      ExplainOptions o;
      o.progress = progress;
      f.ex = explain({d}, {mc}, o);
      f.have_explain = true;
    }
    if (!d.online_value.empty()) {
      step("fit --add paper_params (the offline fit beside augerd's online estimate)");
      const FitResult r = fit(d, mc, {"paper_params"}, progress, {}, online_held(d));
      f.offline = r.effects.front().params;
    }
    f.effect_given = !effect_arg.empty();
    if (f.have_explain && !f.effect_given && !f.ex.effects.empty() && !f.ex.final_models.empty()) {
      std::string names;
      for (const auto& e : f.ex.effects) names += (names.empty() ? "" : " + ") + e;
      f.after_name = names;
      f.after_fitted = f.ex.final_fitted;
      f.after = compare(d, f.ex.final_models.front());
    } else {
      std::string effect = effect_arg;
      if (effect.empty() && f.have_diag && !f.dg.candidates.empty()) effect = f.dg.candidates.front().fitted.effect;
      if (!effect.empty()) {
        step(("fit --add " + effect).c_str());
        const FitResult ft = fit(d, mc, {effect}, progress);
        f.after_name = effect;
        f.after_fitted = ft.effects;
        f.after = compare(d, ft.after);
      }
    }
    const std::string log = typed(d.path), model_arg = model_path.empty() ? "" : " --model " + typed(model_path);
    if (f.have_explain)
      f.next = f.ex.verdict_kind == "noise" || f.ex.verdict_kind == "near_noise"
                   ? "auger explain " + log + model_arg + " --out explained.toml (write the model file), then "
                     "auger compare " + log + " --model explained.toml"
                   : "look at the windows where the model still fails (Error over time), then record the experiment "
                     "that excites them; auger explain " + log + model_arg + " --out explained.toml keeps what was found";
    else if (f.have_diag && f.dg.significant && !f.dg.candidates.empty())
      f.next = "auger fit " + log + model_arg + " --add " + f.dg.candidates.front().fitted.effect +
               " --out fitted.toml, or auger report " + log + model_arg + " --out " + typed(out_dir) +
               " --explain (effects added until only noise is left)";
    else if (f.have_diag)
      f.next = "nothing is missing: the model file in use is fine for this log (auger compare " + log + model_arg + ")";
    else
      f.next = "auger report " + log + model_arg + " --out " + typed(out_dir) + " (with diagnose: which effect is missing)";
    if (const std::string better = terrain_next(d, tc, "report", out_arg); !better.empty())
      f.next = better + "; or " + f.next;

    step("plots");
    std::vector<Section> sections = {summary_section(f, gp, charts), model_section(f, gp, charts), error_section(f, charts)};
    if (f.have_diag) sections.push_back(ranking_section(f, gp));
    if (f.have_explain) sections.push_back(explain_section(f, charts));
    if (!d.online_value.empty()) sections.push_back(online_section(f, charts));
    if (!f.after_name.empty()) {
      sections.push_back(before_after_section(f, charts));
      sections.push_back(effect_section(f, charts));
    }
    const int n_plots = gp.plots();

    // ---- the page
    const std::string page_path = out_dir + "/index.html";
    {
      std::ofstream page(page_path);
      page << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>auger report: "
           << html_escape(d.path) << "</title><style>" << kStyle << charts.style() << "</style></head><body>\n"
           << "<h1>auger report: " << html_escape(d.path) << "</h1>\n<nav>";
      for (const auto& s : sections) page << "<a href=\"#" << s.id << "\">" << s.title << "</a>";
      page << zoom_link("time", 1, 0, "zoom out") << "</nav>\n";
      for (const auto& s : sections) page << "<section id=\"" << s.id << "\"><h2>" << s.title << "</h2>\n" << s.html << "</section>\n";
      page << "<p><small>Written by auger report; every number comes from the same engine as auger compare / "
              "diagnose / fit / explain (docs/workbench.md, docs/workbench-tools.md).</small></p>\n"
           << charts.scripts() << "</body></html>\n";
      if (!page) {
        page.close();
        std::remove(page_path.c_str());
        std::fprintf(stderr, "auger report: cannot write '%s'\n", page_path.c_str());
        return 2;
      }
    }
    dir.done = true;
    if (json) {
      Json j;
      j.begin_object().str("command", "report").str("log", d.path).str("out", page_path);
      j.num("plots", n_plots).num("charts", charts.count());
      j.begin_array("sections");
      for (const auto& s : sections) j.str(nullptr, s.id);
      j.end_array();
      json_terrain(j, tc);
      j.channels("noise_floor", f.cmp.noise_floor, d.active);
      j.begin_object("segments").channels("rms", f.cmp.segments_err.rms, d.active).end_object();
      if (f.have_diag) j.boolean("significant", f.dg.significant);
      if (f.have_explain) j.str("explain_verdict", f.ex.verdict);
      if (!f.after_name.empty()) {
        j.str("effect_added", f.after_name);
        j.begin_object("after").channels("rms", f.after.segments_err.rms, d.active)
            .channels("ratio_to_noise", f.after.segments_err.ratio_to_noise, d.active).end_object();
      }
      if (!d.online_value.empty()) {
        // The online estimate at the log's end against the offline fit (report_online.hpp).
        j.begin_array("online");
        for (const OnlineAgreement& o : online_agreement(d, d.size() - 1, f.offline))
          j.begin_object().str("name", o.name).str("unit", o.unit).num("online", o.online).num("online_sd", o.online_sd)
              .num("offline", o.offline).num("offline_sd", o.offline_sd).boolean("held", o.held)
              .boolean("informed", o.informed).num("z", o.z).end_object();
        j.end_array();
      }
      j.begin_array("warnings");
      for (const auto& w : f.warnings) j.str(nullptr, w);
      j.end_array();
      j.str("next", f.next);
      j.end_object();
      std::printf("%s\n", j.text().c_str());
    } else {
      std::printf("auger report: wrote %s (%zu sections, %d interactive time plots, %d SVG plots); open it in a "
                  "browser (it needs no network)\nnext: %s\n",
                  page_path.c_str(), sections.size(), charts.count(), n_plots, f.next.c_str());
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger report: %s\n", e.what());
    return 2;
  }
}

}  // namespace auger::wb
