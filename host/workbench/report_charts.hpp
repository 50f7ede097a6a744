// Interactive charts of `auger report`: dygraphs (Debian libjs-dygraphs) read from the installed
// package and inlined in the page with its synchronizer extra, so the page stays one offline
// file. Charts of one group share their x-axis: zooming (drag), panning (shift-drag) or resetting
// (double click) one moves all of them; hovering shows every series' value at that time.
#pragma once

#include <string>
#include <vector>

namespace auger::wb {

struct ChartSeries {
  std::string label;
  std::vector<double> y;  // one value per x; NaN = no value there
  // "line", "thin" (a lighter, thinner line), "dashed", "points", "step" (constant until the next value)
  std::string style = "line";
  std::string color;  // CSS colour, "" = dygraphs' own
  // Rows where the line stops and starts anew (a model run restarted from the measured pose: no
  // chord between the runs); the row's own value is not drawn. Elsewhere a NaN is only "no value
  // on this row" and the line joins the values around it (a series measured on other rows).
  std::vector<std::size_t> breaks = {};
};

struct ChartBand {  // a shaded x-interval with a label (the worst windows)
  double x0 = 0, x1 = 0;
  std::string label;
};

struct Chart {
  std::string title;   // above the chart
  std::string xlabel, ylabel;
  std::vector<double> x;  // increasing
  std::vector<ChartSeries> series;
  std::vector<ChartBand> bands;
  std::string group;  // charts of one group zoom and pan together ("" = on its own)
  int height_px = 190;
  bool integer_x = false;  // x is a count (explain's steps): whole-number ticks only
  bool log_y = false;
};

class ChartSet {
 public:
  // Reads dygraph.min.js, dygraph.min.css and extras/synchronizer.js from $AUGER_DYGRAPHS_DIR or
  // /usr/share/javascript/dygraphs. Throws PlotError naming the Debian package libjs-dygraphs if
  // they are missing, so `report` fails before any work.
  ChartSet();
  // The chart's place in the page (a title, the chart and its legend); its data goes to scripts().
  // Rows beyond max_rows are thinned keeping, per bin, each series' largest |value| (peaks survive).
  std::string add(Chart chart, std::size_t max_rows = 8000);
  std::string style() const;    // dygraphs' CSS, for <head>
  std::string scripts() const;  // the library, the charts' data and the code that draws them
  int count() const { return static_cast<int>(specs_.size()); }
  const std::string& source() const { return dir_; }

 private:
  std::string dir_, js_, css_, sync_js_;
  std::vector<std::string> specs_;  // one JSON object per chart
};

// Text for HTML: & < > " escaped.
std::string html_escape(const std::string& s);

// A link that zooms a group's charts to [t0, t1] (or resets them when t0 > t1).
std::string zoom_link(const std::string& group, double t0, double t1, const std::string& text);

}  // namespace auger::wb
