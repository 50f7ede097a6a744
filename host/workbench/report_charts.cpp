// Interactive charts of `auger report` (report_charts.hpp).
#include "report_charts.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "output.hpp"
#include "report_plot.hpp"

namespace auger::wb {
namespace {

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return "";
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// The page is one file: a trailing source-map comment would point at a file beside it.
std::string without_source_map(std::string s) {
  const std::size_t p = s.rfind("sourceMappingURL=");
  if (p == std::string::npos) return s;
  const std::size_t line = s.rfind('\n', p);
  return s.substr(0, line == std::string::npos ? 0 : line + 1);
}

// Rows to keep: all of them, or per bin of rows each series' largest |value| (and the bin's first).
std::vector<std::size_t> rows_to_keep(const Chart& c, std::size_t max_rows) {
  const std::size_t n = c.x.size();
  std::vector<std::size_t> keep;
  if (n <= max_rows) {
    for (std::size_t i = 0; i < n; ++i) keep.push_back(i);
    return keep;
  }
  const std::size_t per_bin = c.series.size() + 1;
  const std::size_t bins = std::max<std::size_t>(1, max_rows / per_bin);
  const std::size_t width = (n + bins - 1) / bins;
  for (std::size_t b = 0; b < n; b += width) {
    const std::size_t e = std::min(n, b + width);
    keep.push_back(b);
    for (const auto& s : c.series) {
      std::size_t best = n;
      for (std::size_t i = b; i < e; ++i)
        if (std::isfinite(s.y[i]) && (best == n || std::fabs(s.y[i]) > std::fabs(s.y[best]))) best = i;
      if (best < n) keep.push_back(best);
    }
  }
  // A break and the rows around it, so that thinning never bridges it.
  for (const auto& s : c.series)
    for (std::size_t i : s.breaks)
      for (std::size_t j = i > 0 ? i - 1 : 0; j <= i + 1 && j < n; ++j) keep.push_back(j);
  std::sort(keep.begin(), keep.end());
  keep.erase(std::unique(keep.begin(), keep.end()), keep.end());
  return keep;
}

// Draws every chart of AUGER_CHARTS, links each group's x-axes, shades the bands, and makes the
// [data-zoom] links work. Errors are not caught: the browser test sees them.
const char* kInit = R"JS(
(function () {
  var specs = JSON.parse(document.getElementById('auger-chart-data').textContent);
  var groups = {};
  window.augerCharts = {};
  specs.forEach(function (s) {
    // A break (ChartSeries::breaks) comes as the string 'break': NaN is dygraphs' explicit gap in
    // a line that otherwise joins its values across rows without one (null).
    s.data.forEach(function (r) { for (var i = 1; i < r.length; ++i) if (r[i] === 'break') r[i] = NaN; });
    var series = {};
    s.styles.forEach(function (st, i) {
      var o = {};
      if (st === 'points') { o.strokeWidth = 0; o.drawPoints = true; o.pointSize = 1.5; }
      else if (st === 'thin') { o.strokeWidth = 0.8; }
      else if (st === 'dashed') { o.strokePattern = [6, 3]; o.strokeWidth = 1.2; }
      else if (st === 'step') { o.stepPlot = true; o.strokeWidth = 1.6; }
      else { o.strokeWidth = 1.4; }
      series[s.labels[i + 1]] = o;
    });
    var opts = {
      labels: s.labels, series: series, xlabel: s.xlabel, ylabel: s.ylabel,
      height: s.height, legend: 'always', labelsDiv: s.id + '-legend', labelsSeparateLines: false,
      connectSeparatedPoints: true, logscale: s.log_y, axisLabelFontSize: 11,
      labelsKMB: false, digitsAfterDecimal: 4, highlightSeriesOpts: null
    };
    if (s.colors.every(function (c) { return c; })) opts.colors = s.colors;
    if (s.integer_x) { opts.xRangePad = 40; opts.drawPoints = true; opts.pointSize = 3; }
    if (s.integer_x) opts.axes = { x: { pixelsPerLabel: 40, axisLabelFormatter: function (v) {
      return Math.abs(v - Math.round(v)) < 1e-9 ? String(Math.round(v)) : ''; } } };
    if (s.bands.length) opts.underlayCallback = function (ctx, area, g) {
      s.bands.forEach(function (b) {
        var l = g.toDomXCoord(b[0]), r = g.toDomXCoord(b[1]);
        ctx.fillStyle = 'rgba(244, 160, 150, 0.35)';
        ctx.fillRect(l, area.y, r - l, area.h);
        ctx.fillStyle = '#a33';
        ctx.font = '11px sans-serif';
        ctx.fillText(b[2], l + 2, area.y + 11);
      });
    };
    var g = new Dygraph(document.getElementById(s.id), s.data, opts);
    window.augerCharts[s.id] = g;
    if (s.group) (groups[s.group] = groups[s.group] || []).push(g);
  });
  Object.keys(groups).forEach(function (k) {
    if (groups[k].length > 1) Dygraph.synchronize(groups[k], { zoom: true, selection: true, range: false });
  });
  window.augerGroups = groups;
  document.querySelectorAll('[data-zoom]').forEach(function (el) {
    el.addEventListener('click', function (ev) {
      ev.preventDefault();
      var p = el.getAttribute('data-zoom').split(','), gs = groups[p[0]];
      if (!gs) return;
      var a = parseFloat(p[1]), b = parseFloat(p[2]);
      if (a < b) gs[0].updateOptions({ dateWindow: [a, b] }); else gs[0].resetZoom();
      gs[0].graphDiv.scrollIntoView({ block: 'nearest' });
    });
  });
})();
)JS";

}  // namespace

std::string html_escape(const std::string& s) {
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

ChartSet::ChartSet() {
  const char* env = std::getenv("AUGER_DYGRAPHS_DIR");
  dir_ = env && *env ? env : "/usr/share/javascript/dygraphs";
  js_ = without_source_map(slurp(dir_ + "/dygraph.min.js"));
  css_ = without_source_map(slurp(dir_ + "/dygraph.min.css"));
  sync_js_ = slurp(dir_ + "/extras/synchronizer.js");
  if (js_.find("Dygraph") == std::string::npos || css_.empty() || sync_js_.find("synchronize") == std::string::npos)
    throw PlotError("dygraphs not found in " + dir_ +
                    " (dygraph.min.js, dygraph.min.css, extras/synchronizer.js): auger report draws its "
                    "interactive plots with it; install the Debian package libjs-dygraphs (scripts/install-deps.sh "
                    "does) or set AUGER_DYGRAPHS_DIR");
  for (const std::string* s : {&js_, &sync_js_})
    if (s->find("</script") != std::string::npos) throw PlotError("dygraphs' script cannot be inlined (holds </script)");
}

std::string ChartSet::add(Chart c, std::size_t max_rows) {
  const std::string id = "chart-" + std::to_string(specs_.size() + 1);
  const std::vector<std::size_t> rows = rows_to_keep(c, max_rows);
  using nlohmann::ordered_json;
  ordered_json labels = ordered_json::array({c.xlabel}), styles = ordered_json::array(),
               colors = ordered_json::array(), bands = ordered_json::array(), data = ordered_json::array();
  std::vector<std::vector<bool>> is_break;
  for (const auto& s : c.series) {
    is_break.emplace_back(c.x.size(), false);
    for (std::size_t i : s.breaks)
      if (i < c.x.size()) is_break.back()[i] = true;
    labels.push_back(s.label);
    styles.push_back(s.style);
    colors.push_back(s.color);
  }
  for (const auto& b : c.bands) bands.push_back(ordered_json::array({json_number(b.x0, 6), json_number(b.x1, 6), b.label}));
  for (std::size_t r : rows) {
    // A row with no value and no break only widens the x-range: drop it.
    bool any = false;
    for (std::size_t i = 0; i < c.series.size(); ++i) any = any || std::isfinite(c.series[i].y[r]) || is_break[i][r];
    if (!any) continue;
    ordered_json row = ordered_json::array({json_number(c.x[r], 6)});
    for (std::size_t i = 0; i < c.series.size(); ++i)
      row.push_back(is_break[i][r] ? ordered_json("break") : json_number(c.series[i].y[r], 6));
    data.push_back(std::move(row));
  }
  ordered_json j = {{"id", id},         {"labels", labels}, {"styles", styles},   {"colors", colors},
                    {"xlabel", c.xlabel}, {"ylabel", c.ylabel}, {"group", c.group}, {"height", c.height_px},
                    {"integer_x", c.integer_x}, {"log_y", c.log_y}, {"bands", bands}, {"data", data}};
  specs_.push_back(json_for_script(j));
  std::ostringstream h;
  h << "<div class=\"chart-box\">";
  if (!c.title.empty()) h << "<div class=\"chart-title\">" << html_escape(c.title) << "</div>";
  h << "<div class=\"chart-legend\" id=\"" << id << "-legend\"></div><div class=\"chart\" id=\"" << id
    << "\" style=\"height:" << c.height_px << "px\"></div></div>\n";
  return h.str();
}

std::string ChartSet::style() const {
  return css_ +
         ".chart-box{margin:0.2em 0 0.6em}.chart-title{font-size:85%;font-weight:bold;color:#333}"
         ".chart-legend{font-size:80%;min-height:1.3em}.chart-legend .dygraph-legend{position:static;width:auto;"
         "background:none}.chart{width:100%}.dygraph-axis-label{font-size:11px}"
         ".dygraph-label.dygraph-ylabel{font-size:12px}.dygraph-label.dygraph-xlabel{font-size:12px}";
}

std::string ChartSet::scripts() const {
  if (specs_.empty()) return "";
  std::ostringstream o;
  o << "<script>\n" << js_ << "\n</script>\n<script>\n" << sync_js_ << "\n</script>\n";
  o << "<script type=\"application/json\" id=\"auger-chart-data\">[";
  for (std::size_t i = 0; i < specs_.size(); ++i) o << (i ? ",\n" : "") << specs_[i];
  o << "]</script>\n<script>" << kInit << "</script>\n";
  return o.str();
}

std::string zoom_link(const std::string& group, double t0, double t1, const std::string& text) {
  char b[96];
  std::snprintf(b, sizeof b, "%s,%.6g,%.6g", group.c_str(), t0, t1);
  return "<a href=\"#\" data-zoom=\"" + html_escape(b) + "\">" + html_escape(text) + "</a>";
}

}  // namespace auger::wb
