// Model files (TOML schema 1): the shipped files load; every mistake names file and line.
#include <catch2/catch.hpp>

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
      "priority = \"translation\"\nomega_min_rpm = 2\nestimator = \"dead_reckoning_imu\"\n";  // lines 19-25
  const ModelFile f = parse_model_file(kHead + kRobot + kSand + control, "m.toml");
  const ControllerConfig c = controller_config(f, "sand");
  CHECK(c.gamma_per_s == Vec3(0.2, 0.2, 0.5));
  CHECK(c.gains.kp == Vec3(100, 90, 4));
  CHECK(c.gains.kd == table5_gains("sand").kd);  // not overridden
  CHECK(c.allocator.kind == AllocatorKind::pseudo_inverse);
  CHECK(c.allocator.priority == AllocationPriority::translation);
  CHECK(c.allocator.omega_min_rpm == 2);
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
  CHECK(err("gains = 3\n") == 5);
}
