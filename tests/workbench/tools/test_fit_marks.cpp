// A model file's `online = true` marks (docs/model.md) survive `auger fit --out`: the refitted
// file keeps them on the same parameters, so augerd goes on estimating what it estimated.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <string>

#include "auger/effect.hpp"
#include "auger/model_file.hpp"
#include "auger/online_estimator.hpp"
#include "tools_fixtures.hpp"

namespace {
// The online-marked parameters of a model file as "effect.parameter=value" lines.
std::string marks_of(const auger::ModelFile& f) {
  std::string out;
  for (const auger::EffectConfig& c : f.effects)
    for (const auger::EffectParamValue& p : c.params)
      if (p.online) out += c.id + "." + p.name + "\n";
  return out;
}
}  // namespace

TEST_CASE("fit --out keeps the model file's online marks on the same parameters") {
  const tools_test::TempDir tmp("fit-marks");
  const std::string dir = tmp.path, log = dir + "/log.csv", marked = dir + "/marked.toml", out = dir + "/out.toml";
  REQUIRE(std::system((tools_test::shell_quote(AUGER_SIM_LOG_PATH) + " --out " + tools_test::shell_quote(log) +
                       " --seconds 60 --seed 3 2>/dev/null").c_str()) == 0);
  // The robot's file with a slope (x online, y not) and a drag (x online, the others not).
  tools_test::write_text(marked, tools_test::read_text(std::string(AUGER_SOURCE_DIR) + "/models/robot.toml") +
                                     "\n[[effect]]\nid = \"terrain_slope\"\nincline_x_rad = { value = 0.0, online = true }\n"
                                     "incline_y_rad = 0.0\n\n[[effect]]\nid = \"quadratic_drag\"\n"
                                     "c_x_nspm2 = { value = 5.0, online = true }\n");
  const auger::ModelFile before = auger::load_model_file(marked);
  REQUIRE(marks_of(before) == "terrain_slope.incline_x_rad\nquadratic_drag.c_x_nspm2\n");
  const auto r = tools_test::run_auger(dir, "fit " + log + " --model " + marked + " --add paper_params --out " + out);
  INFO(r.out << r.err);
  REQUIRE(r.code == 0);
  const auger::ModelFile after = auger::load_model_file(out);
  CHECK(marks_of(after) == marks_of(before));
  // The fit changed values (the terrain re-identified), and the marked ones read back as numbers.
  REQUIRE(after.terrains.size() == 1);
  CHECK(after.terrains.front().params.sigma_long != before.find_terrain("sand")->params.sigma_long);
  REQUIRE(after.effects.size() == 2);
  for (const auger::EffectParamValue& p : after.effects[1].params)
    if (p.name == "c_x_nspm2") CHECK(p.value == 5.0);
  // What augerd reads: the same parameters online.
  const auto p = auger::online_effect_params(after, auger::EffectRegistry::builtin());
  REQUIRE(p.size() == 2);
  CHECK(p[0].name == "terrain_slope.incline_x_rad");
  CHECK(p[1].name == "quadratic_drag.c_x_nspm2");
}
