// auger identify: sigma and D of eqs. (15)-(17) from gantry runs generated with a known truth;
// the confidence intervals must cover the truth at their stated rate over many seeds.
#include <catch2/catch.hpp>

#include <cmath>
#include <sstream>

#include "gantry_gen.hpp"
#include "identify.hpp"
#include "workbench.hpp"
#include "tools_fixtures.hpp"

using namespace auger::wb;
using tools_test::GantryTruth;

TEST_CASE("t quantile and effective sample size against known values") {
  CHECK(t_quantile(0.95, 1e9) == Approx(1.959964).epsilon(1e-5));
  CHECK(t_quantile(0.95, 2) == Approx(4.302653).epsilon(1e-4));
  CHECK(t_quantile(0.95, 10) == Approx(2.228139).epsilon(1e-4));
  // White noise: n_eff close to n; AR(1) with rho 0.9: n (1 - rho) / (1 + rho) = n / 19.
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n01(0, 1);
  std::vector<double> white(20000), ar(20000);
  double a = 0;
  for (std::size_t i = 0; i < white.size(); ++i) {
    white[i] = n01(rng);
    a = 0.9 * a + n01(rng);
    ar[i] = a;
  }
  CHECK(effective_sample_size({white}) == Approx(20000).epsilon(0.15));
  CHECK(effective_sample_size({ar}) == Approx(20000.0 / 19).epsilon(0.25));
}

TEST_CASE("identify recovers sigma and D of both axes, terrains apart") {
  GantryTruth lon;  // sand, Table 2
  GantryTruth lat;
  lat.axis = "lateral", lat.sigma = 0.247, lat.D = 76.1307;
  GantryTruth grav;  // gravel lateral: the slowest rig, m / D = 0.68 s
  grav.axis = "lateral", grav.terrain = "gravel", grav.sigma = 0.0853, grav.D = 23.52;
  const auto res = identify_gantry({tools_test::make_gantry(lon, 1), tools_test::make_gantry(lat, 2),
                                    tools_test::make_gantry(grav, 3)});
  REQUIRE(res.size() == 3);
  for (const auto& r : res) {
    const GantryTruth& t = r.terrain == "gravel" ? grav : r.axis == "lateral" ? lat : lon;
    INFO(r.terrain << " " << r.axis << ": sigma " << r.sigma.value << " [" << r.sigma.lo << ", "
                   << r.sigma.hi << "], D " << r.D.value << " [" << r.D.lo << ", " << r.D.hi << "]");
    CHECK(r.sigma.lo <= t.sigma);
    CHECK(t.sigma <= r.sigma.hi);
    CHECK(r.D.lo <= t.D);
    CHECK(t.D <= r.D.hi);
    // Sand's force is 5-20 times the rig noise: the estimates are tight there.
    if (r.terrain == "sand") {
      CHECK(r.sigma.value == Approx(t.sigma).epsilon(0.05));
      CHECK(r.D.value == Approx(t.D).epsilon(0.10));
    }
    CHECK(r.pieces.size() == 12);  // 3 speeds x 4 repetitions, every one reached steady state
    // The rig vibration (AR(1), rho 0.9, 3 N against 1 N white) makes neighbouring force
    // samples nearly copies: counting them as independent would shrink the interval ~3x.
    CHECK(r.sigma.n_eff < static_cast<double>(r.n_samples) / 5);
    CHECK(r.sigma.n_eff > static_cast<double>(r.n_samples) / 40);
  }
}

TEST_CASE("identify's 95 % intervals cover the truth at their rate over 25 seeds") {
  int covered = 0, total = 0;
  double width_sigma = 0, width_D = 0;
  for (unsigned seed = 100; seed < 125; ++seed) {
    for (int axis = 0; axis < 2; ++axis) {
      GantryTruth tr;
      if (axis == 1) tr.axis = "lateral", tr.sigma = 0.247, tr.D = 76.1307;
      const auto res = identify_gantry({tools_test::make_gantry(tr, seed * 2 + axis)});
      REQUIRE(res.size() == 1);
      const auto& r = res[0];
      covered += (r.sigma.lo <= tr.sigma && tr.sigma <= r.sigma.hi);
      covered += (r.D.lo <= tr.D && tr.D <= r.D.hi);
      total += 2;
      width_sigma += (r.sigma.hi - r.sigma.lo) / tr.sigma / 50;
      width_D += (r.D.hi - r.D.lo) / tr.D / 50;
    }
  }
  INFO("covered " << covered << " of " << total << "; mean relative width sigma " << width_sigma
                  << ", D " << width_D);
  // 95 % nominal: 100 intervals, P(<= 88 covered) < 1 % for a true 95 % interval.
  CHECK(covered >= 89);
  // ... and not by being uselessly wide (measured: 6 % and 7 % of the value on average).
  CHECK(width_sigma < 0.10);
  CHECK(width_D < 0.15);
}

TEST_CASE("auger identify on gantry log files: table, --json, same numbers as the library") {
  const tools_test::TempDir tmp("identify");
  const std::string dir = tmp.path;
  GantryTruth lon, lat;
  lat.axis = "lateral", lat.sigma = 0.247, lat.D = 76.1307;
  const auto g_lon = tools_test::make_gantry(lon, 7), g_lat = tools_test::make_gantry(lat, 8);
  tools_test::write_text(dir + "/lon.csv", tools_test::gantry_log_text(g_lon));
  tools_test::write_text(dir + "/lat.csv", tools_test::gantry_log_text(g_lat));
  // The files hold the values to 10 digits: identify them in memory from the file text's values.
  const auto lib = identify_gantry({read_gantry_data(dir + "/lon.csv"), read_gantry_data(dir + "/lat.csv")});
  REQUIRE(lib.size() == 2);

  const auto json = tools_test::run_auger(dir, "identify " + dir + "/lon.csv " + dir + "/lat.csv --json");
  REQUIRE(json.code == 0);
  CHECK(tools_test::json_eval(dir, json.out, "len(d['groups'])") == "2");
  for (int k = 0; k < 2; ++k) {
    const auto& r = lib[static_cast<std::size_t>(k)];
    const std::string grp = "[g for g in d['groups'] if g['axis'] == '" + r.axis + "'][0]";
    const std::string s = r.axis == "longitudinal" ? "sigma_long" : "sigma_lat";
    const std::string D = r.axis == "longitudinal" ? "D_x" : "D_y";
    CHECK(tools_test::json_number(dir, json.out, grp + "['" + s + "']['value']") == Approx(r.sigma.value).epsilon(2e-5));
    CHECK(tools_test::json_number(dir, json.out, grp + "['" + s + "']['ci'][0]") == Approx(r.sigma.lo).epsilon(2e-5));
    CHECK(tools_test::json_number(dir, json.out, grp + "['" + D + "']['value']") == Approx(r.D.value).epsilon(2e-5));
    CHECK(tools_test::json_number(dir, json.out, grp + "['" + D + "']['ci'][1]") == Approx(r.D.hi).epsilon(2e-5));
  }
  const auto table = tools_test::run_auger(dir, "identify " + dir + "/lon.csv " + dir + "/lat.csv");
  REQUIRE(table.code == 0);
  CHECK_THAT(table.out, Catch::Contains("sigma_long") && Catch::Contains("sigma_lat") &&
                            Catch::Contains("D_x") && Catch::Contains("D_y") && Catch::Contains("95 % interval"));
}

TEST_CASE("identify on the simulator's gantry logs (auger-sim-log --gantry): Table 2 inside the intervals") {
  // The simulator's rig (sim/robot/log_gen_gantry.cpp) is other code than the generator above:
  // encoder-quantised speed telemetry, its own screw lag and noise. Truth: Table 2.
  struct Case {
    const char* axis;
    const char* terrain;
    double sigma, D;
  };
  const Case cases[] = {{"longitudinal", "sand", 0.812, 529.95},
                        {"lateral", "sand", 0.247, 76.1307},
                        {"longitudinal", "gravel", 0.297, 214.78},
                        {"lateral", "gravel", 0.0853, 23.52}};
  const tools_test::TempDir tmp("identify-sim");
  const std::string dir = tmp.path;
  int covered = 0, total = 0;
  for (int seed = 40; seed < 50; ++seed) {
    std::string files;
    for (const Case& c : cases) {
      const std::string f = dir + "/" + c.axis + "_" + c.terrain + "_" + std::to_string(seed) + ".csv";
      const std::string cmd = tools_test::shell_quote(AUGER_SIM_LOG_PATH) + " --out " + tools_test::shell_quote(f) +
                              " --gantry " + c.axis + " --terrain " + c.terrain + " --seed " + std::to_string(seed) +
                              " 2>/dev/null";
      REQUIRE(std::system(cmd.c_str()) == 0);
      files += " " + f;
    }
    const auto r = tools_test::run_auger(dir, "identify" + files + " --json");
    REQUIRE(r.code == 0);
    // One Python call per seed: every group's four interval ends.
    const std::string ends = tools_test::json_eval(
        dir, r.out,
        "' '.join(repr(x) for g in sorted(d['groups'], key=lambda g: (g['terrain'], g['axis'])) "
        "for k in g if k[:2] in ('si', 'D_') for x in g[k]['ci'])");
    std::istringstream is(ends);
    // Sorted: gravel lateral, gravel longitudinal, sand lateral, sand longitudinal.
    for (const Case* c : {&cases[3], &cases[2], &cases[1], &cases[0]}) {
      double s_lo = 0, s_hi = 0, d_lo = 0, d_hi = 0;
      REQUIRE(is >> s_lo >> s_hi >> d_lo >> d_hi);
      covered += (s_lo <= c->sigma && c->sigma <= s_hi) + (d_lo <= c->D && c->D <= d_hi);
      total += 2;
      // Tight as well as right: the simulated rig pins sigma and D to well under 2 %.
      CHECK((s_hi - s_lo) / c->sigma < 0.02);
      CHECK((d_hi - d_lo) / c->D < 0.02);
    }
  }
  INFO("covered " << covered << " of " << total);
  CHECK(covered >= 72);  // 95 % intervals over 80: P(< 72) < 1 % for a true 95 % (measured: 157 of 160 over 20 seeds)
}

// compare (load_dataset) and identify (read_gantry_data) take a gantry log's metadata from the
// one reader (GantryLogReader): the same axis, terrain and mass, and the same refusal.
TEST_CASE("compare and identify read a gantry log's metadata the same way") {
  const tools_test::TempDir tmp("gmeta");
  GantryTruth tr;
  tr.reps = 1;
  const std::string good = tools_test::gantry_log_text(tools_test::make_gantry(tr, 1));
  const std::string body = good.substr(good.find("t_s,"));
  struct Case {
    std::string metadata;
    bool ok;
    std::string axis;
    double mass_kg;
  };
  const std::vector<Case> cases = {
      {"# axis: lateral\n# terrain: gravel\n# mass_kg: 20.5\n", true, "lateral", 20.5},
      {"# axis: longitudinal\n", true, "longitudinal", 16.0},  // the paper's 16 kg when absent
      {"# mass_kg: 1e1\n# axis: lateral\n", true, "lateral", 10.0},
      {"# terrain: sand\n# mass_kg: 20\n", false, "", 0},    // no axis: refused by both
      {"# axis: lateral\n# mass_kg: 20kg\n", false, "", 0},  // not a number: refused by both
      {"# axis: lateral\n# mass_kg: 0\n", false, "", 0},     // outside 0.1..1000 kg
      {"# axis: sideways\n", false, "", 0},
  };
  int k = 0;
  for (const Case& c : cases) {
    const std::string path = tmp.path + "/g" + std::to_string(k++) + ".csv";
    tools_test::write_text(path, "# format: auger-gantry-log v1\n" + c.metadata + body);
    INFO(c.metadata);
    if (c.ok) {
      const Dataset d = load_dataset(path);
      const GantryData g = read_gantry_data(path);
      CHECK(d.gantry);
      CHECK(d.axis == c.axis);
      CHECK(g.axis == c.axis);
      CHECK(d.gantry_mass_kg == c.mass_kg);
      CHECK(g.mass_kg == c.mass_kg);
      CHECK(g.terrain == (d.terrain.empty() ? "unknown" : d.terrain));
      CHECK(d.active[c.axis == "lateral" ? kY : kX]);
    } else {
      std::string a, b;
      try {
        load_dataset(path);
      } catch (const auger::LogError& e) {
        a = e.what();
      }
      try {
        read_gantry_data(path);
      } catch (const auger::LogError& e) {
        b = e.what();
      }
      CHECK_FALSE(a.empty());
      CHECK(a == b);
    }
  }
}
