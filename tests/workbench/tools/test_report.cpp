// auger report: the page for a generated log has every section, the interactive time plots and
// the SVG plots, no external reference, the same numbers as `auger compare --json`; in headless
// Chromium it loads without a console error, its time plots zoom together, the worst windows'
// numbers are the RMS of the curve drawn under them, and every candidate is charted. Clear
// errors when gnuplot or dygraphs is missing; gnuplot strings quoted.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "friction_log.hpp"
#include "report_plot.hpp"
#include "tools_fixtures.hpp"

TEST_CASE("auger report: sections, valid inline SVG, nothing external, numbers of compare --json") {
  const tools_test::TempDir tmp("report");
  const std::string dir = tmp.path;
  const std::string log = dir + "/log.csv";
  tools_test::write_text(log, tools_test::dry_friction_log());
  const auto r = tools_test::run_auger(dir, "report " + log + " --out " + dir + "/rep --json");
  INFO(r.out << r.err);
  REQUIRE(r.code == 0);
  CHECK(tools_test::json_eval(dir, r.out, "d['sections']") ==
        "['summary', 'measured-vs-model', 'error', 'ranking', 'before-after', 'effect']");
  CHECK(tools_test::json_number(dir, r.out, "d['plots']") == 2);  // the path, the candidates
  // x, y, psi, imu_psi: measured vs model, error, pose before/after, error before/after; then
  // the effect's curves (friction: force against speed and steady speed, at least along x).
  const double charts = tools_test::json_number(dir, r.out, "d['charts']");
  CHECK(charts >= 16 + 2);
  CHECK_THAT(tools_test::json_eval(dir, r.out, "d['next']"), Catch::StartsWith("auger fit "));
  const std::string html = tools_test::read_text(dir + "/rep/index.html");
  REQUIRE(!html.empty());

  // Valid SVG (each inline <svg> parses as XML and holds drawn paths); nothing that loads from
  // elsewhere: no src/link/import/frame, scripts only inline, hrefs only to the page's own
  // anchors, "http" only in XML namespace names and in the scripts' licence comments (the
  // browser check below sees any request the scripts would make); no duplicate id; every
  // candidate of the ranking table named in the ranking chart.
  const std::string check = dir + "/check.py";
  tools_test::write_text(check, R"PY(
import re, sys, xml.etree.ElementTree as ET
h = open(sys.argv[1], encoding='utf-8').read()
svgs = re.findall(r'<svg\b.*?</svg>', h, re.S)
for s in svgs:
    root = ET.fromstring(s)
    assert root.tag.endswith('svg'), root.tag
    assert len(root.findall('.//{http://www.w3.org/2000/svg}path')) > 5
scripts = re.findall(r'<script\b[^>]*>', h)
assert len(scripts) == 4 and all('src' not in s for s in scripts), scripts
body = re.sub(r'<script\b.*?</script>', '', h, flags=re.S)
low = body.lower()
for bad in ('src=', '<link', '@import', '<iframe', '<object', '<embed'):
    assert bad not in low, bad
for m in re.finditer(r'href=["\']([^"\']*)', body):
    assert m.group(1).startswith('#'), m.group(1)
stripped = re.sub(r'xmlns(:\w+)?="http://www\.w3\.org/[^"]*"', '', body)
assert 'http:' not in stripped and 'https:' not in stripped
assert not re.search(r'url\((?!#)', body), 'url() to something other than an id of the page'
ids = re.findall(r'\bid=["\']([^"\']+)', body)
assert len(ids) == len(set(ids)), 'duplicate ids'
names = re.findall(r'id="candidate-\d+">([^<]+)<', h)
ranking_svg = svgs[1]
texts = set(t.strip() for t in re.findall(r'<text\b[^>]*>(.*?)</text>', ranking_svg, re.S))
missing = [n for n in names if n not in ''.join(texts)]
assert len(names) >= 14 and not missing, (len(names), missing)
print(len(svgs))
)PY");
  {
    const std::string cmd = "python3 " + tools_test::shell_quote(check) + " " +
                            tools_test::shell_quote(dir + "/rep/index.html") + " >" + dir + "/check.out 2>&1";
    const int rc = std::system(cmd.c_str());
    INFO(tools_test::read_text(dir + "/check.out"));
    CHECK(rc == 0);
    CHECK(tools_test::read_text(dir + "/check.out") == "2\n");
  }
  for (const char* section : {"id=\"summary\"", "id=\"measured-vs-model\"", "id=\"error\"", "id=\"ranking\"",
                              "id=\"before-after\"", "id=\"effect\"", "Produced by GNUPLOT", "Ranking rule:",
                              "Force against speed, x"})
    CHECK_THAT(html, Catch::Contains(section));

  // The page's numbers are compare's.
  const auto cmp = tools_test::run_auger(dir, "compare " + log + " --json");
  REQUIRE(cmp.code == 0);
  auto cell = [&](const std::string& id) {
    const std::string key = "id=\"" + id + "\">";
    const auto p = html.find(key);
    if (p == std::string::npos) return std::string("(no cell " + id + ")");
    return html.substr(p + key.size(), html.find('<', p + key.size()) - p - key.size());
  };
  // A JSON number (or null, shown as a dash) against a cell of the page.
  auto same = [&](const std::string& id, const std::string& expr) {
    const std::string want = tools_test::json_eval(dir, cmp.out, expr), got = cell(id);
    INFO(id << ": page '" << got << "', compare --json " << expr << " = " << want);
    if (want == "None") {
      CHECK(got == "&ndash;");
    } else {
      REQUIRE(got.find_first_not_of("0123456789.eE+-") == std::string::npos);
      CHECK(std::stod(got) == Approx(std::stod(want)).epsilon(1e-5));  // the page shows 6 digits
    }
  };
  int compared = 0;
  for (const std::string ch : {"x", "y", "psi", "imu_psi"}) {
    for (const std::string run : {"open_loop", "segments", "one_step"}) {
      same(run + "-rms-" + ch, "d['" + run + "']['rms'].get('" + ch + "')");
      same(run + "-ratio-" + ch, "d['" + run + "']['ratio_to_noise'].get('" + ch + "')");
      compared += 2;
    }
    same("noise-" + ch, "d['noise_floor']['" + ch + "']");
  }
  same("worst-1-t_start_s", "d['worst'][0]['t_start_s']");
  same("worst-1-ratio", "d['worst'][0]['ratio_to_noise']");
  CHECK(compared == 24);
  // The segments' x error is well above the noise (the dry friction the model lacks).
  CHECK(std::stod(cell("segments-ratio-x")) > 3);

  // In a real browser: no console error or exception, no request outside the page; every chart
  // drawn with data; the time plots' x-axes linked (zooming one zooms all); and the worst
  // window's number is what the curve under its band shows: the RMS of the 5 s-window error
  // curve over the window, and the step line's height there.
  const std::string js = R"JS(JSON.stringify((() => {
    const C = window.augerCharts, T = window.augerGroups.time, ids = Object.keys(C);
    const title = id => document.getElementById(id).parentElement.querySelector('.chart-title').textContent;
    T[0].updateOptions({dateWindow: [20, 30]});
    const linked = T.filter(g => Math.abs(g.xAxisRange()[0] - 20) < 1e-9 && Math.abs(g.xAxisRange()[1] - 30) < 1e-9).length;
    T[0].resetZoom();
    const t0 = parseFloat(document.getElementById('worst-1-t_start_s').textContent);
    const row = document.getElementById('worst-1-t_start_s').parentElement;
    const dof = row.children[3].textContent.split(' ')[0];
    const g = C[ids.find(i => title(i) === dof + ': error in noise floors')];
    const labels = g.getLabels(), ce = labels.indexOf('error, re-initialised every 5 s'),
          cs = labels.indexOf('RMS of each 5 s window');
    const t1 = parseFloat(row.children[2].textContent);
    let ss = 0, n = 0, step = null;
    for (let r = 0; r < g.numRows(); ++r) {
      const t = g.getValue(r, 0);
      if (t < t0 - 1e-9 || t > t1 + 1e-9) continue;
      const e = g.getValue(r, ce);
      if (e !== null && !isNaN(e)) { ss += e * e; ++n; }
      if (step === null) step = g.getValue(r, cs);
    }
    return {charts: ids.length, empty: ids.filter(i => C[i].numRows() < 2).length, time: T.length, linked: linked,
            canvases: document.querySelectorAll('.chart canvas').length, window_rms: Math.sqrt(ss / n),
            window_rows: n, window_step: step};
  })()))JS";
  const std::string bout = dir + "/browser.json";
  const std::string bcmd = "python3 " + tools_test::shell_quote(AUGER_BROWSER_CHECK) + " " +
                           tools_test::shell_quote(dir + "/rep/index.html") + " --eval " + tools_test::shell_quote(js) +
                           " >" + tools_test::shell_quote(bout) + " 2>&1";
  const int brc = std::system(bcmd.c_str());
  const std::string b = tools_test::read_text(bout);
  INFO(b);
  REQUIRE(brc == 0);  // no console error, no exception, no outside request
  CHECK(tools_test::json_number(dir, b, "d['eval']['charts']") == charts);
  CHECK(tools_test::json_number(dir, b, "d['eval']['empty']") == 0);
  CHECK(tools_test::json_number(dir, b, "d['eval']['time']") == 16);
  CHECK(tools_test::json_number(dir, b, "d['eval']['linked']") == 16);
  CHECK(tools_test::json_number(dir, b, "d['eval']['canvases']") >= charts);
  const double worst = std::stod(tools_test::json_eval(dir, cmp.out, "d['worst'][0]['ratio_to_noise']"));
  CHECK(tools_test::json_number(dir, b, "d['eval']['window_rows']") >= 90);  // 5 s of 20 Hz poses
  CHECK(tools_test::json_number(dir, b, "d['eval']['window_rms']") == Approx(worst).epsilon(1e-4));
  CHECK(tools_test::json_number(dir, b, "d['eval']['window_step']") == Approx(worst).epsilon(1e-5));
}

TEST_CASE("auger report without gnuplot or dygraphs: a clear error naming the package, nothing written") {
  const tools_test::TempDir tmp("report-missing");
  const std::string dir = tmp.path;
  tools_test::write_text(dir + "/log.csv", tools_test::dry_friction_log());
  struct Missing {
    const char* env;  // pointing the tool at nothing
    const char* package;
  };
  for (const Missing m : {Missing{"AUGER_GNUPLOT=", "gnuplot-nox"}, Missing{"AUGER_DYGRAPHS_DIR=", "libjs-dygraphs"}}) {
    const auto r = tools_test::run_auger(dir, "report " + dir + "/log.csv --out " + dir + "/rep --no-diagnose",
                                         m.env + dir + "/no-such-thing");
    INFO(m.package << ": " << r.err);
    CHECK(r.code == 2);
    CHECK_THAT(r.err, Catch::Contains(m.package));
    CHECK(tools_test::read_text(dir + "/rep/index.html").empty());
  }
}

TEST_CASE("gnuplot strings are quoted: quotes, a backslash and a newline reach the SVG as text") {
  using auger::wb::gp_quote;
  CHECK(gp_quote("plain") == "'plain'");
  CHECK(gp_quote("it's") == "'it''s'");
  CHECK(gp_quote("a\nb") == "'a b'");
  auger::wb::Gnuplot gp;
  const std::string label = "O'Brien \"x\" \\ `date` $(id)\nsecond";
  const std::string svg = gp.svg("quote", "set title " + gp_quote(label) + "\nplot x title " + gp_quote("it's"));
  CHECK_THAT(svg, Catch::Contains("O&apos;Brien") || Catch::Contains("O'Brien"));
  CHECK_THAT(svg, Catch::Contains("`date` $(id) second"));
}
