// The sections of `auger report`'s page (report.hpp): tables from the engine's results, time
// plots as linked dygraphs charts, the path and the candidates as gnuplot SVG.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "cli_text.hpp"
#include "report.hpp"
#include "report_effect.hpp"

namespace auger::wb {

namespace {

std::string esc(const std::string& s) { return html_escape(s); }

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

constexpr const char* kTimeGroup = "time";
const char* const kMeasured = "#777777";
const char* const kSegments = "#1f77b4";
const char* const kOpenLoop = "#d62728";
const char* const kAfter = "#2ca02c";

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

// The rows where a run restarted from the measured pose ends: each run is a line of its own, so
// no chord joins one run's end to the next one's start (ChartSeries::breaks, and a NaN row for
// the path's gnuplot lines).
std::vector<std::size_t> restarts(const Dataset& d, const Prediction& p) {
  std::vector<std::size_t> rows;
  for (std::size_t i = 1; i < p.segment_start.size(); ++i)
    if (p.segment_start[i] > 0 && p.segment_start[i] < d.size()) rows.push_back(p.segment_start[i] - 1);
  return rows;
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

std::string channel_label(int c) { return std::string(channel_name(c)) + " (" + channel_unit(c) + ")"; }

// A chart of one channel over the log's time, in the page's linked group.
Chart time_chart(const Dataset& d, int c, const std::string& what, const std::string& ylabel) {
  Chart ch;
  ch.title = std::string(channel_name(c)) + ": " + what;
  ch.xlabel = "t (s)";
  ch.ylabel = ylabel;
  ch.x = d.t_s;
  ch.group = kTimeGroup;
  return ch;
}

std::string error_label(int c) { return std::string(channel_name(c)) + " error (times the noise floor)"; }

void stats_rows(std::ostringstream& h, const char* id, const std::string& label, const ErrorStats& e, const Dataset& d) {
  h << "<tr><th class=l>" << esc(label) << "</th>";
  for (int c = 0; c < kChannels; ++c) {
    if (!d.active[static_cast<std::size_t>(c)]) continue;
    const auto cc = static_cast<std::size_t>(c);
    h << "<td id=\"" << id << "-rms-" << channel_name(c) << "\">" << num(e.rms[cc]) << "</td>"
      << "<td id=\"" << id << "-ratio-" << channel_name(c) << "\">" << num(e.ratio_to_noise[cc]) << "</td>";
  }
  h << "</tr>\n";
}

std::string channel_header(const Dataset& d, const char* first) {
  std::ostringstream h;
  h << "<tr><th class=l>" << first << "</th>";
  for (int c = 0; c < kChannels; ++c)
    if (d.active[static_cast<std::size_t>(c)])
      h << "<th>" << channel_name(c) << " RMS (" << channel_unit(c) << ")</th><th>" << channel_name(c)
        << " (times the noise floor)</th>";
  h << "</tr>\n";
  return h.str();
}

// Parameters with their uncertainty and flags, for a table cell.
std::string params_html(const FittedEffect& e) {
  std::ostringstream h;
  for (const auto& p : e.params) {
    h << "<br>" << esc(p.name) << " = " << num(p.value);
    if (std::isfinite(p.sigma)) {
      char b[32];
      std::snprintf(b, sizeof b, "%.2g", p.sigma);  // an uncertainty to two digits
      h << " &plusmn; " << b;
    }
    if (!p.unit.empty() && p.unit != "-") h << " " << esc(p.unit);
    if (!p.flag.empty()) h << " <span class=flag>FLAG: " << esc(p.flag) << "</span>";
  }
  return h.str();
}

std::string next_html(const std::string& next) {
  return "<p class=next>Next: <code>" + esc(next) + "</code></p>\n";
}

}  // namespace

// ---------------------------------------------------------------- summary
Section summary_section(const Findings& f, const Gnuplot& gp, const ChartSet& charts) {
  const Dataset& d = f.d;
  const CompareResult& cmp = f.cmp;
  std::ostringstream h;
  for (const auto& w : f.warnings) h << "<p class=warn>Warning: " << esc(w) << "</p>\n";
  if (f.have_explain) h << "<p class=verdict><b>auger explain:</b> " << esc(f.ex.verdict) << "</p>\n";
  else if (f.have_diag) h << "<p class=verdict><b>auger diagnose:</b> " << esc(f.dg.verdict) << "</p>\n";
  h << next_html(f.next);
  h << "<table><tr><th class=l>log</th><td class=l>" << esc(d.path) << "</td></tr>"
    << "<tr><th class=l>kind</th><td class=l>" << (d.gantry ? "gantry (" + esc(d.axis) + ")" : "robot") << "</td></tr>"
    << "<tr><th class=l>duration</th><td class=l>" << fixed(d.duration_s(), 1) << " s, " << d.size() << " samples</td></tr>"
    << "<tr><th class=l>model</th><td class=l>" << esc(cmp.model.source) << "</td></tr>"
    << "<tr><th class=l>terrain</th><td class=l id=terrain>" << esc(f.terrain) << "</td></tr>"
    << "<tr><th class=l>plots</th><td class=l>time plots: dygraphs (" << esc(charts.source()) << "), others: "
    << esc(gp.version()) << "</td></tr></table>\n";
  h << "<p>Noise floor estimated from the data (every error below is also given as a multiple of it; 1 = only noise "
       "left):</p><table><tr>";
  for (int c : f.chans) h << "<th>" << esc(channel_label(c)) << "</th>";
  h << "</tr><tr>";
  for (int c : f.chans)
    h << "<td id=\"noise-" << channel_name(c) << "\">" << num(cmp.noise_floor[static_cast<std::size_t>(c)]) << "</td>";
  h << "</tr></table>\n<table>" << channel_header(d, "run");
  stats_rows(h, "open_loop", "open loop (Table 4)", cmp.open_loop_err, d);
  stats_rows(h, "segments", "segments of 25 s", cmp.segments_err, d);
  if (d.active[kImuPsi]) stats_rows(h, "imu_heading", "IMU heading (Fig. 9)", cmp.imu_heading_err, d);
  stats_rows(h, "one_step", "one step ahead", cmp.one_step_err, d);
  h << "</table>\n";
  return {"summary", "Summary", h.str()};
}

// ---------------------------------------------------------------- measured vs model
Section model_section(const Findings& f, Gnuplot& gp, ChartSet& charts) {
  const Dataset& d = f.d;
  const CompareResult& cmp = f.cmp;
  std::ostringstream h;
  h << "<p>Measured pose (grey points) and the model run from the measured screw speeds: re-initialised from the "
       "measured pose every 25 s (blue) and open loop from the first pose (red, dashed). Drag to zoom (the time "
       "plots of the page follow), shift-drag to pan, double-click to zoom out; "
    << zoom_link(kTimeGroup, 1, 0, "whole log") << ".</p>\n";
  for (int c : f.chans) {
    Chart ch = time_chart(d, c, "measured and model", channel_label(c));
    const auto seg = predicted(d, cmp.segments, c), ol = predicted(d, cmp.open_loop, c);
    ch.series = {{"measured", measured(d, seg, c), "points", kMeasured},
                 {"model, segments of 25 s", seg, "line", kSegments, restarts(d, cmp.segments)},
                 {"model, open loop", ol, "dashed", kOpenLoop}};
    h << charts.add(std::move(ch));
  }
  if (d.active[kX] && d.active[kY]) {
    // The canvas takes the path's own aspect ratio (set size ratio -1), so no band of it is empty.
    auto sx = predicted(d, cmp.segments, kX), sy = predicted(d, cmp.segments, kY);
    const auto ox = predicted(d, cmp.open_loop, kX), oy = predicted(d, cmp.open_loop, kY);
    std::vector<double> mx(d.size(), kNaN), my(d.size(), kNaN), ax(d.size(), kNaN), ay(d.size(), kNaN);
    double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
    for (std::size_t k = 0; k < d.size(); ++k)
      if (std::isfinite(d.meas[k][kX]) && std::isfinite(d.meas[k][kY])) {
        mx[k] = d.meas[k][kX], my[k] = d.meas[k][kY];
        x0 = std::min(x0, mx[k]), x1 = std::max(x1, mx[k]), y0 = std::min(y0, my[k]), y1 = std::max(y1, my[k]);
      }
    const bool after = !f.after_name.empty();
    if (after) ax = predicted(d, f.after.segments, kX), ay = predicted(d, f.after.segments, kY);
    std::vector<std::size_t> rows;
    const std::size_t step = std::max<std::size_t>(1, d.size() / 4000);
    for (std::size_t k = 0; k < d.size(); k += step) rows.push_back(k);
    // gnuplot ends a line at an undefined value: one per restart, kept through the thinning.
    auto end_lines = [&](const Prediction& p, std::vector<double>& vx, std::vector<double>& vy) {
      for (std::size_t r : restarts(d, p)) rows.push_back(r), vx[r] = vy[r] = kNaN;
    };
    end_lines(cmp.segments, sx, sy);
    if (after) end_lines(f.after.segments, ax, ay);
    std::sort(rows.begin(), rows.end());
    rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
    auto pick = [&](const std::vector<double>& v) {
      std::vector<double> o;
      for (std::size_t k : rows) o.push_back(v[k]);
      return o;
    };
    const std::string fd = gp.data("path", {pick(mx), pick(my), pick(sx), pick(sy), pick(ox), pick(oy), pick(ax), pick(ay)});
    // The open loop may leave the measured area far behind: the view is the measured path's.
    const double span_x = std::max(x1 - x0, 0.05), span_y = std::max(y1 - y0, 0.05), pad = 0.08;
    const double cx = 0.5 * (x0 + x1), cy = 0.5 * (y0 + y1);
    const int width = 900;
    const int plot_w = width - 110;
    const int height = std::clamp(static_cast<int>(plot_w * span_y / span_x) + 110, 260, 900);
    std::ostringstream ps;
    ps << "set size ratio -1\nset xlabel 'x (m)'\nset ylabel 'y (m)'\nset key outside top center horizontal font ',10'\n"
       << "set xrange [" << cx - (0.5 + pad) * span_x << ":" << cx + (0.5 + pad) * span_x << "]\n"
       << "set yrange [" << cy - (0.5 + pad) * span_y << ":" << cy + (0.5 + pad) * span_y << "]\n"
       << "plot " << fd << " using 1:2 with points pt 7 ps 0.25 lc rgb '" << kMeasured << "' title 'measured', " << fd
       << " using 3:4 with lines lw 1.5 lc rgb '" << kSegments << "' title 'model, segments of 25 s', " << fd
       << " using 5:6 with lines lw 1 dt 2 lc rgb '" << kOpenLoop << "' title 'model, open loop'";
    if (after) ps << ", " << fd << " using 7:8 with lines lw 1.2 lc rgb '" << kAfter << "' title " << gp_quote("after: " + f.after_name + ", segments of 25 s");
    ps << "\n";
    h << "<figure>" << gp.svg("path", ps.str(), width, height)
      << "<figcaption>The path in the plane (world frame, x forward and y left at the start), drawn to scale; the view "
         "is the measured path's (the open loop may leave it).</figcaption></figure>\n";
  }
  return {"measured-vs-model", "Measured vs model", h.str()};
}

// ---------------------------------------------------------------- error over time
Section error_section(const Findings& f, ChartSet& charts) {
  const Dataset& d = f.d;
  const CompareResult& cmp = f.cmp;
  const Model& m = cmp.model.model;
  // The simulation the windows measure (workbench.hpp window_errors): re-initialised every 5 s.
  Prediction win;
  simulate(m, d, window_sim_options(sim_options_for(m), 5.0), win);
  std::ostringstream h;
  h << "<p>The model's error in multiples of each channel's noise floor. The <b>5 s windows</b> are what "
       "&ldquo;where the model fails&rdquo; measures: the model re-initialised from the measured pose at each window's "
       "start (so a window shows what acts inside it, not what accumulated before); the step line is each window's "
       "RMS, the number in the table. The shaded bands are the five worst windows. For comparison, the thin grey "
       "curve is the headline run, re-initialised every 25 s, whose error grows within each segment.</p>\n";
  for (int c : f.chans) {
    const auto cc = static_cast<std::size_t>(c);
    Chart ch = time_chart(d, c, "error in noise floors", error_label(c));
    std::vector<double> step(d.size(), kNaN);
    std::size_t k = 0;
    for (const auto& w : cmp.windows) {
      if (w.dof != c) continue;
      while (k < d.size() && d.t_s[k] < w.t_start_s) ++k;
      for (std::size_t i = k; i < d.size() && d.t_s[i] <= w.t_end_s; ++i)
        if (std::isfinite(d.meas[i][cc])) step[i] = w.ratio_to_noise;
    }
    ch.series = {{"error, re-initialised every 5 s", error_ratio(d, win, cmp.segment_floor, c), "line",
                            "#ff7f0e", restarts(d, win)},
                 {"RMS of each 5 s window", step, "step", "#8c2d04"},
                 {"error, segments of 25 s", error_ratio(d, cmp.segments, cmp.segment_floor, c), "thin",
                            "#aaaaaa", restarts(d, cmp.segments)}};
    int n = 0;
    for (const auto& w : cmp.worst) {
      ++n;
      if (w.dof == c) ch.bands.push_back({w.t_start_s, w.t_end_s, "#" + std::to_string(n)});
    }
    h << charts.add(std::move(ch));
  }
  h << "<p>The worst 5 s windows (click a time to zoom the plots to it):</p>\n<table><tr><th>#</th><th>t start (s)</th>"
       "<th>t end (s)</th><th class=l>channel</th><th>RMS</th><th>RMS (times the noise floor)</th></tr>\n";
  int n = 0;
  for (const auto& w : cmp.worst) {
    ++n;
    h << "<tr><td>" << n << "</td><td id=\"worst-" << n << "-t_start_s\">" << num(w.t_start_s) << "</td><td>"
      << num(w.t_end_s) << "</td><td class=l>" << channel_name(w.dof) << " "
      << zoom_link(kTimeGroup, w.t_start_s - 2.5, w.t_end_s + 2.5, "zoom") << "</td><td>" << num(w.rms) << " "
      << channel_unit(w.dof) << "</td><td id=\"worst-" << n << "-ratio\">" << num(w.ratio_to_noise) << "</td></tr>\n";
  }
  h << "</table>\n<p>Error by regime (segments of 25 s, multiples of the noise floor):</p><table><tr>"
       "<th class=l>kind</th><th class=l>regime</th><th>duration (s)</th>";
  for (int c : f.chans) h << "<th>" << channel_name(c) << "</th>";
  h << "</tr>\n";
  for (const auto& g : cmp.regimes) {
    h << "<tr><td class=l>" << esc(g.kind) << "</td><td class=l>" << esc(g.label) << "</td><td>" << fixed(g.seconds, 1)
      << "</td>";
    for (int c : f.chans) h << "<td>" << fixed(g.ratio_to_noise[static_cast<std::size_t>(c)], 2) << "</td>";
    h << "</tr>\n";
  }
  h << "</table>\n";
  return {"error", "Error over time and where the model fails", h.str()};
}

// ---------------------------------------------------------------- candidates
Section ranking_section(const Findings& f, Gnuplot& gp) {
  const DiagnoseResult& dg = f.dg;
  std::ostringstream h;
  h << "<p>" << (dg.significant ? "" : "<span class=warn>Not significant:</span> ") << esc(dg.verdict) << "</p>\n";
  h << "<p><b>Ranking rule:</b> " << esc(kRankingRule) << ". The held-out error is measured on the segments no fit "
       "has seen (the " << (dg.refits_model ? "model as given" : "nominal model") << ": "
    << fixed(dg.nominal_heldout_ratio, 3) << " times the noise floor); delta BIC is the change of the Bayesian "
       "information criterion against it on the training segments (negative = better), with the effective sample "
       "size (n_eff " << fixed(dg.n_eff, 0) << " of " << fixed(dg.n, 0) << " residuals). A candidate with a large BIC gain "
       "below one with a small gain has a held-out error no better than the model's, or a flagged fit.</p>\n";
  h << "<table><tr><th>rank</th><th class=l>effect</th><th class=l>fitted (value &plusmn; one standard uncertainty)</th>"
       "<th>&Delta;BIC</th><th>held-out error (times the noise floor)</th><th class=l>near tie</th></tr>\n";
  std::ostringstream block;
  int rank = 0;
  bool first = true;
  RankGroup group = RankGroup::kImproves;
  for (const auto& c : dg.candidates) {
    ++rank;
    const RankGroup g = rank_group(c, dg.nominal_heldout_ratio);
    if (first || heading_group(g) != group)
      h << "<tr class=group><td colspan=6 class=l>" << esc(rank_group_words(g)) << "</td></tr>\n";
    first = false;
    group = heading_group(g);
    h << "<tr><td>" << rank << "</td><td class=l id=\"candidate-" << rank << "\">" << esc(c.fitted.effect)
      << "</td><td class=l>" << esc(c.fitted.description) << params_html(c.fitted);
    for (const auto& r : c.refitted) h << "<br><i>refitted with it: " << esc(r.effect) << "</i>" << params_html(r);
    h << "</td><td id=\"candidate-" << rank << "-delta_bic\">" << num(c.delta_bic) << "</td><td>" << fixed(c.heldout_ratio, 3)
      << "</td><td class=l>" << (c.near_tie ? "yes; the experiment that tells it from its neighbour: " + esc(c.tell_apart) : "")
      << "</td></tr>\n";
    std::string label = c.fitted.effect;
    std::replace(label.begin(), label.end(), '"', '\'');
    block << rank << " \"" << label << "\" " << (std::isfinite(c.delta_bic) ? c.delta_bic : 0) << " "
          << (std::isfinite(c.heldout_ratio) ? c.heldout_ratio : 0) << " " << static_cast<int>(g) << "\n";
  }
  h << "</table>\n";
  if (!dg.candidates.empty()) {
    const int n = static_cast<int>(dg.candidates.size());
    std::ostringstream script;
    script << "$ranking << EOD\n" << block.str() << "EOD\n"
           << "set style fill solid 0.75\nset boxwidth 0.7\nunset key\nset xrange [0.4:" << n + 0.6 << "]\n"
           << "set palette defined (0 '#1f77b4', 1 '#ff7f0e', 2 '#999999')\nset cbrange [0:2]\nunset colorbox\n"
           << "set multiplot layout 2,1 margins 0.1,0.93,0.22,0.95 spacing 0,0.04\n"
           << "set xtics format '' scale 0\nset ylabel 'delta BIC (lower is better)'\n"
           << "plot $ranking using 1:3:5 with boxes lc palette\n"
           << "set xtics rotate by -35 font ',9' scale 0\nset ylabel 'held-out error (times the noise floor)'\n"
           << "set yrange [0:*]\n"
           << "plot $ranking using 1:4:5:xtic(2) with boxes lc palette, " << dg.nominal_heldout_ratio
           << " with lines dt 2 lc rgb '#d62728' lw 1.5\nunset multiplot\n";
    h << "<figure>" << gp.svg("ranking", script.str(), std::max(900, 60 * n + 120), 560)
      << "<figcaption>Every candidate of diagnose, in rank order: delta BIC (top) and the held-out error (bottom; the "
         "dashed line is the model without any: "
      << fixed(dg.nominal_heldout_ratio, 3)
      << " times the noise floor). Blue: lowers the held-out error by 2 % or more, plausible fit; orange: lowers it, "
         "but a fitted value is flagged; grey: does not lower it by 2 %.</figcaption></figure>\n";
  }
  if (!dg.where.empty()) {
    h << "<p>Where what remains after the best candidate is largest (5 s windows):</p><table><tr><th>t start (s)</th>"
         "<th>t end (s)</th><th class=l>channel</th><th>RMS</th><th>RMS (times the noise floor)</th></tr>\n";
    for (const auto& w : dg.where)
      h << "<tr><td>" << num(w.t_start_s) << "</td><td>" << num(w.t_end_s) << "</td><td class=l>" << channel_name(w.dof)
        << " " << zoom_link(kTimeGroup, w.t_start_s - 2.5, w.t_end_s + 2.5, "zoom") << "</td><td>" << num(w.rms) << " "
        << channel_unit(w.dof) << "</td><td>" << num(w.ratio_to_noise) << "</td></tr>\n";
    h << "</table>\n";
  }
  return {"ranking", "Candidate ranking (diagnose)", h.str()};
}

// ---------------------------------------------------------------- before and after
Section before_after_section(const Findings& f, ChartSet& charts) {
  const Dataset& d = f.d;
  const CompareResult& cmp = f.cmp;
  std::ostringstream h;
  if (!f.have_explain && f.have_diag && !f.dg.significant && !f.effect_given)
    h << "<p class=warn>diagnose found nothing significant: the top candidate is shown for completeness, not as a "
         "finding.</p>\n";
  h << "<p>Model after: <b id=\"best-effect\">" << esc(f.after_name) << "</b> ("
    << (f.have_explain ? "the model auger explain arrived at" : f.effect_given ? "--effect" : "diagnose's first candidate")
    << ", fitted together with the paper's parameters)</p>\n";
  if (f.have_explain) {
    h << "<p>Its fitted values: the final model in <a href=\"#explain\">the steps of auger explain</a>.</p>\n";
  } else {
    h << "<table><tr><th class=l>effect</th><th class=l>fitted (value &plusmn; one standard uncertainty)</th></tr>\n";
    for (const auto& e : f.after_fitted)
      h << "<tr><td class=l>" << esc(e.effect) << "</td><td class=l>" << esc(e.description) << params_html(e) << "</td></tr>\n";
    h << "</table>\n";
  }
  h << "<table>" << channel_header(d, "model (segments of 25 s)");
  stats_rows(h, "before", "before (" + cmp.model.source + ")", cmp.segments_err, d);
  stats_rows(h, "after", "after (+ " + f.after_name + ")", f.after.segments_err, d);
  h << "</table>\n<p>The pose, measured (grey) and the model before (blue) and after (green), each re-initialised "
       "every 25 s; then the error of both in noise floors.</p>\n";
  for (int c : f.chans) {
    Chart ch = time_chart(d, c, "before and after", channel_label(c));
    const auto before = predicted(d, cmp.segments, c), after = predicted(d, f.after.segments, c);
    ch.series = {{"measured", measured(d, before, c), "points", kMeasured},
                 {"before", before, "line", kSegments, restarts(d, cmp.segments)},
                 {"after", after, "line", kAfter, restarts(d, f.after.segments)}};
    h << charts.add(std::move(ch));
  }
  for (int c : f.chans) {
    Chart ch = time_chart(d, c, "error before and after", error_label(c));
    ch.height_px = 160;
    ch.series = {{"before", error_ratio(d, cmp.segments, cmp.segment_floor, c), "thin", "#999999",
                            restarts(d, cmp.segments)},
                 {"after", error_ratio(d, f.after.segments, cmp.segment_floor, c), "line", kAfter,
                            restarts(d, f.after.segments)}};
    h << charts.add(std::move(ch));
  }
  return {"before-after", "Before and after", h.str()};
}

// ---------------------------------------------------------------- the effect's own curves
Section effect_section(const Findings& f, ChartSet& charts) {
  std::ostringstream h;
  const auto curves = effect_curves(f.cmp.model.model, f.after.model.model, f.d);
  h << "<p>What the fitted model does differently, over the speeds this log covers (the model before dashed, after "
       "solid): the force against speed is the resistance of eq. (6) plus the effects' body forces; the steady speed "
       "against screw speed includes every effect on the motion (traction, a dead band, saturation, friction, drag).";
  bool timing_only = curves.empty();
  for (const auto& e : f.after_fitted) timing_only = timing_only && e.effect == "pose_time_offset";
  if (curves.empty())
    h << " The fit changes none of these curves" << (timing_only ? " (a time offset of the pose shows in the pose plots)" : "") << ".";
  h << "</p>\n";
  for (auto c : curves) h << charts.add(std::move(c));
  return {"effect", "The fitted effect's own curves", h.str()};
}

// ---------------------------------------------------------------- explain's steps
Section explain_section(const Findings& f, ChartSet& charts) {
  const ExplainResult& ex = f.ex;
  std::ostringstream h;
  h << "<p><b>Verdict:</b> " << esc(ex.verdict) << "</p>\n";
  h << "<p>Each step refits every effect chosen so far and the paper's parameters jointly with the candidate; a "
       "candidate is taken when it gains more than 10 in BIC and lowers the held-out error by 2 %, the lowest held-out "
       "error first (a fit with a value at or beyond its physical range counted 15 % worse); an effect that no longer "
       "pays for itself is dropped. Held-out "
       "error per channel in multiples of the noise floor (1.00 = only noise left).</p>\n<table><tr><th>step</th>"
       "<th class=l>effect added</th>";
  for (int c = 0; c < kChannels; ++c)
    if (ex.active[static_cast<std::size_t>(c)]) h << "<th>" << channel_name(c) << "</th>";
  h << "<th>all channels</th><th>&Delta;BIC against the step before</th><th class=l>notes</th></tr>\n";
  Chart ch;
  ch.title = "Held-out error at each step of auger explain";
  ch.xlabel = "step";
  ch.ylabel = "held-out error (times the noise floor)";
  ch.integer_x = true;
  ch.log_y = true;
  ch.height_px = 240;
  std::vector<ChartSeries> series;
  for (int c = 0; c < kChannels; ++c)
    if (ex.active[static_cast<std::size_t>(c)]) series.push_back({channel_name(c), {}, "line", ""});
  series.push_back({"all channels (RMS)", {}, "dashed", ""});
  for (const auto& s : ex.steps) {
    h << "<tr><td id=\"explain-step-" << s.index << "\">" << s.index << "</td><td class=l>"
      << (s.added.empty() ? "(the model as given)" : "+ " + esc(s.added)) << "</td>";
    std::size_t k = 0;
    for (int c = 0; c < kChannels; ++c)
      if (ex.active[static_cast<std::size_t>(c)]) {
        const double v = s.heldout_ratio[static_cast<std::size_t>(c)];
        h << "<td>" << fixed(v, 2) << "</td>";
        series[k++].y.push_back(v);
      }
    series.back().y.push_back(s.heldout_combined);
    h << "<td>" << fixed(s.heldout_combined, 2) << "</td><td>" << (s.index > 0 ? fixed(s.delta_bic, 1) : "") << "</td><td class=l>";
    for (const auto& dr : s.dropped) h << esc(dr) << " dropped: it no longer pays for itself. ";
    if (s.flagged) {
      // Which values, and why (as `auger explain` prints them).
      h << "<span class=flag>flagged:";
      for (const auto& fe : s.fitted)
        for (const auto& p : fe.params)
          if (!p.flag.empty()) h << " <span class=flagged-param>" << esc(fe.effect + ": " + param_text(p)) << " (" << esc(p.flag) << ")</span>";
      h << "</span>. ";
    }
    for (const auto& a : s.alternatives)
      h << "near tie: " << esc(a.fitted.effect) << " (held-out " << fixed(a.heldout_ratio, 2)
        << " times the noise floor); the experiment that tells them apart: " << esc(a.tell_apart) << ". ";
    h << "</td></tr>\n";
    ch.x.push_back(s.index);
  }
  h << "</table>\n";
  ch.series = std::move(series);
  if (ch.x.size() >= 1) h << charts.add(std::move(ch));
  h << "<p>The final model, refitted on every segment (as <code>auger compare --model</code> computes it: ";
  for (int c = 0; c < kChannels; ++c)
    if (ex.active[static_cast<std::size_t>(c)])
      h << channel_name(c) << " " << fixed(ex.final_ratio[static_cast<std::size_t>(c)], 2) << " ";
  h << "times the noise floor):</p>\n<table><tr><th class=l>effect</th><th class=l>fitted (value &plusmn; one standard "
       "uncertainty)</th></tr>\n";
  for (const auto& e : ex.final_fitted)
    h << "<tr><td class=l>" << esc(e.effect) << "</td><td class=l>" << esc(e.description) << params_html(e) << "</td></tr>\n";
  h << "</table>\n<p>Residual tests: ";
  for (const auto& t : ex.tests) h << esc(describe_residual_tests(t)) << " ";
  h << "</p>\n";
  return {"explain", "The steps of auger explain", h.str()};
}

}  // namespace auger::wb
