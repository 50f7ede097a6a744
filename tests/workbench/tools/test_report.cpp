// auger report: the page for a generated log has every section, valid inline SVG drawn by
// gnuplot, no external reference, the same numbers as `auger compare --json`, and a clear
// error when gnuplot is missing.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <sstream>

#include "auger/dynamics.hpp"
#include "auger/model.hpp"
#include "tools_fixtures.hpp"

namespace {

// 80 s of manual-style driving of the nominal sand model (the paper's Table 3) with a constant
// extra force along x that the nominal model does not have, pose at 20 Hz with 3 mm / 5 mrad
// noise, IMU heading every row.
std::string generated_log() {
  using namespace auger;
  const Model m = make_model(RobotParams{}, TerrainParams{"sand", 0.812, 0.247, 560.33, 320.08, 11.46});
  DynamicsData data(m);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n01(0, 1);
  Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
  std::ostringstream os;
  os.precision(10);
  os << "# format: auger-robot-log v1\n# terrain: sand\n"
     << "t_s,omega_rpm_0,omega_rpm_1,omega_rpm_2,omega_rpm_3,x_m,y_m,psi_rad,imu_psi_rad\n";
  const double dt = 0.01;
  for (int k = 0; k < 8000; ++k) {
    const double t = k * dt;
    // Forward, sideways, turning, combined: 10 s each, twice.
    const int phase = static_cast<int>(t / 10) % 4;
    const Vec3 body = phase == 0 ? Vec3(0.05, 0, 0) : phase == 1 ? Vec3(0, 0.06, 0)
                    : phase == 2 ? Vec3(0, 0, 0.15) : Vec3(0.03, -0.03, -0.1);
    const Vec4 omega = kinematic_screw_speeds_rpm(m, body);
    if (k % 5 == 0) {
      os << t << ',' << omega[0] << ',' << omega[1] << ',' << omega[2] << ',' << omega[3] << ','
         << eta.x() + 0.003 * n01(rng) << ',' << eta.y() + 0.003 * n01(rng) << ','
         << wrap_angle(eta.z() + 0.005 * n01(rng)) << ',' << wrap_angle(eta.z() + 0.005 * n01(rng)) << '\n';
    } else {
      os << t << ',' << omega[0] << ',' << omega[1] << ',' << omega[2] << ',' << omega[3] << ",,,,"
         << wrap_angle(eta.z() + 0.005 * n01(rng)) << '\n';
    }
    dynamics_step(m, data, eta, zeta, omega, dt);
    zeta.x() -= 0.01 * 12.0 / 29.0 * (zeta.x() > 0 ? 1 : zeta.x() < 0 ? -1 : 0);  // 12 N dry friction along x
  }
  return os.str();
}

}  // namespace

TEST_CASE("auger report: sections, valid inline SVG, nothing external, numbers of compare --json") {
  const tools_test::TempDir tmp("report");
  const std::string dir = tmp.path;
  const std::string log = dir + "/log.csv";
  tools_test::write_text(log, generated_log());
  const auto r = tools_test::run_auger(dir, "report " + log + " --out " + dir + "/rep --json");
  INFO(r.out << r.err);
  REQUIRE(r.code == 0);
  CHECK(tools_test::json_eval(dir, r.out, "d['sections']") ==
        "['summary', 'measured-vs-model', 'error', 'ranking', 'before-after']");
  CHECK(tools_test::json_number(dir, r.out, "d['plots']") == 5);
  const std::string html = tools_test::read_text(dir + "/rep/index.html");
  REQUIRE(!html.empty());

  // Valid SVG (each inline <svg> parses as XML and holds drawn paths) and nothing that loads
  // from elsewhere: no src/link/script/import, hrefs only to the page's own anchors and ids,
  // "http" only in XML namespace names.
  const std::string check = dir + "/check.py";
  tools_test::write_text(check, R"PY(
import re, sys, xml.etree.ElementTree as ET
h = open(sys.argv[1], encoding='utf-8').read()
svgs = re.findall(r'<svg\b.*?</svg>', h, re.S)
for s in svgs:
    root = ET.fromstring(s)
    assert root.tag.endswith('svg'), root.tag
    assert len(root.findall('.//{http://www.w3.org/2000/svg}path')) > 5
low = h.lower()
for bad in ('src=', '<link', '<script', '@import', '<iframe', '<object', '<embed'):
    assert bad not in low, bad
for m in re.finditer(r'href=["\']([^"\']*)', h):
    assert m.group(1).startswith('#'), m.group(1)
stripped = re.sub(r'xmlns(:\w+)?="http://www\.w3\.org/[^"]*"', '', h)
assert 'http:' not in stripped and 'https:' not in stripped
assert not re.search(r'url\((?!#)', h), 'url() to something other than an id of the page'
ids = re.findall(r'\bid=["\']([^"\']+)', h)
assert len(ids) == len(set(ids)), 'duplicate ids'
print(len(svgs))
)PY");
  {
    const std::string cmd = "python3 " + tools_test::shell_quote(check) + " " +
                            tools_test::shell_quote(dir + "/rep/index.html") + " >" + dir + "/check.out 2>&1";
    const int rc = std::system(cmd.c_str());
    INFO(tools_test::read_text(dir + "/check.out"));
    CHECK(rc == 0);
    CHECK(tools_test::read_text(dir + "/check.out") == "5\n");
  }
  for (const char* section : {"id=\"summary\"", "id=\"measured-vs-model\"", "id=\"error\"", "id=\"ranking\"",
                              "id=\"before-after\"", "Produced by GNUPLOT"})
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
}

TEST_CASE("auger report without gnuplot: a clear error naming the package, nothing written") {
  const tools_test::TempDir tmp("report-nognuplot");
  const std::string dir = tmp.path;
  tools_test::write_text(dir + "/log.csv", generated_log());
  const auto r = tools_test::run_auger(dir, "report " + dir + "/log.csv --out " + dir + "/rep --no-diagnose",
                                       "AUGER_GNUPLOT=" + dir + "/no-such-gnuplot");
  CHECK(r.code == 2);
  CHECK_THAT(r.err, Catch::Contains("gnuplot") && Catch::Contains("gnuplot-nox"));
  CHECK(tools_test::read_text(dir + "/rep/index.html").empty());
}
