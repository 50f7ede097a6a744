// Fields (sim/robot/field.hpp, docs/robot-sim.md "Fields"): the file's errors, which zone a point
// lies in, and the true robot taking each contact's terrain from the zone under it.
#include <catch2/catch.hpp>

#include <memory>

#include "auger/dynamics.hpp"
#include "field.hpp"
#include "robot_fixtures.hpp"

using namespace auger;
using namespace auger::sim;
using namespace robot_test;

namespace {

Field parse(const std::string& text) { return parse_field(text, "f.toml", model_file()); }

// The message of the ConfigError that parsing text throws ("" if it parses).
std::string error_of(const std::string& text) {
  try {
    parse(text);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

const std::string kHead = "schema = 1\nterrain = \"sand\"\n";

// Sand, with frozen grass where the coordinate `axis` (0: x, 1: y) exceeds 1 m.
std::shared_ptr<const Field> grass_beyond(int axis) {
  const std::string rect = axis == 0 ? "[1.0, -50.0, 50.0, 50.0]" : "[-50.0, 1.0, 50.0, 50.0]";
  return std::make_shared<const Field>(parse(kHead + "[[patch]]\nterrain = \"frozen_grass\"\nrect = " + rect + "\n"));
}

// Steady body velocity of the nominal model when each contact i carries its zone's terrain:
// translation sums each screw's traction (eq. (7) per screw) and a quarter of each zone's D.
Vec3 mixed_steady(const std::array<const Model*, 4>& at, const Vec4& omega_rpm) {
  Vec3 f = Vec3::Zero();
  double d_x = 0, d_y = 0;
  for (int i = 0; i < 4; ++i) {
    f[0] += at[static_cast<std::size_t>(i)]->SB(0, i) * omega_rpm[i];
    f[1] += at[static_cast<std::size_t>(i)]->SB(1, i) * omega_rpm[i];
    d_x += at[static_cast<std::size_t>(i)]->D_diag[0] / 4;
    d_y += at[static_cast<std::size_t>(i)]->D_diag[1] / 4;
  }
  return Vec3(f[0] / d_x, f[1] / d_y, 0);
}

}  // namespace

TEST_CASE("field files: bad input is an error naming file, line and column", "[robot][field]") {
  const std::string patch = "[[patch]]\nterrain = \"frozen_grass\"\n";
  struct Case {
    std::string text, want;
  };
  const Case cases[] = {
      {"schema = 1\nterrain = \"sand\n", "f.toml:2:"},  // TOML syntax: an unterminated string
      {"terrain = \"sand\"\n", "f.toml:1:1: the field needs 'schema = 1'"},
      {"schema = 2\nterrain = \"sand\"\n", "f.toml:1:10: 'schema' must be 1"},
      {"schema = 1\n", "f.toml:1:1: the field needs 'terrain'"},
      {"schema = 1\nterrain = \"mud\"\n", "f.toml:2:11: terrain 'mud' is not in the model file"},
      {"schema = 1\nterrain = \"sand\"\nspeed = 3\n", "f.toml:3:9: unknown key 'speed'"},
      {kHead + patch + "rect = [0, 0, 1]\n", "f.toml:5:8: 'rect' must be [x_min_m, y_min_m, x_max_m, y_max_m]"},
      {kHead + patch + "rect = [1, 0, 0, 1]\n", "f.toml:5:8: 'rect' needs x_min < x_max"},
      {kHead + patch + "polygon = [[0, 0], [1, 0]]\n", "f.toml:5:11: 'polygon' needs at least 3 distinct points, has 2"},
      {kHead + patch + "polygon = [[0, 0], [1, 0], [2, 0]]\n", "f.toml:5:11: 'polygon' encloses no area"},
      {kHead + patch + "polygon = [[0, 0], [1, 1], [1, 0], [0, 1]]\n", "f.toml:5:11: 'polygon' crosses itself: edge 1 meets edge 3"},
      {kHead + patch + "polygon = [[0, 0], [1, \"a\"], [1, 1]]\n", "f.toml:5:24: 'polygon' must be a number"},
      {kHead + patch + "polygon = [[0, 0], [1, 0, 2], [1, 1]]\n", "f.toml:5:20: each point of 'polygon' must be [x_m, y_m]"},
      {kHead + patch + "rect = [0, 0, 1, 1]\npolygon = [[0, 0], [1, 0], [1, 1]]\n", "f.toml:5:8: patch 'patch 1' has both"},
      {kHead + patch, "f.toml:3:1: patch 'patch 1' needs 'polygon' or 'rect'"},
      {kHead + "[[patch]]\nname = \"wet\"\nrect = [0, 0, 1, 1]\n", "f.toml:3:1: patch 'wet' needs 'terrain'"},
      {kHead + patch + "rect = [0, 0, 1, 1]\nsigma_scale = 0\n", "f.toml:6:15: 'sigma_scale' must be > 0"},
      {kHead + patch + "rect = [0, 0, 1, 1]\nblocking_rpm = -1\n", "f.toml:6:16: 'blocking_rpm' must be >= 0"},
      {kHead + patch + "rect = [0, 0, 1, 1]\ncolour = \"green\"\n", "f.toml:6:10: unknown key 'colour' in [[patch]]"},
      {kHead + "patch = 3\n", "f.toml:3:9: 'patch' must be [[patch]] tables"},
  };
  for (const Case& c : cases) {
    INFO(c.text);
    const std::string got = error_of(c.text);
    INFO("error: " << got);
    CHECK(got.find(c.want) == 0);
  }
  CHECK(error_of("schema = 1\nterrain = \"mud\"\n").find("(known: frozen_grass, sand)") != std::string::npos);
  CHECK_THROWS_WITH(load_field("/nonexistent/field.toml", model_file()),
                    "/nonexistent/field.toml:0:0: cannot read the field file");
  // The shipped example parses: sand, with a band of frozen grass.
  const Field ex = load_field(AUGER_FIELDS_DIR "/sand-grass.toml", model_file());
  REQUIRE(ex.zones.size() == 2);
  CHECK(ex.terrain_names == std::vector<std::string>{"sand", "frozen_grass"});
  CHECK(ex.zone_at(0.75, 0.0) == 1);
  CHECK(ex.zone_at(0.0, 0.0) == 0);
}

TEST_CASE("field files: the zone at a point; later patches on top; shared edges belong to one", "[robot][field]") {
  const Field f = parse(std::string(kHead) +
                        "[[patch]]\nname = \"L\"\nterrain = \"frozen_grass\"\n"
                        "polygon = [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2], [0, 0]]\n"  // closed ring
                        "[[patch]]\nname = \"wet corner\"\nterrain = \"sand\"\nsigma_scale = 0.5\ndrag_scale = 2\n"
                        "rect = [1.5, 0.5, 3, 0.8]\n"
                        "[[patch]]\nname = \"beside\"\nterrain = \"frozen_grass\"\nrect = [-1, 0, 0, 2]\n");
  REQUIRE(f.zones.size() == 4);
  CHECK(f.zones[1].polygon.size() == 6);  // the repeated first point is dropped
  CHECK(f.zone_at(0.5, 0.5) == 1);
  CHECK(f.zone_at(1.5, 1.5) == 0);   // the L's notch
  CHECK(f.zone_at(0.5, 1.5) == 1);
  CHECK(f.zone_at(1.8, 0.6) == 2);   // the later patch lies on top
  CHECK(f.zone_at(2.5, 0.6) == 2);
  CHECK(f.zone_at(1.2, 0.6) == 1);
  CHECK(f.zone_at(-0.5, 1.0) == 3);
  CHECK(f.zone_at(5, 5) == 0);
  // The edge x = 0 between "beside" and the L: every point of it is in exactly one of the two.
  for (double y = 0.05; y < 2.0; y += 0.1) {
    const bool in_l = point_in_polygon(f.zones[1].polygon, 0.0, y), in_b = point_in_polygon(f.zones[3].polygon, 0.0, y);
    CHECK(in_l != in_b);
  }
  // The scales act on the model file's row; terrain ids in order of first use.
  CHECK(f.zones[2].terrain.sigma_long == Approx(0.5 * 0.812));
  CHECK(f.zones[2].terrain.D_y == Approx(2 * 320.08));
  CHECK(f.zones[2].terrain_id == 0);
  CHECK(f.zones[3].terrain_id == 1);
  CHECK(terrain_ids_metadata(f) == "0=sand 1=frozen_grass");
  // Blocking: a patch's own value, else the caller's, else 1.5 rpm on sand only.
  Field g = parse(kHead + "[[patch]]\nterrain = \"sand\"\nblocking_rpm = 2.5\nrect = [0, 0, 1, 1]\n"
                                       "[[patch]]\nterrain = \"frozen_grass\"\nrect = [2, 0, 3, 1]\n");
  Field h = g;
  default_blocking(g, std::nullopt);
  CHECK(*g.zones[0].blocking_rpm == 1.5);
  CHECK(*g.zones[1].blocking_rpm == 2.5);
  CHECK(*g.zones[2].blocking_rpm == 0.0);
  default_blocking(h, 1.0);
  CHECK(*h.zones[0].blocking_rpm == 1.0);
  CHECK(*h.zones[1].blocking_rpm == 2.5);
  CHECK(*h.zones[2].blocking_rpm == 1.0);
}

TEST_CASE("fields: a field of one terrain is exactly the robot without a field", "[robot][field]") {
  const Model m = nominal("sand");
  TruthParams plain;
  plain.blocking.on = true;
  TruthParams with = plain;
  auto f = std::make_shared<Field>(parse(kHead));
  default_blocking(*f, std::nullopt);
  with.field = f;
  TrueRobot a(m, plain), b(m, with);
  // Forward and turning, then screws 1 and 3 below the blocking speed.
  for (int k = 0; k < 1500; ++k) {
    const Vec4 omega = k < 1000 ? Vec4(12 * kForward + 4 * kYaw + 3 * kLateral) : Vec4(10, 0.5, 10, -1);
    a.step(omega, 0.01);
    b.step(omega, 0.01);
  }
  CHECK(a.state().eta == b.state().eta);  // bit for bit
  CHECK(a.state().zeta == b.state().zeta);
  CHECK(a.load_torque_nm() == b.load_torque_nm());
  CHECK(a.state().eta.head<2>().norm() > 0.5);
}

TEST_CASE("fields: crossing onto frozen grass, the robot's speed changes as each contact's sigma and D predict",
          "[robot][field]") {
  const Model sand = nominal("sand"), grass = nominal("frozen_grass");
  // Forward across x = 1 m, then sideways across y = 1 m: on sand, with the front (or left) pair
  // of contacts on grass, then all four on grass.
  struct Run {
    int axis;
    Vec4 omega;
    std::array<int, 4> first_pair;  // the contacts that cross first
  };
  for (const Run& run : {Run{0, 15 * kForward, {0, 3, -1, -1}}, Run{1, 15 * kLateral, {2, 3, -1, -1}}}) {
    TruthParams tp;
    tp.field = grass_beyond(run.axis);
    TrueRobot robot(sand, tp);
    const Model* all_sand[4] = {&sand, &sand, &sand, &sand};
    std::array<const Model*, 4> mixed{&sand, &sand, &sand, &sand};
    mixed[static_cast<std::size_t>(run.first_pair[0])] = mixed[static_cast<std::size_t>(run.first_pair[1])] = &grass;
    const Vec3 want[3] = {mixed_steady({all_sand[0], all_sand[1], all_sand[2], all_sand[3]}, run.omega),
                          mixed_steady(mixed, run.omega), mixed_steady({&grass, &grass, &grass, &grass}, run.omega)};
    // The half-extent of the contacts along the crossing: l_x (forward) or l_y (sideways).
    const double half = run.axis == 0 ? sand.robot.l_x_m : sand.robot.l_y_m;
    int seen[3] = {0, 0, 0};
    int last_phase = 0;
    double phase_start_s = 0;
    for (int k = 0; k < 6000 && robot.state().eta[run.axis] < 1.0 + half + 0.3; ++k) {
      robot.step(run.omega, 0.01);
      const double c = robot.state().eta[run.axis];
      const std::array<int, 4> z = robot.contact_zones(robot.state());
      const int on_grass = z[0] + z[1] + z[2] + z[3];
      const int phase = c < 1.0 - half ? 0 : c < 1.0 + half ? 1 : 2;
      CHECK(on_grass == (phase == 0 ? 0 : phase == 1 ? 2 : 4));
      if (phase != last_phase) phase_start_s = robot.t_s(), last_phase = phase;
      if (robot.t_s() - phase_start_s < 1.0 || robot.t_s() < 1.0) continue;  // m / D_y <= 0.14 s: settled
      const double got = robot.state().zeta[run.axis], expect = want[phase][run.axis];
      INFO("axis " << run.axis << " at " << c << " m, phase " << phase << ": " << got << " m/s, predicted " << expect);
      CHECK(std::fabs(got / expect - 1.0) < 0.002);
      CHECK(std::fabs(robot.state().eta[2]) < 1e-3);  // the symmetric pairs make no turn
      ++seen[phase];
    }
    CHECK(seen[0] > 100);
    CHECK(seen[1] > 100);
    CHECK(seen[2] > 10);
    // What the crossing changes in steady speed: 46 % forward, only 1.5 % sideways (sigma_lat / D_y
    // is nearly the same on both terrains); either is well above the tolerance above.
    CHECK(std::fabs(want[2][run.axis] / want[0][run.axis] - 1) > (run.axis == 0 ? 0.4 : 0.01));
  }
}

TEST_CASE("fields: blocking follows the ground under each stopped screw", "[robot][field]") {
  // Screws 0 and 2 alone at 23 rpm along the force diagonal: on sand (blocking) the stopped 1 and 3 hold the robot; on
  // frozen grass (no blocking) it moves (docs/model-notes.md "Blocking").
  const Model sand = nominal("sand");
  auto run = [&](const std::string& text) {
    auto f = std::make_shared<Field>(parse(text));
    default_blocking(*f, std::nullopt);
    TruthParams tp;
    tp.field = f;
    TrueRobot robot(sand, tp);
    for (int k = 0; k < 1000; ++k) robot.step(Vec4(-23, 0, 23, 0), 0.01);
    return robot.state().eta.head<2>().norm();
  };
  const double on_sand = run(kHead);
  const double on_grass = run(kHead + "[[patch]]\nterrain = \"frozen_grass\"\nrect = [-5, -5, 5, 5]\n");
  CHECK(on_sand < 0.02);
  CHECK(on_grass > 0.3);
}

TEST_CASE("fields: the scheduler's records and truth log carry the ground under the robot", "[robot][field]") {
  const Model m = nominal("sand");
  TruthParams tp;
  tp.field = grass_beyond(0);
  SchedulerConfig sc;
  sc.log_truth = true;
  Scheduler s(m, tp, sc);
  std::ostringstream log;
  s.set_log(&log);
  s.set_command_source([](double, Vec4& cmd) {
    cmd = 20 * kForward;
    return true;
  });
  int changes = 0, last = 0;
  s.set_tick_sink([&](const TickRecord& r) {
    const int want = r.eta_true[0] < 1.0 ? 0 : 1;  // the body's centre
    CHECK(r.zone == want);
    if (r.zone != last) ++changes, last = r.zone;
  });
  s.run_until(25.0);
  CHECK(changes == 1);
  const std::string text = log.str();
  CHECK(text.find("# terrain_ids: 0=sand 1=frozen_grass\n") != std::string::npos);
  CHECK(text.find(",terrain_id,terrain_id_0,terrain_id_1,terrain_id_2,terrain_id_3,zone,true_sigma_long") !=
        std::string::npos);
}
