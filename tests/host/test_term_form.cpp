// The discovered term (auger/term_form.hpp, effect `term`): its dof and form parsed with errors
// that name what is wrong, its value and force against hand calculation (eqs. (6)-(7)), its units,
// and a model file that carries it (text parameters) reading back to the same term.
#include <cmath>

#include <catch2/catch.hpp>

#include "auger/effect.hpp"
#include "auger/model_file.hpp"
#include "auger/term_form.hpp"

using namespace auger;

namespace {
const TerrainParams kSand{"sand", 0.812, 0.247, 560.33, 320.08, 11.46};
}  // namespace

TEST_CASE("term form: parsed to a canonical spelling; a bad dof, function, input or mix is refused by name") {
  const TermForm f("yaw", " u_mps * sign( v_mps ) ");
  CHECK(f.dof() == TermDof::kYaw);
  CHECK(f.form_text() == "u_mps*sign(v_mps)");
  CHECK(f.input_names() == std::vector<std::string>{"u_mps", "v_mps"});
  CHECK_THROWS_WITH(TermForm("z", "u_mps"), Catch::Contains("'z'") && Catch::Contains("screws"));
  CHECK_THROWS_WITH(TermForm("x", "tanh(u_mps)"), Catch::Contains("'tanh'"));
  CHECK_THROWS_WITH(TermForm("x", "speed"), Catch::Contains("'speed'") && Catch::Contains("u_mps"));
  CHECK_THROWS_WITH(TermForm("x", "u_mps*v_mps*r_radps"), Catch::Contains("two factors"));
  CHECK_THROWS_WITH(TermForm("x", "sign(u_mps"), Catch::Contains("')'"));
  CHECK_THROWS_WITH(TermForm("x", "neg(omega_rpm)"), Catch::Contains("screw dof"));
  CHECK_THROWS_WITH(TermForm("screw_1", "u_mps"), Catch::Contains("own omega_rpm"));
  CHECK_THROWS(TermForm("x", ""));
  // A screw's own speed names its screw; every screw's, all four.
  CHECK(TermForm("screw_2", "neg(omega_rpm)").input_names() == std::vector<std::string>{"omega_rpm_2"});
  CHECK(TermForm("screws", "omega_rpm*t_s").input_names().size() == 5);
  // Beside its own speed a screw's term may read the body's motion; alone it may not.
  CHECK(TermForm("screws", "omega_rpm*abs(r_radps)").input_names().back() == "r_radps");
  CHECK_THROWS_WITH(TermForm("screw_0", "t_s*abs(r_radps)"), Catch::Contains("own omega_rpm"));
}

TEST_CASE("term form: values of the functions, the force through S B for a screw, units of the coefficient") {
  TermInputs in;
  in.zeta = Vec3(0.1, -0.2, 0.3);
  in.eta = Vec3(1, 2, 0.5);
  in.omega_rpm = Vec4(-4, 3, -5, 6);
  in.t_s = 10;
  CHECK(TermForm("x", "sqs(v_mps)").value(in) == Approx(-0.04));
  CHECK(TermForm("x", "sq(v_mps)").value(in) == Approx(0.04));
  CHECK(TermForm("x", "abs(v_mps)*cos2(psi_rad)").value(in) == Approx(0.2 * std::cos(1.0)));
  CHECK(TermForm("x", "1").value(in) == 1.0);
  CHECK(TermForm("screw_0", "pos(omega_rpm)").value(in, 0) == 0.0);
  CHECK(TermForm("screw_0", "neg(omega_rpm)").value(in, 0) == -4.0);
  CHECK(TermForm("screw_3", "omega_rpm*t_s").value(in, 3) == Approx(60.0));
  CHECK(TermForm("screws", "omega_rpm*abs(r_radps)").value(in, 2) == Approx(-1.5));
  const Model m = make_model(RobotParams{}, kSand, {});
  // Screw 2 turning backwards at 5 rpm, its thrust 30 % weaker: -0.3 x (-5) rpm more through its
  // column of S B (eq. (7)); a body dof puts c x value on its own axis only.
  const Vec3 f2 = TermForm("screw_2", "neg(omega_rpm)").force(m, in, -0.3);
  CHECK((f2 - m.SB.col(2) * 1.5).norm() < 1e-12);
  const Vec3 fy = TermForm("y", "u_mps").force(m, in, 40);
  CHECK(fy.x() == 0.0);
  CHECK(fy.y() == Approx(4.0));
  CHECK(fy.z() == 0.0);
  const Vec3 all = TermForm("screws", "omega_rpm").force(m, in, 0.5);
  CHECK((all - m.SB * (0.5 * in.omega_rpm)).norm() < 1e-12);
  CHECK(TermForm("x", "sqs(u_mps)").coefficient_unit() == "N/(m/s)^2");
  CHECK(TermForm("yaw", "v_mps").coefficient_unit() == "N m/(m/s)");
  CHECK(TermForm("x", "sign(u_mps)").coefficient_unit() == "N");
  CHECK(TermForm("screw_1", "neg(omega_rpm)").coefficient_unit() == "-");
  CHECK(TermForm("y", "u_mps*r_radps").coefficient_unit() == "N/(m/s rad/s)");
  CHECK(TermForm("screws", "omega_rpm*t_s").coefficient_unit() == "rpm/(rpm s)");
  // The ground's drag D zeta of eq. (6) on every axis alike, grown by c x form: at t = 10 s and
  // c = 0.005 1/s, 5 % more drag against the motion on each axis; it reads the body velocity.
  const Vec3 drag = TermForm("drag", "t_s").force(m, in, 0.005);
  for (int k = 0; k < 3; ++k) CHECK(drag[k] == Approx(-0.05 * m.D_diag[k] * in.zeta[k]));
  CHECK(drag.x() < 0);
  CHECK(drag.y() > 0);
  CHECK(TermForm("drag", "t_s").coefficient_unit() == "1/s");
  CHECK(TermForm("drag", "x_m").coefficient_unit() == "1/m");
  CHECK(TermForm("drag", "sin(psi_rad)").coefficient_unit() == "-");
  CHECK(TermForm("drag", "t_s").input_names() == std::vector<std::string>{"u_mps", "v_mps", "r_radps", "t_s"});
  CHECK(TermForm("drag", "t_s").describe(0.005).find("drag") != std::string::npos);
  CHECK_THROWS_WITH(TermForm("drag", "omega_rpm"), Catch::Contains("screw dof"));
}

TEST_CASE("term effect: from a model file with its dof and form as texts; written back the same; wrong kinds named") {
  const std::string head =
      "schema = 1\nomega_unit = \"rpm\"\nframe = \"rep103\"\n[robot]\nr_s_m = 0.0775\nphi_deg = 30\nl_x_m = 0.15\n"
      "l_y_m = 0.30\nalpha_deg = 26.5\nm_kg = 29\nI_z_kgm2 = 3.72\nomega_max_rpm = 23\n[terrain.sand]\nsigma_long = 0.812\nsigma_lat = 0.247\n"
      "D_x = 560.33\nD_y = 320.08\nD_psi = 11.46\n";
  const std::string term = "[[effect]]\nid = \"term\"\ndof = \"screw_2\"\nform = \"neg(omega_rpm)\"\ncoefficient = -0.3\n";
  const ModelFile f = parse_model_file(head + term, "t.toml");
  const Model m = build_model(f, "sand");
  REQUIRE(m.effects.size() == 1);
  CHECK(m.effects[0]->id() == "term");
  CHECK(m.effects[0]->params()[0].second == -0.3);
  CHECK(m.effects[0]->text_params()[1].second == "neg(omega_rpm)");
  // Its body force is the form's (a step's context as the dynamics give it).
  EffectContext ctx;
  ctx.eta.setZero();
  ctx.zeta.setZero();
  ctx.omega_rpm = Vec4(0, 0, -5, 0);
  Vec3 force;
  m.effects[0]->body_force(m, ctx, force, nullptr);
  CHECK((force - m.SB.col(2) * 1.5).norm() < 1e-12);
  // Written and read again: the same texts and coefficient.
  ModelFile again = f;
  again.effects.clear();
  EffectConfig c;
  c.id = "term";
  for (const auto& [n, v] : m.effects[0]->params()) c.params.push_back({n, v, 0, 0});
  for (const auto& [n, v] : m.effects[0]->text_params()) c.texts.push_back({n, v, 0, 0});
  again.effects.push_back(c);
  const Model back = build_model(parse_model_file(write_model_file(again), "again.toml"), "sand");
  CHECK(back.effects[0]->text_params() == m.effects[0]->text_params());
  CHECK(back.effects[0]->params() == m.effects[0]->params());
  // A number where a text belongs, a text where a number does, a missing form, a bad form: named.
  auto error_of = [&](const std::string& body) {
    try {
      build_model(parse_model_file(head + body, "bad.toml"), "sand");
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  CHECK_THAT(error_of("[[effect]]\nid = \"term\"\ndof = 2\nform = \"u_mps\"\ncoefficient = 1\n"),
             Catch::StartsWith("bad.toml:21:") && Catch::Contains("'dof' must be a text"));
  CHECK_THAT(error_of("[[effect]]\nid = \"term\"\ndof = \"x\"\nform = \"u_mps\"\ncoefficient = \"big\"\n"),
             Catch::Contains("'coefficient' must be a number"));
  CHECK_THAT(error_of("[[effect]]\nid = \"term\"\ndof = \"x\"\ncoefficient = 1\n"), Catch::Contains("needs the text 'form'"));
  CHECK_THAT(error_of("[[effect]]\nid = \"term\"\ndof = \"x\"\nform = \"wobble(u_mps)\"\ncoefficient = 1\n"),
             Catch::StartsWith("bad.toml:19:") && Catch::Contains("'wobble'"));
  CHECK_THAT(error_of("[[effect]]\nid = \"coulomb_friction\"\nforce_x_n = \"4\"\n"),
             Catch::Contains("'force_x_n' must be a number"));
}
