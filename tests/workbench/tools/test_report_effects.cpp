// auger report draws what was fitted where it acts (issue 26 point 6, docs/workbench-tools.md):
// a one-screw traction loss as that screw's drive force against its own speed, screw blocking as
// the resistance against one screw's speed near zero, each run of the model (25 s, 5 s windows) as a
// line of its own in every chart (no chord at a restart), every legend above its chart
// naming each series, and the heading regimes over every row. Checked in the page's DOM
// in headless Chromium (tools/browser_check.py).
#include <catch2/catch.hpp>

#include <cstdlib>
#include <string>

#include "report.hpp"
#include "tools_fixtures.hpp"

namespace {

// auger-sim-log's 60 s log with `args`, then `auger report LOG --out DIR/rep ARGS` and the page's
// DOM evaluated by js in headless Chromium; returns the browser check's JSON.
std::string report_in_browser(const std::string& dir, const std::string& sim_args, const std::string& report_args,
                              const std::string& js, std::string& report_json) {
  const std::string log = dir + "/log.csv";
  REQUIRE(std::system((tools_test::shell_quote(AUGER_SIM_LOG_PATH) + " --out " + tools_test::shell_quote(log) +
                       " --seconds 60 --seed 2 " + sim_args + " 2>/dev/null")
                          .c_str()) == 0);
  const auto r = tools_test::run_auger(dir, "report " + log + " --out " + dir + "/rep --no-diagnose --json " + report_args);
  INFO(r.err);
  REQUIRE(r.code == 0);
  report_json = r.out;
  const std::string out = dir + "/browser.json";
  const int rc = std::system(("python3 " + tools_test::shell_quote(AUGER_BROWSER_CHECK) + " " +
                              tools_test::shell_quote(dir + "/rep/index.html") + " --eval " + tools_test::shell_quote(js) +
                              " >" + tools_test::shell_quote(out) + " 2>&1")
                                 .c_str());
  const std::string b = tools_test::read_text(out);
  INFO(b);
  REQUIRE(rc == 0);  // no console error, no exception, no outside request
  return b;
}

// In the page: the chart whose title starts with `prefix`, its series' labels and values.
const char* const kFindChart = R"JS(
  const C = window.augerCharts;
  const title = id => document.getElementById(id).parentElement.querySelector('.chart-title').textContent;
  const chart = prefix => C[Object.keys(C).find(i => title(i).startsWith(prefix))];
  const column = (g, label) => { const c = g.getLabels().indexOf(label), v = [];
    for (let r = 0; r < g.numRows(); ++r) v.push([g.getValue(r, 0), g.getValue(r, c)]); return v; };
  const at = (v, x) => v.reduce((b, p) => Math.abs(p[0] - x) < Math.abs(b[0] - x) ? p : b)[1];
)JS";

}  // namespace

TEST_CASE("report: a one-screw traction loss drawn per screw, 25 s runs without chords, heading regimes of all rows") {
  const tools_test::TempDir tmp("report-screw");
  const std::string dir = tmp.path;
  const std::string js = std::string("JSON.stringify((() => {") + kFindChart + R"JS(
    const g = chart('Drive force of each screw against its own speed');
    const labels = g ? g.getLabels() : [];
    const xmax = g ? g.getValue(g.numRows() - 1, 0) : 0;
    const lost = g ? at(column(g, 'after, screw 2'), xmax) : null;
    const others = g ? at(column(g, 'after, screws 0, 1, 3'), xmax) : null;
    // Each run restarted from the measured pose ends in a break (NaN: dygraphs' explicit gap;
    // a row without a value is null and is bridged), in every chart that draws model runs.
    const breaks = (prefix, label) => column(chart(prefix), label).filter(p => Number.isNaN(p[1])).length;
    const runs = {segments: breaks('x: measured and model', 'model, segments of 25 s'),
                  before: breaks('x: before and after', 'before'), after: breaks('x: before and after', 'after'),
                  error_before: breaks('x: error before and after', 'before'),
                  windows: breaks('x: error in noise floors', 'error, re-initialised every 5 s'),
                  window_segments: breaks('x: error in noise floors', 'error, segments of 25 s')};
    const x = chart('x: measured and model');
    runs.t_last = x.getValue(x.numRows() - 1, 0);
    // Every chart's legend above its plot, not over it or over another legend, naming each series.
    const legends = Object.keys(C).map(id => {
      const l = document.getElementById(id + '-legend'), r = l.getBoundingClientRect();
      const top = document.getElementById(id).getBoundingClientRect().top;
      return {id: id, above: r.height > 0 && r.bottom <= top + 0.5, r: r,
              named: C[id].getLabels().slice(1).every(lb => l.textContent.includes(lb))};
    });
    const legend_faults = legends.filter((a, i) => !a.above || !a.named ||
      legends.some((b, j) => j !== i && a.r.top < b.r.bottom && b.r.top < a.r.bottom &&
                             a.r.left < b.r.right && b.r.left < a.r.right)).map(a => a.id);
    // The heading regimes of the page's table.
    let heading = 0;
    document.querySelectorAll('#error table tr').forEach(tr => {
      const td = tr.querySelectorAll('td');
      if (td.length > 2 && td[0].textContent === 'heading') heading += parseFloat(td[2].textContent);
    });
    return {labels: labels, lost: lost, others: others, runs: runs, legend_faults: legend_faults,
            charts: legends.length,
            connected: x.getOption('connectSeparatedPoints', 'model, segments of 25 s'), heading_s: heading};
  })()))JS";
  std::string rj;
  const std::string b =
      report_in_browser(dir, "--effect screw_traction_loss:screw=2,loss=0.5", "--effect screw_traction_loss", js, rj);
  // Screw 2's line apart from the others', at about half their force (the loss fitted near 0.5).
  CHECK(tools_test::json_eval(dir, b, "d['eval']['labels']") ==
        "['screw speed (rpm)', 'before, screws 0, 1, 2, 3', 'after, screws 0, 1, 3', 'after, screw 2']");
  const double share = tools_test::json_number(dir, b, "d['eval']['lost'] / d['eval']['others']");
  CHECK(share > 0.4);
  CHECK(share < 0.6);
  // 60 s (its last row at 60.00 s) in runs of 25 s: two restarts after the first start, each its
  // own line; in 5 s windows twelve.
  REQUIRE(tools_test::json_number(dir, b, "d['eval']['runs']['t_last']") == Approx(60.0));
  for (const char* s : {"segments", "before", "after", "error_before", "window_segments"}) {
    INFO(s);
    CHECK(tools_test::json_number(dir, b, std::string("d['eval']['runs']['") + s + "']") == 2);
  }
  CHECK(tools_test::json_number(dir, b, "d['eval']['runs']['windows']") == 12);
  CHECK(tools_test::json_eval(dir, b, "d['eval']['legend_faults']") == "[]");
  CHECK(tools_test::json_number(dir, b, "d['eval']['charts']") > 20);
  // Rows without a value (the camera's gaps) are bridged, not broken.
  CHECK(tools_test::json_eval(dir, b, "d['eval']['connected']") == "True");
  // Heading regimes over every row (a 20 Hz camera's rows alone were a fifth of the log).
  CHECK(tools_test::json_number(dir, b, "d['eval']['heading_s']") == Approx(60.0).margin(0.2));
  const auto cmp = tools_test::run_auger(dir, "compare " + dir + "/log.csv --json");
  REQUIRE(cmp.code == 0);
  CHECK(tools_test::json_number(dir, cmp.out, "sum(g['seconds'] for g in d['regimes'] if g['kind'] == 'heading')") ==
        Approx(60.0).margin(0.2));
}

TEST_CASE("report: screw blocking drawn as the resistance against one screw's speed near zero") {
  const tools_test::TempDir tmp("report-blocking");
  const std::string dir = tmp.path;
  const std::string js = std::string("JSON.stringify((() => {") + kFindChart + R"JS(
    const g = chart('Screw blocking:'), v = column(g, 'after (fitted)');
    const xmax = g.getValue(g.numRows() - 1, 0);
    const friction = chart('Force against speed, x');
    return {at_rest: at(v, 0), beyond: at(v, xmax), xmax: xmax,
            friction_title: friction ? title(Object.keys(C).find(i => C[i] === friction)) : ''};
  })()))JS";
  std::string rj;
  const std::string b = report_in_browser(dir, "--physical-base", "--effect screw_blocking", js, rj);
  // The fitted force_n at standstill, nothing well above the blocking speed (4 times it).
  const double force = tools_test::json_number(dir, b, "d['eval']['at_rest']");
  CHECK(force > 5);
  CHECK(tools_test::json_number(dir, b, "d['eval']['beyond']") == Approx(0).margin(1e-9));
  CHECK(tools_test::json_number(dir, b, "d['eval']['xmax']") < 20);
  // Not drawn as a dry friction of the body's speed (with the screws still every screw blocks).
  CHECK_THAT(tools_test::json_eval(dir, b, "d['eval']['friction_title']"),
             Catch::Contains("screw blocking: its own chart") || Catch::Equals(""));
}

TEST_CASE("report: a flagged value of an explain step is named, with its value and why") {
  auger::wb::Dataset d;
  auger::wb::Findings f(d);
  auger::wb::ExplainStep s0, s1;
  s1.index = 1;
  s1.added = "force_lag";
  s1.flagged = true;
  auger::wb::FittedEffect paper, lag;
  paper.effect = "paper_params";
  paper.params = {{"D_x", 560.0, 3.0, "N/(m/s)", ""}};
  lag.effect = "force_lag";
  lag.params = {{"tau_s", 0.004, 0.01, "s", "not identified by this log"}, {"delay_s", 0.0, 0.001, "s", ""}};
  s1.fitted = {paper, lag};
  f.ex.steps = {s0, s1};
  f.ex.active = {true, false, false, false};
  auger::wb::ChartSet charts;
  const std::string html = auger::wb::explain_section(f, charts).html;
  CHECK_THAT(html, Catch::Contains("flagged: <span class=flagged-param>force_lag: tau_s = 0.004 +- 0.01 s "
                                   "(not identified by this log)</span>"));
  CHECK_THAT(html, !Catch::Contains("delay_s = 0 +-") && !Catch::Contains("D_x = 560"));
}
