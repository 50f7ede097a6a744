// Model files (TOML schema 1): the shipped files load; every mistake names file and line.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>

#include "auger/model_file.hpp"

using namespace auger;

namespace {
const std::string kHead = "schema = 1\nomega_unit = \"rpm\"\nframe = \"rep103\"\n";
const std::string kRobot =
    "[robot]\nr_s_m = 0.0775\nphi_deg = 30\nl_x_m = 0.15\nl_y_m = 0.30\nalpha_deg = 26.5\n"
    "m_kg = 29\nI_z_kgm2 = 3.72\nomega_max_rpm = 23\n";                       // lines 4-12
const std::string kSand = "[terrain.sand]\nsigma_long = 0.812\nsigma_lat = 0.247\nD_x = 560.33\n"
                          "D_y = 320.08\nD_psi = 11.46\n";                      // lines 13-18

ConfigError config_error(const std::string& text) {
  try {
    build_model(parse_model_file(text, "m.toml"), "sand");
  } catch (const ConfigError& e) {
    return e;
  }
  FAIL("no ConfigError");
  return ConfigError("", 0, 0, "");
}
}  // namespace

TEST_CASE("shipped models/robot.toml is the paper's robot and terrains") {
  const ModelFile f = load_model_file(AUGER_MODELS_DIR "/robot.toml");
  REQUIRE(f.robot);
  CHECK(f.robot->r_s_m == 0.0775);
  CHECK(f.robot->phi_rad == Approx(kPi / 6));
  CHECK(f.robot->alpha_rad == Approx(deg_to_rad(26.5)));
  CHECK(f.robot->m_kg == 29);
  CHECK(f.robot->I_z_kgm2 == 3.72);
  const Model sand = build_model(f, "sand");
  CHECK(sand.sigma == Vec3(0.812, 0.247, 0.247));
  CHECK(sand.D_diag == Vec3(560.33, 320.08, 11.46));
  const Model grass = build_model(f, "frozen_grass");
  CHECK(grass.sigma == Vec3(0.4, 0.16, 0.16));
  CHECK(grass.D_diag == Vec3(509.81, 210.50, 4.52));
  CHECK_THROWS_AS(build_model(f, "gravel"), ConfigError);
}

TEST_CASE("shipped models/gantry.toml holds Table 2 and is not a robot") {
  const ModelFile f = load_model_file(AUGER_MODELS_DIR "/gantry.toml");
  REQUIRE(f.gantry_mass_kg);
  CHECK(*f.gantry_mass_kg == 16);
  REQUIRE(f.find_terrain("gravel"));
  CHECK(f.find_terrain("gravel")->params.D_y == 23.52);
  CHECK(std::isnan(f.find_terrain("sand")->params.D_psi));
  CHECK_THROWS_AS(build_model(f, "sand"), ConfigError);  // no [robot]
}

TEST_CASE("model file errors name file and line") {
  CHECK_NOTHROW(build_model(parse_model_file(kHead + kRobot + kSand, "m.toml"), "sand"));
  SECTION("unknown key in [robot]") {
    auto e = config_error(kHead + kRobot + "mass = 3\n" + kSand);
    CHECK(e.line() == 13);
    CHECK_THAT(e.what(), Catch::Contains("m.toml:13:") && Catch::Contains("'mass'"));
  }
  SECTION("unknown top-level key") {
    CHECK(config_error("schema = 1\ncolour = \"red\"\n").line() == 2);
  }
  SECTION("missing robot key") {
    std::string r = kRobot;
    r.erase(r.find("m_kg = 29\n"), 10);
    auto e = config_error(kHead + r + kSand);
    CHECK(e.line() == 4);
    CHECK_THAT(e.what(), Catch::Contains("m_kg"));
  }
  SECTION("unknown effect id") {
    auto e = config_error(kHead + kRobot + kSand + "\n[[effect]]\nid = \"warp_drive\"\n");
    CHECK(e.line() == 20);
    CHECK_THAT(e.what(), Catch::Contains("warp_drive") && Catch::Contains("coulomb_friction"));
  }
  SECTION("unknown effect parameter") {
    auto e = config_error(kHead + kRobot + kSand + "[[effect]]\nid = \"coulomb_friction\"\nforce_x_n = 2\nforce_z_n = 1\n");
    CHECK(e.line() == 22);
    CHECK_THAT(e.what(), Catch::Contains("force_z_n"));
  }
  SECTION("units and frame are checked") {
    CHECK(config_error("schema = 1\nomega_unit = \"rad/s\"\n").line() == 2);
    CHECK(config_error("schema = 1\nframe = \"ned\"\n").line() == 2);
    CHECK(config_error("schema = 2\n").line() == 1);
    CHECK_THAT(config_error("omega_unit = \"rpm\"\n").what(), Catch::Contains("schema"));
  }
  SECTION("types and syntax") {
    CHECK(config_error(kHead + "[robot]\nr_s_m = \"big\"\n").line() == 5);
    CHECK(config_error(kHead + "[robot\n").line() == 4);
    CHECK(config_error(kHead + "robot = 3\n").line() == 4);
  }
  SECTION("physically impossible values") {
    std::string r = kRobot;
    r.replace(r.find("m_kg = 29"), 9, "m_kg = -1");
    CHECK_THAT(config_error(kHead + r + kSand).what(), Catch::Contains("m_kg"));
  }
  SECTION("terrain without D_psi cannot drive the robot") {
    std::string t = kSand;
    t.erase(t.find("D_psi"));
    auto e = config_error(kHead + kRobot + t);
    CHECK(e.line() == 13);
  }
}

TEST_CASE("model file effects are created in order") {
  const Model m = build_model(
      parse_model_file(kHead + kRobot + kSand +
                           "[[effect]]\nid = \"screw_dead_band\"\nomega_dead_rpm = 1.5\n"
                           "[[effect]]\nid = \"coulomb_friction\"\nforce_y_n = 4\n",
                       "m.toml"),
      "sand");
  REQUIRE(m.effects.size() == 2);
  CHECK(m.effects[0]->id() == "screw_dead_band");
  CHECK(m.effects[1]->params()[1] == std::make_pair(std::string("force_y_n"), 4.0));
  CHECK(m.effects[1]->params()[0].second == 0.0);  // default
}

TEST_CASE("[control] overrides the defaults; bad values name their line") {
  const std::string control =
      "[control]\ngamma_per_s = [0.2, 0.2, 0.5]\nkp = [100, 90, 4]\nallocator = \"pseudo_inverse\"\n"
      "priority = \"translation\"\nomega_min_rpm = 2\nestimator = \"dead_reckoning_imu\"\nsign_hold_rpm = 0.5\n";  // lines 19-26
  const ModelFile f = parse_model_file(kHead + kRobot + kSand + control, "m.toml");
  const ControllerConfig c = controller_config(f, "sand");
  CHECK(c.gamma_per_s == Vec3(0.2, 0.2, 0.5));
  CHECK(c.gains.kp == Vec3(100, 90, 4));
  CHECK(c.gains.kd == table5_gains("sand").kd);  // not overridden
  CHECK(c.allocator.kind == AllocatorKind::pseudo_inverse);
  CHECK(c.allocator.priority == AllocationPriority::translation);
  CHECK(c.allocator.omega_min_rpm == 2);
  CHECK(c.allocator.sign_hold_rpm == 0.5);
  CHECK(controller_config(parse_model_file(kHead + kRobot, "m.toml"), "sand").allocator.sign_hold_rpm == 0.0);  // off
  CHECK(c.allocator.omega_max_rpm == 23);
  CHECK(c.estimator == EstimatorKind::dead_reckoning_imu);
  CHECK(controller_config(parse_model_file(kHead + kRobot, "m.toml"), "frozen_grass").gains.kd.x() == 90);
  auto err = [&](const std::string& extra) {
    try {
      parse_model_file(kHead + "[control]\n" + extra, "m.toml");
    } catch (const ConfigError& e) {
      return e.line();
    }
    return -1;
  };
  CHECK(err("kp = [1, 2]\n") == 5);
  CHECK(err("gamma_per_s = [1, 2, 3]\nallocator = \"magic\"\n") == 6);
  CHECK(err("kd = [1, -2, 3]\n") == 5);
  CHECK(err("sign_hold_rpm = -1\n") == 5);
  CHECK(err("gains = 3\n") == 5);
}

// ---- the writer: write_model_file -> parse_model_file gives every double back to the bit ----
namespace {
bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Doubles a fit can produce and a printf at 10 digits would not keep: thirds, subnormals, the
// extremes, values an ulp apart, and random bit patterns (finite ones).
std::vector<double> hard_doubles(std::uint64_t seed, std::size_t n) {
  std::vector<double> v = {1.0 / 3, -2.0 / 3, 0.1, 0.812 + 1e-16, std::nextafter(0.812, 1.0),
                           std::numeric_limits<double>::denorm_min(), -std::numeric_limits<double>::denorm_min(),
                           4.9406564584124654e-320, std::numeric_limits<double>::min(),
                           std::nextafter(std::numeric_limits<double>::min(), 0.0),
                           std::numeric_limits<double>::max(), -std::numeric_limits<double>::max(), 1e300 / 3,
                           1e-300 / 3, 123456789012345678.0, 0.0, -0.0, 30.0, 1e22, 9007199254740993.0};
  std::mt19937_64 rng(seed);
  while (v.size() < n) {
    const std::uint64_t bits = rng();
    double d;
    std::memcpy(&d, &bits, sizeof d);
    if (std::isfinite(d)) v.push_back(d);
  }
  return v;
}
}  // namespace

TEST_CASE("write_model_file: every double reads back to the same bits") {
  const std::vector<double> v = hard_doubles(14, 200);
  std::size_t k = 0;
  auto next = [&] { return v[k++ % v.size()]; };
  for (int round = 0; round < 4; ++round) {
    ModelFile f;
    f.comment = "round " + std::to_string(round) + "\nsecond line";
    RobotParams r;
    r.r_s_m = next();
    r.l_x_m = next();
    r.l_y_m = next();
    r.m_kg = next();
    r.I_z_kgm2 = next();
    r.omega_max_rpm = next();
    // Angles come from degrees (as a file gives them): any degree value must come back.
    r.phi_rad = deg_to_rad(next());
    r.alpha_rad = deg_to_rad(1.0 / 3 + round);
    f.robot = r;
    f.gantry_mass_kg = next();
    for (const char* name : {"sand", "gravel"}) {
      TerrainEntry t;
      t.params.name = name;
      t.params.sigma_long = next();
      t.params.sigma_lat = next();
      t.params.D_x = next();
      t.params.D_y = next();
      t.params.D_psi = std::string(name) == "sand" ? next() : std::nan("");
      t.comment = std::string("terrain ") + name;
      f.terrains.push_back(t);
    }
    for (int e = 0; e < 3; ++e) {
      EffectConfig c;
      c.id = "effect_" + std::to_string(e);
      c.comment = "effect " + std::to_string(e);
      for (int p = 0; p < 4; ++p) c.params.push_back({"p" + std::to_string(p), next(), 0, 0});
      f.effects.push_back(c);
    }
    f.control.kp = Vec3(std::fabs(next()), std::fabs(next()), std::fabs(next()));  // the reader wants >= 0
    f.control.omega_min_rpm = std::fabs(next());
    f.control.sign_hold_rpm = std::fabs(next());
    f.control.allocator = AllocatorKind::pseudo_inverse;
    f.control.estimator = EstimatorKind::dead_reckoning_imu;

    const std::string text = write_model_file(f);
    INFO(text);
    CHECK(text.rfind("# round ", 0) == 0);
    CHECK(text.find("# second line\n") != std::string::npos);
    const ModelFile g = parse_model_file(text, "written.toml");
    REQUIRE(g.robot);
    const RobotParams& q = *g.robot;
    for (auto [a, b] : {std::pair{r.r_s_m, q.r_s_m}, {r.l_x_m, q.l_x_m}, {r.l_y_m, q.l_y_m}, {r.m_kg, q.m_kg},
                        {r.I_z_kgm2, q.I_z_kgm2}, {r.omega_max_rpm, q.omega_max_rpm}, {r.phi_rad, q.phi_rad},
                        {r.alpha_rad, q.alpha_rad}, {*f.gantry_mass_kg, *g.gantry_mass_kg}})
      CHECK(same_bits(a, b));
    REQUIRE(g.terrains.size() == 2);  // the reader lists them by name
    for (std::size_t t = 0; t < 2; ++t) {
      const TerrainParams& a = f.terrains[t].params;
      REQUIRE(g.find_terrain(a.name));
      const TerrainParams& b = g.find_terrain(a.name)->params;
      CHECK(same_bits(a.sigma_long, b.sigma_long));
      CHECK(same_bits(a.sigma_lat, b.sigma_lat));
      CHECK(same_bits(a.D_x, b.D_x));
      CHECK(same_bits(a.D_y, b.D_y));
      CHECK((std::isnan(a.D_psi) ? std::isnan(b.D_psi) : same_bits(a.D_psi, b.D_psi)));
    }
    REQUIRE(g.effects.size() == 3);
    for (std::size_t e = 0; e < 3; ++e) {
      CHECK(g.effects[e].id == f.effects[e].id);
      REQUIRE(g.effects[e].params.size() == 4);
      for (const auto& p : f.effects[e].params) {
        bool found = false;
        for (const auto& p2 : g.effects[e].params)
          if (p2.name == p.name) found = same_bits(p.value, p2.value);
        CHECK(found);
      }
    }
    REQUIRE(g.control.kp);
    for (int i = 0; i < 3; ++i) CHECK(same_bits((*f.control.kp)[i], (*g.control.kp)[i]));
    CHECK(same_bits(*f.control.omega_min_rpm, *g.control.omega_min_rpm));
    REQUIRE(g.control.sign_hold_rpm);
    CHECK(same_bits(*f.control.sign_hold_rpm, *g.control.sign_hold_rpm));
    CHECK(g.control.allocator == AllocatorKind::pseudo_inverse);
    CHECK(g.control.estimator == EstimatorKind::dead_reckoning_imu);
    CHECK_FALSE(g.control.kd);
    // And the text is stable: written again from what was read, it is the same.
    ModelFile h = g;
    h.comment = f.comment;
    for (std::size_t t = 0; t < 2; ++t) h.terrains[t] = *g.find_terrain(f.terrains[t].params.name);
    for (std::size_t t = 0; t < 2; ++t) h.terrains[t].comment = f.terrains[t].comment;
    for (std::size_t e = 0; e < 3; ++e) h.effects[e].comment = f.effects[e].comment;
    CHECK(write_model_file(h) == text);
  }
}

TEST_CASE("write_model_file: the shipped robot model reads back the same") {
  ModelFile f = load_model_file(AUGER_MODELS_DIR "/robot.toml");
  const ModelFile g = parse_model_file(write_model_file(f), "again.toml");
  for (const std::string terrain : {"sand", "frozen_grass"}) {
    const Model a = build_model(f, terrain), b = build_model(g, terrain);
    CHECK(a.sigma == b.sigma);
    CHECK(a.D_diag == b.D_diag);
    CHECK(a.K_i == b.K_i);
    CHECK(a.B == b.B);
    CHECK(a.M_diag == b.M_diag);
  }
}
