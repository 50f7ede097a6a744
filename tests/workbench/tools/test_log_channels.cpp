// Logs as the group's bags import (issue 26 points 4 and 5; docs/workbench.md "How the model is run
// against a log" and "A log without pose"): sensors slower than the 100 Hz grid leave their rows empty between samples, and
// the noise floor sees only measured samples; a log without pose is compared in the IMU heading
// alone and says what it cannot check.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "tools_fixtures.hpp"

namespace {

// auger-sim-log's 60 s sand log (camera 20 Hz, IMU and screw speeds every row).
std::string sim_log(const std::string& dir, const std::string& extra = "") {
  const std::string path = dir + "/sim.csv";
  REQUIRE(std::system((tools_test::shell_quote(AUGER_SIM_LOG_PATH) + " --out " + tools_test::shell_quote(path) +
                       " --seconds 60 --seed 5 " + extra + " 2>/dev/null")
                          .c_str()) == 0);
  return tools_test::read_text(path);
}

std::vector<std::string> fields_of(const std::string& line) {
  std::vector<std::string> f;
  std::string cur;
  for (char c : line) {
    if (c == ',') f.push_back(cur), cur.clear();
    else cur += c;
  }
  f.push_back(cur);
  return f;
}

// The log with column `name` emptied on data row k (0-based) where keep(k, name) is false.
std::string thinned(const std::string& log, const std::function<bool(std::size_t, const std::string&)>& keep) {
  std::istringstream in(log);
  std::string out, line;
  std::vector<std::string> header;
  std::size_t row = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') {
      out += line + "\n";
      continue;
    }
    if (header.empty()) {
      header = fields_of(line);
      out += line + "\n";
      continue;
    }
    auto f = fields_of(line);
    for (std::size_t i = 0; i < f.size() && i < header.size(); ++i)
      if (!keep(row, header[i])) f[i].clear();
    std::string joined;
    for (std::size_t i = 0; i < f.size(); ++i) joined += (i ? "," : "") + f[i];
    out += joined + "\n";
    ++row;
  }
  return out;
}

}  // namespace

TEST_CASE("a 50 Hz IMU and 5 Hz screw speeds give the noise floors of the 100 Hz log within 10 %") {
  const tools_test::TempDir tmp("rates");
  const std::string dir = tmp.path, full = dir + "/full.csv", slow = dir + "/slow.csv";
  const std::string log = sim_log(dir);
  tools_test::write_text(full, log);
  // As the importer writes such a bag: each sample on its row, the rows between empty; screw i's
  // feedback at rows 20 j + 5 i (the modules report at 5 Hz, out of phase), all four on row 0.
  tools_test::write_text(slow, thinned(log, [](std::size_t k, const std::string& c) {
                           if (c == "imu_psi_rad" || c == "imu_r_radps") return k % 2 == 1;
                           if (c.rfind("omega_rpm_", 0) == 0) return k == 0 || k % 20 == 5 * std::size_t(c.back() - '0');
                           return true;
                         }));
  const auto a = tools_test::run_auger(dir, "compare " + full + " --json");
  const auto b = tools_test::run_auger(dir, "compare " + slow + " --json");
  INFO(a.err << b.err);
  REQUIRE(a.code == 0);
  REQUIRE(b.code == 0);
  for (const char* c : {"x", "y", "psi", "imu_psi"}) {
    const double fa = tools_test::json_number(dir, a.out, std::string("d['noise_floor']['") + c + "']");
    const double fb = tools_test::json_number(dir, b.out, std::string("d['noise_floor']['") + c + "']");
    INFO(c << ": 100 Hz " << fa << ", slow " << fb);
    CHECK(fb == Approx(fa).epsilon(0.10));
  }
  // The paper's own model (the log's truth) stays at the noise: no interpolated sample counted as
  // noise-free, no screw speed lagging its report.
  CHECK(tools_test::json_number(dir, b.out, "max(d['segments']['ratio_to_noise'].values())") < 1.3);
}

TEST_CASE("a log without pose: compare and diagnose in the IMU heading, and what they cannot check") {
  const tools_test::TempDir tmp("nopose");
  const std::string dir = tmp.path, log = dir + "/nopose.csv";
  tools_test::write_text(log, thinned(sim_log(dir), [](std::size_t, const std::string& c) {
                           return c != "x_m" && c != "y_m" && c != "psi_rad";
                         }));
  const auto c = tools_test::run_auger(dir, "compare " + log + " --json");
  INFO(c.err);
  REQUIRE(c.code == 0);
  CHECK(tools_test::json_eval(dir, c.out, "sorted(d['noise_floor'])") == "['imu_psi']");
  CHECK(tools_test::json_number(dir, c.out, "d['segments']['ratio_to_noise']['imu_psi']") < 1.3);
  CHECK(tools_test::json_eval(dir, c.out, "[w for w in d['warnings'] if 'no pose' in w][0]").find(
            "Not checked: the model's x and y") != std::string::npos);
  CHECK_THAT(c.err, Catch::Contains("warning: the log has no pose"));

  const auto d = tools_test::run_auger(dir, "diagnose " + log + " --json");
  INFO(d.err);
  REQUIRE(d.code == 0);
  // Effects only a pose shows are not candidates; paper_params keeps sigma and D along x and y.
  CHECK(tools_test::json_eval(dir, d.out,
                              "[c['effect'] for c in d['candidates'] if c['effect'] in "
                              "('terrain_slope', 'rigid_body_coupling', 'pose_time_offset', 'imu_heading_bias')]") ==
        "[]");
  CHECK(tools_test::json_eval(dir, d.out,
                              "[c['params']['sigma_long'] for c in d['candidates'] if c['effect'] == 'paper_params']") ==
        "[0.812]");
  CHECK(tools_test::json_eval(dir, d.out, "any('no pose' in w for w in d['warnings'])") == "True");
}
