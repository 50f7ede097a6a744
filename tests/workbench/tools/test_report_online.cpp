// auger report on a log with augerd's online estimate (issue 29 point 5, docs/workbench-tools.md
// "report"): the on_* columns drawn over time with their +-SD band beside the offline fit of the
// same log (auger fit LOG --add paper_params), and their agreement in combined SDs. Checked in
// the page's DOM in headless Chromium (tools/browser_check.py), and online_agreement directly.
// The on-robot agreement (augerd's FIL log against the offline fit): tests/daemon/online_agreement.sh.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <string>

#include "report_online.hpp"
#include "tools_fixtures.hpp"

namespace {

// The online columns augerd writes with [online] (daemon_log.hpp online_columns), appended to
// each row of a log: sigma_long ramps 0.5 -> 0.8 N/rpm over 60 s (SD 0.02 after the first second's
// prior), D_x held at 560.33 (SD 1 %: drag_prior_rel_sd 0.01), the others constant with SD 10 %.
const char* const kAddOnline = R"PY(
import sys
src, dst = sys.argv[1], sys.argv[2]
names = ["on_sigma_long", "on_sigma_lat", "on_D_x", "on_D_y", "on_D_psi",
         "on_sd_sigma_long", "on_sd_sigma_lat", "on_sd_D_x", "on_sd_D_y", "on_sd_D_psi"]
with open(src) as f, open(dst, "w") as o:
    header = True
    for line in f:
        line = line.rstrip("\n")
        if line.startswith("#") or not line:
            o.write(line + "\n"); continue
        if header:
            o.write(line + "," + ",".join(names) + "\n"); header = False; continue
        t = float(line.split(",")[0])
        v = [0.5 + 0.3 * t / 60, 0.247, 560.33, 320.08, 11.46]
        # The prior's SD (50 %; 1 % for the held D_x) until the data inform the estimate at 1 s.
        sd = [0.25, 0.1235, 5.6033, 160.04, 5.73] if t < 1 else [0.02, 0.0247, 5.6033, 32.008, 1.146]
        o.write(line + "," + ",".join("%.6g" % x for x in v + sd) + "\n")
)PY";

}  // namespace

TEST_CASE("report: augerd's online estimate over time with its SD band, beside the offline fit") {
  const tools_test::TempDir tmp("report-online");
  const std::string dir = tmp.path, sim = dir + "/sim.csv", log = dir + "/log.csv";
  REQUIRE(std::system((tools_test::shell_quote(AUGER_SIM_LOG_PATH) + " --out " + tools_test::shell_quote(sim) +
                       " --seconds 60 --seed 2 2>/dev/null").c_str()) == 0);
  tools_test::write_text(dir + "/add.py", kAddOnline);
  REQUIRE(std::system(("python3 " + tools_test::shell_quote(dir + "/add.py") + " " + tools_test::shell_quote(sim) + " " +
                       tools_test::shell_quote(log)).c_str()) == 0);
  const auto r = tools_test::run_auger(dir, "report " + log + " --out " + dir + "/rep --no-diagnose --json");
  INFO(r.err);
  REQUIRE(r.code == 0);
  CHECK(tools_test::json_eval(dir, r.out, "'online' in d['sections']") == "True");
  // D_x held online (its SD 1 %), so held in the offline fit too.
  const auto fit = tools_test::run_auger(dir, "fit " + log + " --add paper_params --hold D_x --json");
  REQUIRE(fit.code == 0);
  const auto bad = tools_test::run_auger(dir, "fit " + log + " --add paper_params --hold D_z");
  CHECK(bad.code == 2);
  CHECK_THAT(bad.err, Catch::Contains("--hold D_z: paper_params has sigma_long, sigma_lat, D_x, D_y, D_psi"));
  const auto offline = [&](const std::string& p) {
    return tools_test::json_number(
        dir, fit.out, "[e['params']['" + p + "'] for e in d['effects'] if e['effect'] == 'paper_params'][0]");
  };

  const std::string js = R"JS(JSON.stringify((() => {
    const C = window.augerCharts;
    const title = id => document.getElementById(id).parentElement.querySelector('.chart-title').textContent;
    const chart = t => C[Object.keys(C).find(i => title(i) === t)];
    const column = (g, label) => { const c = g.getLabels().indexOf(label), v = [];
      for (let r = 0; r < g.numRows(); ++r) v.push([g.getValue(r, 0), g.getValue(r, c)]); return v; };
    const at = (v, x) => v.reduce((b, p) => Math.abs(p[0] - x) < Math.abs(b[0] - x) ? p : b)[1];
    const s = chart('Online estimate of sigma_long'), dx = chart('Online estimate of D_x (held online)');
    const rows = {};
    document.querySelectorAll('table.online-agreement tr').forEach(tr => {
      const td = [...tr.querySelectorAll('td')].map(x => x.textContent);
      if (td.length) rows[td[0]] = td.slice(1);
    });
    return {labels: s.getLabels(), on30: at(column(s, 'online'), 30), lo30: at(column(s, 'online - SD'), 30),
            hi30: at(column(s, 'online + SD'), 30), off: at(column(s, 'offline fit'), 30),
            off_hi: at(column(s, 'offline + SD'), 30), dx: at(column(dx, 'online'), 10),
            group: s.getOption('xlabel'), rows: rows};
  })()))JS";
  const std::string out = dir + "/browser.json";
  const int rc = std::system(("python3 " + tools_test::shell_quote(AUGER_BROWSER_CHECK) + " " +
                              tools_test::shell_quote(dir + "/rep/index.html") + " --eval " + tools_test::shell_quote(js) +
                              " >" + tools_test::shell_quote(out) + " 2>&1").c_str());
  const std::string b = tools_test::read_text(out);
  INFO(b);
  REQUIRE(rc == 0);  // no console error, no exception, no outside request
  CHECK(tools_test::json_eval(dir, b, "d['eval']['labels']") ==
        "['t (s)', 'online', 'online - SD', 'online + SD', 'offline fit', 'offline - SD', 'offline + SD']");
  // The log's column at t = 30 s (the rows are 10 ms apart), its band +-0.02 N/rpm.
  CHECK(tools_test::json_number(dir, b, "d['eval']['on30']") == Approx(0.65).margin(0.001));
  CHECK(tools_test::json_number(dir, b, "d['eval']['lo30']") == Approx(0.63).margin(0.001));
  CHECK(tools_test::json_number(dir, b, "d['eval']['hi30']") == Approx(0.67).margin(0.001));
  CHECK(tools_test::json_number(dir, b, "d['eval']['dx']") == Approx(560.33));
  // The offline line is auger fit's value of the same log.
  const double off = offline("sigma_long");
  CHECK(tools_test::json_number(dir, b, "d['eval']['off']") == Approx(off).epsilon(1e-6));
  CHECK(tools_test::json_number(dir, b, "d['eval']['off_hi']") > off);
  // The table: D_x held on both sides (not compared); sigma_long's z from the values at the end
  // (0.8 +- 0.02 online) and the fit's.
  CHECK_THAT(tools_test::json_eval(dir, b, "d['eval']['rows']['D_x'][2]"), Catch::StartsWith("held online and offline"));
  CHECK(tools_test::json_number(dir, fit.out, "[e['params']['D_x'] for e in d['effects']][0]") == Approx(560.33));
  const double z = tools_test::json_number(dir, b, "d['eval']['rows']['sigma_long'][2]");
  const double sd_off = tools_test::json_number(
      dir, fit.out, "[e['params_sigma']['sigma_long'] for e in d['effects'] if e['effect'] == 'paper_params'][0]");
  CHECK(z == Approx(std::fabs(0.8 - off) / std::hypot(0.02, sd_off)).epsilon(0.02));
  CHECK(tools_test::json_eval(dir, r.out, "[o['name'] for o in d['online'] if o['held']]") == "['D_x']");
}

TEST_CASE("report: online_agreement compares what was estimated online; held parameters are named") {
  auger::wb::Dataset d;
  d.path = "log.csv";
  d.t_s = {0, 1};
  d.online_value = {{0.5, 0.25, 560, 320, 11.5}, {0.44, 0.25, 560, 320, 11.5}};
  d.online_sd = {{0.25, 0.12, 5.6, 3.2, 0.115}, {0.01, 0.1, 5.6, 3.2, 0.115}};  // all of D held (1 %)
  CHECK(auger::wb::online_held(d) == std::vector<std::string>{"D_x", "D_y", "D_psi"});
  const std::vector<auger::wb::FitParam> off = {{"sigma_long", 0.40, 0.02, "N/rpm", ""}, {"sigma_lat", 0.16, 0.01, "N/rpm", ""},
                                                {"D_x", 560, auger::wb::kNaN, "N/(m/s)", ""},      {"D_y", 320, auger::wb::kNaN, "N/(m/s)", ""},
                                                {"D_psi", 11.5, auger::wb::kNaN, "N m/(rad/s)", ""}};
  const auto a = auger::wb::online_agreement(d, 1, off);
  REQUIRE(a.size() == 5);
  CHECK(a[0].z == Approx(0.04 / std::hypot(0.01, 0.02)));
  CHECK(a[2].held);
  CHECK_FALSE(a[2].informed);
  CHECK(std::isnan(a[2].z));
  // sigma_lat at its prior's SD (0.12 -> 0.1: not below half of it): not informed, not compared.
  CHECK(a[0].informed);
  d.online_sd[1][1] = 0.05;
  // D estimated online (its prior SD in the first row): compared as well.
  d.online_sd[0] = {0.25, 0.12, 280, 160, 5.7};
  CHECK(auger::wb::online_held(d).empty());
  CHECK(auger::wb::online_agreement(d, 1, off)[1].z == Approx(0.09 / std::hypot(0.05, 0.01)));
  const std::vector<auger::wb::FitParam> off2 = {off[0], off[1], {"D_x", 509.81, 20, "N/(m/s)", ""},
                                                 {"D_y", 210.5, 10, "N/(m/s)", ""}, {"D_psi", 4.52, 0.3, "N m/(rad/s)", ""}};
  const auto b = auger::wb::online_agreement(d, 1, off2);
  CHECK_FALSE(b[2].held);
  CHECK(b[2].z == Approx(50.19 / std::hypot(5.6, 20)));
  d.online_value.clear();
  CHECK_THROWS_WITH(auger::wb::online_agreement(d, 1, off), Catch::Contains("has no on_* columns"));
}
