// `auger report LOG --out DIR [--model FILE] [--effect ID] [--no-diagnose] [--json]`: one
// self-contained HTML page (DIR/index.html: inline SVG from gnuplot, inline CSS, no external
// reference) with what compare, diagnose and fit find (the engine, workbench.hpp).
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "args.hpp"
#include "checks.hpp"
#include "commands.hpp"
#include "report_plot.hpp"
#include "workbench.hpp"

namespace auger::wb {
namespace {

constexpr std::size_t kMaxPlotPoints = 4000;  // per series: enough for 900 px, small SVG

std::string esc(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '&': o += "&amp;"; break;
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '"': o += "&quot;"; break;
      default: o += c;
    }
  }
  return o;
}

// Numbers to 6 significant digits: what a reader needs; the test holds them to compare --json.
std::string num(double v) {
  if (!std::isfinite(v)) return "&ndash;";
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

std::string fixed(double v, int digits) {
  if (!std::isfinite(v)) return "&ndash;";
  char b[32];
  std::snprintf(b, sizeof b, "%.*f", digits, v);
  return b;
}

std::vector<int> active_channels(const Dataset& d) {
  std::vector<int> c;
  for (int k = 0; k < kChannels; ++k)
    if (d.active[static_cast<std::size_t>(k)]) c.push_back(k);
  return c;
}

// Prediction minus measurement in noise floors (headings wrapped), NaN where either is missing.
std::vector<double> error_ratio(const Dataset& d, const Prediction& p, const ChannelValues& noise, int c) {
  std::vector<double> e(d.size(), kNaN);
  const auto cc = static_cast<std::size_t>(c);
  if (p.pred.size() != d.size()) return e;
  for (std::size_t k = 0; k < d.size(); ++k) {
    const double m = d.meas[k][cc], q = p.pred[k][cc];
    if (!std::isfinite(m) || !std::isfinite(q)) continue;
    const double err = c >= kPsi ? wrap_angle(q - m) : q - m;
    e[k] = err / noise[cc];
  }
  return e;
}

// A prediction series for plotting: headings unwrapped so the curve has no 2 pi jumps.
std::vector<double> predicted(const Dataset& d, const Prediction& p, int c) {
  std::vector<double> v(d.size(), kNaN);
  const auto cc = static_cast<std::size_t>(c);
  if (p.pred.size() != d.size()) return v;
  double prev = kNaN;
  for (std::size_t k = 0; k < d.size(); ++k) {
    double q = p.pred[k][cc];
    if (c >= kPsi && std::isfinite(q) && std::isfinite(prev)) q = prev + wrap_angle(q - prev);
    if (std::isfinite(q)) prev = q;
    v[k] = q;
  }
  return v;
}

// The measured heading drawn on the model's branch (model + wrapped difference), so measured
// and model curves of psi are comparable across +-pi.
std::vector<double> measured(const Dataset& d, const std::vector<double>& model_curve, int c) {
  std::vector<double> v(d.size(), kNaN);
  const auto cc = static_cast<std::size_t>(c);
  for (std::size_t k = 0; k < d.size(); ++k) {
    const double m = d.meas[k][cc];
    if (!std::isfinite(m)) continue;
    v[k] = c >= kPsi && std::isfinite(model_curve[k]) ? model_curve[k] + wrap_angle(m - model_curve[k]) : m;
  }
  return v;
}

// Rows kept for a plot: the measured samples (decimated), or every sample for model curves.
std::vector<std::vector<double>> pick(const std::vector<std::size_t>& idx, const std::vector<std::vector<double>>& cols) {
  std::vector<std::vector<double>> out(cols.size());
  for (std::size_t c = 0; c < cols.size(); ++c)
    for (std::size_t i : idx) out[c].push_back(cols[c][i]);
  return out;
}

std::vector<std::size_t> finite_rows(const std::vector<double>& v) {
  std::vector<std::size_t> idx;
  for (std::size_t k = 0; k < v.size(); ++k)
    if (std::isfinite(v[k])) idx.push_back(k);
  return idx;
}

std::vector<std::size_t> thin(const std::vector<std::size_t>& idx, std::size_t max_points) {
  if (idx.size() <= max_points) return idx;
  std::vector<std::size_t> out;
  const std::size_t step = (idx.size() + max_points - 1) / max_points;
  for (std::size_t i = 0; i < idx.size(); i += step) out.push_back(idx[i]);
  return out;
}

// The worst windows as shaded rectangles behind a time plot.
std::string window_marks(const std::vector<Window>& worst) {
  std::ostringstream s;
  int n = 0;
  for (const auto& w : worst) {
    ++n;
    s << "set object " << n << " rect from " << w.t_start_s << ", graph 0 to " << w.t_end_s
      << ", graph 1 behind fillcolor rgb '#f4c7c3' fillstyle solid 0.6 noborder\n";
    s << "set label " << n << " '" << n << ": " << channel_name(w.dof) << "' at " << w.t_start_s
      << ", graph 0.95 front font ',9'\n";
  }
  return s.str();
}

struct Section {
  std::string id, title, html;
};

void stats_rows(std::ostringstream& h, const char* id, const char* label, const ErrorStats& e, const Dataset& d) {
  h << "<tr><th>" << label << "</th>";
  for (int c : active_channels(d)) {
    const auto cc = static_cast<std::size_t>(c);
    h << "<td id=\"" << id << "-rms-" << channel_name(c) << "\">" << num(e.rms[cc]) << "</td>"
      << "<td id=\"" << id << "-ratio-" << channel_name(c) << "\">" << num(e.ratio_to_noise[cc]) << "</td>";
  }
  h << "</tr>\n";
}

std::string channel_header(const Dataset& d, const char* first) {
  std::ostringstream h;
  h << "<tr><th>" << first << "</th>";
  for (int c : active_channels(d))
    h << "<th>" << channel_name(c) << " RMS (" << channel_unit(c) << ")</th><th>" << channel_name(c)
      << " / noise</th>";
  h << "</tr>\n";
  return h.str();
}

const char* kStyle =
    "body{font-family:sans-serif;max-width:1000px;margin:1em auto;padding:0 1em;color:#222}"
    "table{border-collapse:collapse;margin:0.5em 0 1em}td,th{border:1px solid #ccc;padding:2px 6px;"
    "text-align:right;font-size:90%}th{background:#f3f3f3}td.l,th.l{text-align:left}"
    "figure{margin:0.5em 0}figcaption{font-size:85%;color:#555}svg{max-width:100%;height:auto}"
    "nav a{margin-right:1em}.warn{color:#a40}";

int report_usage(std::FILE* f, int code) {
  std::fprintf(f,
               "usage: auger report LOG --out DIR [--model FILE] [--effect ID] [--no-diagnose] [--json]\n"
               "  writes DIR/index.html, one self-contained page (opens offline): measured vs model for\n"
               "  x, y, psi and the path; the error over time with the worst windows; the candidate\n"
               "  ranking of diagnose; before/after curves with the best effect (or --effect ID) added.\n"
               "  The plots are drawn by gnuplot ($AUGER_GNUPLOT or gnuplot on PATH; Debian gnuplot-nox).\n");
  return code;
}

// The output directory: created for this report if it does not exist; a report that fails
// leaves nothing behind (the directory it created is removed, a directory that existed keeps
// what it had: the page is written last, in one piece).
struct OutputDir {
  std::string path;
  bool created = false;
  bool done = false;
  bool make() {
    struct stat st {};
    if (stat(path.c_str(), &st) == 0) return S_ISDIR(st.st_mode);
    if (mkdir(path.c_str(), 0755) != 0) return false;
    created = true;
    return true;
  }
  ~OutputDir() {
    if (!done && created) rmdir(path.c_str());
  }
};

// What the engine found: everything a section draws from.
struct Findings {
  explicit Findings(const Dataset& data) : d(data) {}
  const Dataset& d;
  std::vector<int> chans;  // active channels
  CompareResult cmp;
  bool have_diag = false;
  DiagnoseResult dg;
  bool effect_given = false;  // --effect ID, not diagnose's first candidate
  std::string effect;         // the effect added for before/after ("" = none)
  FitResult ft;
  CompareResult after;  // compare() of the fitted model
};

const char* kTimeLabel = "set xlabel 't (s)'\n";

// Summary: the log, the model, the noise floor and compare's errors.
Section summary_section(const Findings& f, Gnuplot& gp) {
  const Dataset& d = f.d;
  const CompareResult& cmp = f.cmp;
  const std::vector<int>& chans = f.chans;
  std::ostringstream h;
  h << "<table><tr><th class=l>log</th><td class=l>" << esc(d.path) << "</td></tr>"
    << "<tr><th class=l>kind</th><td class=l>" << (d.gantry ? "gantry (" + esc(d.axis) + ")" : "robot") << "</td></tr>"
    << "<tr><th class=l>duration</th><td class=l>" << fixed(d.duration_s(), 1) << " s, " << d.size() << " samples</td></tr>"
    << "<tr><th class=l>model</th><td class=l>" << esc(cmp.model.source) << ", terrain " << esc(cmp.model.terrain) << "</td></tr>"
    << "<tr><th class=l>plots</th><td class=l>" << esc(gp.version()) << "</td></tr></table>\n";
  h << "<p>Noise floor estimated from the data (every error below is also shown as a multiple of it):</p><table><tr>";
  for (int c : chans) h << "<th>" << channel_name(c) << " (" << channel_unit(c) << ")</th>";
  h << "</tr><tr>";
  for (int c : chans)
    h << "<td id=\"noise-" << channel_name(c) << "\">" << num(cmp.noise_floor[static_cast<std::size_t>(c)]) << "</td>";
  h << "</tr></table>\n<table>" << channel_header(d, "run");
  stats_rows(h, "open_loop", "open loop (Table 4)", cmp.open_loop_err, d);
  stats_rows(h, "segments", "segments of 25 s", cmp.segments_err, d);
  if (d.active[kImuPsi]) stats_rows(h, "imu_heading", "IMU heading (Fig. 9)", cmp.imu_heading_err, d);
  stats_rows(h, "one_step", "one step ahead", cmp.one_step_err, d);
  h << "</table>\n";
  return {"summary", "Summary", h.str()};
}

// Measured vs model over time, and the path in the plane.
Section model_section(const Findings& f, Gnuplot& gp) {
  const Dataset& d = f.d;
  const CompareResult& cmp = f.cmp;
  const std::vector<int>& chans = f.chans;
  std::ostringstream script, h;
  script << "set multiplot layout " << chans.size() << ",1\nset key inside top right horizontal font ',9'\n";
  for (int c : chans) {
    const auto seg = predicted(d, cmp.segments, c), ol = predicted(d, cmp.open_loop, c);
    const auto meas = measured(d, seg, c);
    const auto model_rows = decimate(d.t_s, seg, kMaxPlotPoints, false);
    const auto meas_rows = thin(finite_rows(meas), kMaxPlotPoints);
    const std::string fm = gp.data(std::string("meas_") + channel_name(c), pick(meas_rows, {d.t_s, meas}));
    const std::string fs = gp.data(std::string("model_") + channel_name(c), pick(model_rows, {d.t_s, seg, ol}));
    script << (c == chans.back() ? kTimeLabel : "unset xlabel\n") << "set ylabel '" << channel_name(c) << " ("
           << channel_unit(c) << ")'\n"
           << "plot " << fm << " using 1:2 with points pt 7 ps 0.25 lc rgb '#777777' title 'measured', "
           << fs << " using 1:2 with lines lw 1.5 lc rgb '#1f77b4' title 'model, segments of 25 s', "
           << fs << " using 1:3 with lines lw 1 dt 2 lc rgb '#d62728' title 'model, open loop'\n";
  }
  script << "unset multiplot\n";
  h << "<figure>" << gp.svg("time", script.str(), 900, 200 * static_cast<int>(chans.size()) + 60)
    << "<figcaption>Measured pose (grey points) and the model run from the measured screw speeds: "
       "re-initialised from the measured pose every 25 s (blue) and open loop from the first pose "
       "(red, dashed).</figcaption></figure>\n";
  if (d.active[kX] && d.active[kY]) {
    const auto sx = predicted(d, cmp.segments, kX), sy = predicted(d, cmp.segments, kY);
    const auto ox = predicted(d, cmp.open_loop, kX), oy = predicted(d, cmp.open_loop, kY);
    std::vector<double> mx(d.size(), kNaN), my(d.size(), kNaN);
    for (std::size_t k = 0; k < d.size(); ++k)
      if (std::isfinite(d.meas[k][kX]) && std::isfinite(d.meas[k][kY])) mx[k] = d.meas[k][kX], my[k] = d.meas[k][kY];
    const std::string fm = gp.data("path_meas", pick(thin(finite_rows(mx), kMaxPlotPoints), {mx, my}));
    const std::string fs = gp.data("path_model", pick(decimate(d.t_s, sx, kMaxPlotPoints, false), {sx, sy, ox, oy}));
    std::ostringstream ps;
    ps << "set size ratio -1\nset xlabel 'x (m)'\nset ylabel 'y (m)'\n"
       << "plot " << fm << " using 1:2 with points pt 7 ps 0.25 lc rgb '#777777' title 'measured', " << fs
       << " using 1:2 with lines lw 1.5 lc rgb '#1f77b4' title 'model, segments', " << fs
       << " using 3:4 with lines lw 1 dt 2 lc rgb '#d62728' title 'model, open loop'\n";
    h << "<figure>" << gp.svg("path", ps.str(), 700, 600)
      << "<figcaption>The path in the plane (world frame, x forward, y left at the start).</figcaption></figure>\n";
  }
  return {"measured-vs-model", "Measured vs model", h.str()};
}

// The error over time with the worst windows marked, and by regime.
Section error_section(const Findings& f, Gnuplot& gp) {
  const Dataset& d = f.d;
  const CompareResult& cmp = f.cmp;
  const std::vector<int>& chans = f.chans;
  std::ostringstream script, h;
  script << kTimeLabel << "set ylabel 'error / noise floor'\n" << window_marks(cmp.worst) << "plot ";
  bool first = true;
  for (int c : chans) {
    const auto e = error_ratio(d, cmp.segments, cmp.noise_floor, c);
    const auto rows = decimate(d.t_s, e, kMaxPlotPoints, true);
    std::vector<std::size_t> keep;
    for (std::size_t k : rows)
      if (std::isfinite(e[k])) keep.push_back(k);
    script << (first ? "" : ", ") << gp.data(std::string("err_") + channel_name(c), pick(keep, {d.t_s, e}))
           << " using 1:2 with lines lw 1 title '" << channel_name(c) << "'";
    first = false;
  }
  script << "\n";
  h << "<figure>" << gp.svg("error", script.str())
    << "<figcaption>Model minus measurement (segments of 25 s) in multiples of each channel's noise floor; "
       "the shaded bands are the worst 5 s windows (each simulated from its own measured start pose, "
       "so they show what acts inside them), numbered as in the table.</figcaption></figure>\n";
  h << "<table><tr><th>#</th><th>t start (s)</th><th>t end (s)</th><th>DOF</th><th>RMS</th><th>/ noise</th></tr>\n";
  int n = 0;
  for (const auto& w : cmp.worst) {
    ++n;
    h << "<tr><td>" << n << "</td><td id=\"worst-" << n << "-t_start_s\">" << num(w.t_start_s) << "</td><td>"
      << num(w.t_end_s) << "</td><td>" << channel_name(w.dof) << "</td><td>" << num(w.rms) << " "
      << channel_unit(w.dof) << "</td><td id=\"worst-" << n << "-ratio\">" << num(w.ratio_to_noise) << "</td></tr>\n";
  }
  h << "</table>\n<p>Error by regime (segments of 25 s, multiples of the noise floor):</p><table><tr>"
       "<th class=l>kind</th><th class=l>regime</th><th>seconds</th>";
  for (int c : chans) h << "<th>" << channel_name(c) << "</th>";
  h << "</tr>\n";
  for (const auto& g : cmp.regimes) {
    h << "<tr><td class=l>" << esc(g.kind) << "</td><td class=l>" << esc(g.label) << "</td><td>" << fixed(g.seconds, 1)
      << "</td>";
    for (int c : chans) h << "<td>" << fixed(g.ratio_to_noise[static_cast<std::size_t>(c)], 2) << "</td>";
    h << "</tr>\n";
  }
  h << "</table>\n";
  return {"error", "Error over time and where the model fails", h.str()};
}

// diagnose's candidates, ranked.
Section ranking_section(const Findings& f, Gnuplot& gp) {
  std::ostringstream h, script;
  h << "<p>" << (f.dg.significant ? "" : "<span class=warn>Not significant:</span> ") << esc(f.dg.verdict) << "</p>\n";
  h << "<table><tr><th>rank</th><th class=l>effect</th><th class=l>fitted</th><th>&Delta;BIC</th>"
       "<th>held-out / noise</th><th>near tie</th></tr>\n";
  std::ostringstream block;
  int rank = 0;
  for (const auto& c : f.dg.candidates) {
    ++rank;
    h << "<tr><td>" << rank << "</td><td class=l id=\"candidate-" << rank << "\">" << esc(c.fitted.effect)
      << "</td><td class=l>" << esc(c.fitted.description);
    for (const auto& p : c.fitted.params)
      h << "<br>" << esc(p.name) << " = " << num(p.value) << (std::isfinite(p.sigma) ? " &plusmn; " + num(p.sigma) : "")
        << " " << esc(p.unit);
    h << "</td><td id=\"candidate-" << rank << "-delta_bic\">" << num(c.delta_bic) << "</td><td>"
      << num(c.heldout_ratio) << "</td><td>" << (c.near_tie ? "yes: " + esc(c.tell_apart) : "") << "</td></tr>\n";
    if (rank <= 12) block << rank << " \"" << c.fitted.effect << "\" " << (std::isfinite(c.delta_bic) ? c.delta_bic : 0) << "\n";
  }
  h << "</table>\n";
  if (!f.dg.candidates.empty()) {
    script << "$ranking << EOD\n" << block.str() << "EOD\n"
           << "set style fill solid 0.7\nset boxwidth 0.7\nset xtics rotate by -35 font ',9'\nunset key\n"
           << "set ylabel 'delta BIC vs the nominal model (lower is better)'\n"
           << "plot $ranking using 1:3:xtic(2) with boxes lc rgb '#1f77b4'\n";
    h << "<figure>" << gp.svg("ranking", script.str(), 900, 420)
      << "<figcaption>The candidates of diagnose, best first: each effect fitted on the training part, "
         "ranked by an information criterion with the effective sample size.</figcaption></figure>\n";
  }
  if (!f.dg.where.empty()) {
    h << "<p>Where what remains after the best candidate is largest:</p><table><tr><th>t start (s)</th>"
         "<th>t end (s)</th><th>DOF</th><th>/ noise</th></tr>\n";
    for (const auto& w : f.dg.where)
      h << "<tr><td>" << num(w.t_start_s) << "</td><td>" << num(w.t_end_s) << "</td><td>" << channel_name(w.dof)
        << "</td><td>" << num(w.ratio_to_noise) << "</td></tr>\n";
    h << "</table>\n";
  }
  return {"ranking", "Candidate ranking (diagnose)", h.str()};
}

// Before and after adding the best (or the given) effect.
Section before_after_section(const Findings& f, Gnuplot& gp) {
  const Dataset& d = f.d;
  const CompareResult& cmp = f.cmp;
  const std::vector<int>& chans = f.chans;
  std::ostringstream h, script;
  if (f.have_diag && !f.dg.significant && !f.effect_given)
    h << "<p class=warn>diagnose found nothing significant: the top candidate is shown for "
         "completeness, not as a finding.</p>\n";
  h << "<p>Effect added: <b id=\"best-effect\">" << esc(f.effect) << "</b>";
  for (const auto& e : f.ft.effects) {
    h << "<br>" << esc(e.effect) << ": " << esc(e.description);
    for (const auto& p : e.params) h << "; " << esc(p.name) << " = " << num(p.value) << " " << esc(p.unit);
  }
  h << "</p>\n<table>" << channel_header(d, "model");
  stats_rows(h, "before", "before (nominal)", f.ft.err_before, d);
  stats_rows(h, "after", ("after (+ " + f.effect + ")").c_str(), f.ft.err_after, d);
  h << "</table>\n";
  script << "set multiplot layout " << chans.size() << ",1\nset key inside top right horizontal font ',9'\n";
  for (int c : chans) {
    const auto eb = error_ratio(d, cmp.segments, cmp.noise_floor, c);
    const auto ea = error_ratio(d, f.after.segments, cmp.noise_floor, c);
    const auto rows = decimate(d.t_s, eb, kMaxPlotPoints, true);
    std::vector<std::size_t> keep;
    for (std::size_t k : rows)
      if (std::isfinite(eb[k]) || std::isfinite(ea[k])) keep.push_back(k);
    const std::string file = gp.data(std::string("ba_") + channel_name(c), pick(keep, {d.t_s, eb, ea}));
    script << (c == chans.back() ? kTimeLabel : "unset xlabel\n") << "set ylabel '" << channel_name(c) << " error / noise'\n"
           << "plot " << file << " using 1:2 with lines lw 1 lc rgb '#bbbbbb' title 'before', " << file
           << " using 1:3 with lines lw 1.2 lc rgb '#2ca02c' title 'after'\n";
  }
  script << "unset multiplot\n";
  h << "<figure>" << gp.svg("before_after", script.str(), 900, 180 * static_cast<int>(chans.size()) + 60)
    << "<figcaption>The error (segments of 25 s, in noise floors) of the nominal model (grey) and with "
    << esc(f.effect) << " fitted (green).</figcaption></figure>\n";
  return {"before-after", "Before and after adding the best effect", h.str()};
}

}  // namespace

int run_report(int argc, char** argv) {
  Args a;
  if (!parse_args(argc, argv, {"--json", "--help", "--no-diagnose"}, {"--out", "--model", "--effect"}, a)) return 2;
  if (a.has("--help")) return report_usage(stdout, 0);
  if (a.positional.size() != 1 || !a.has("--out")) return report_usage(stderr, 2);
  const std::string out_dir = a.get("--out");
  const bool json = a.has("--json");
  const bool progress = isatty(STDERR_FILENO);
  auto step = [&](const char* what) {
    if (progress) std::fprintf(stderr, "auger report: %s\n", what);
  };

  try {
    const Dataset d = load_dataset(a.positional[0]);  // bad input first: exit 2 naming the line
    const bool search = !a.has("--no-diagnose") || a.has("--effect");
    if (search) require_fit_data(d, "report");
    const ModelChoice mc = choose_model(d, a.get("--model"));
    Gnuplot gp;  // then a missing gnuplot, before the work
    OutputDir dir{out_dir};
    if (!dir.make()) {
      std::fprintf(stderr, "auger report: cannot create directory '%s': %s\n", out_dir.c_str(), std::strerror(errno));
      return 2;
    }
    step("compare");
    Findings f(d);
    f.cmp = compare(d, mc);
    require_noise_floor(d, f.cmp.noise_floor);
    require_finite(d, f.cmp.segments_err, mc, "segments of 25 s");
    f.chans = active_channels(d);
    f.effect = a.get("--effect");
    f.effect_given = !f.effect.empty();
    if (!a.has("--no-diagnose")) {
      step("diagnose (every library effect; this is the slow part)");
      DiagnoseOptions o;
      o.progress = progress;
      f.dg = diagnose(d, mc, o);
      f.have_diag = true;
      if (f.effect.empty() && !f.dg.candidates.empty()) f.effect = f.dg.candidates.front().fitted.effect;
    }
    if (!f.effect.empty()) {
      step(("fit --add " + f.effect).c_str());
      f.ft = fit(d, mc, {f.effect}, progress);
      f.after = compare(d, f.ft.after);
    }

    step("plots (gnuplot)");
    std::vector<Section> sections = {summary_section(f, gp), model_section(f, gp), error_section(f, gp)};
    if (f.have_diag) sections.push_back(ranking_section(f, gp));
    if (!f.effect.empty()) sections.push_back(before_after_section(f, gp));
    const int n_plots = gp.plots();

    // ---- the page
    const std::string page_path = out_dir + "/index.html";
    {
      std::ofstream page(page_path);
      page << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>auger report: " << esc(d.path)
        << "</title><style>" << kStyle << "</style></head><body>\n<h1>auger report</h1>\n<nav>";
      for (const auto& s : sections) page << "<a href=\"#" << s.id << "\">" << s.title << "</a>";
      page << "</nav>\n";
      for (const auto& s : sections) page << "<section id=\"" << s.id << "\"><h2>" << s.title << "</h2>\n" << s.html << "</section>\n";
      page << "<p><small>Written by auger report; every number comes from the same engine as auger compare / "
           "diagnose / fit (docs/workbench.md).</small></p></body></html>\n";
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
      j.num("plots", n_plots);
      j.begin_array("sections");
      for (const auto& s : sections) j.str(nullptr, s.id);
      j.end_array();
      j.channels("noise_floor", f.cmp.noise_floor, d.active);
      j.begin_object("segments").channels("rms", f.cmp.segments_err.rms, d.active).end_object();
      if (f.have_diag) j.boolean("significant", f.dg.significant);
      if (!f.effect.empty()) j.str("effect_added", f.effect);
      j.end_object();
      std::printf("%s\n", j.text().c_str());
    } else {
      std::printf("auger report: wrote %s (%d plots, %zu sections)\n", page_path.c_str(), n_plots, sections.size());
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "auger report: %s\n", e.what());
    return 2;
  }
}

}  // namespace auger::wb
