// Unit tests of auger explain (host/wb_engine/explain.hpp) on synthetic logs made with the host
// model (engine_synth.hpp): two effects at once, a clean log, a terrain change inside a held-out
// segment, several logs, physics outside the library and its discovered term, parsimony, near
// ties and possible stand-ins.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

#include "engine_synth.hpp"
#include "explain_internal.hpp"  // terms_accepted (the rule itself)
#include "fitting.hpp"  // flag_params (the plausibility rule itself), make_part, fitted_effect
#include "workbench.hpp"

using namespace auger;
using namespace auger::wb;
using namespace auger::wb::test;

TEST_CASE("explain: two effects at once are both named, jointly fitted, and the error falls to the noise", "[slow]") {
  SynthOptions o;
  o.seconds = 90;
  const Model truth = make_model(RobotParams{}, kSand,
                                 {entry("screw_dead_band").make({2.0, 1}), entry("resistance_offset").make({0.03, 0.0})});
  ExplainOptions eo;
  eo.only = {"screw_dead_band", "resistance_offset", "coulomb_friction", "quadratic_drag"};
  const ExplainResult r = explain({synth(truth, o)}, {nominal()}, eo);
  INFO(r.verdict);
  REQUIRE(r.steps.size() >= 3);
  CHECK(std::find(r.effects.begin(), r.effects.end(), "screw_dead_band") != r.effects.end());
  CHECK(std::find(r.effects.begin(), r.effects.end(), "resistance_offset") != r.effects.end());
  CHECK(r.effects.size() == 2);
  // The held-out error falls at every step and ends at the noise.
  for (std::size_t i = 1; i < r.steps.size(); ++i) CHECK(r.steps[i].heldout_combined < r.steps[i - 1].heldout_combined);
  for (int c = 0; c < kChannels; ++c) CHECK(r.final_ratio[static_cast<std::size_t>(c)] < 1.15);
  CHECK(r.verdict_kind == "noise");
  // The model file reads back to the model explain judged (same doubles).
  const Model back = build_model(parse_model_file(r.model_toml, "explained"), "sand");
  REQUIRE(back.effects.size() == r.final_models.front().model.effects.size());
  for (std::size_t e = 0; e < back.effects.size(); ++e) {
    const auto a = back.effects[e]->params(), b = r.final_models.front().model.effects[e]->params();
    for (std::size_t i = 0; i < a.size(); ++i) CHECK(a[i].second == b[i].second);
  }
  CHECK(back.terrain.D_x == r.final_models.front().model.terrain.D_x);
}

TEST_CASE("explain: a clean log adds nothing; an effect that does not pay for itself is dropped") {
  SynthOptions o;
  o.seconds = 70;
  o.seed = 5;
  ExplainOptions eo;
  eo.only = {"coulomb_friction", "quadratic_drag", "terrain_slope"};
  const ExplainResult clean = explain({synth(nominal().model, o)}, {nominal()}, eo);
  CHECK(clean.effects.empty());
  CHECK(clean.verdict_kind == "noise");
  // A model file that carries a dry friction the log does not have: the backward check (or the
  // first step) takes it out rather than keeping it at zero cost.
  const ModelChoice given = with_effects({entry("quadratic_drag").make({2000, 2000, 0})});
  const Model truth = make_model(RobotParams{}, kSand, {std::make_shared<CoulombFriction>(Vec3(8, 5, 0.3))});
  const ExplainResult r = explain({synth(truth, o)}, {given}, eo);
  INFO(r.verdict);
  CHECK(std::find(r.effects.begin(), r.effects.end(), "coulomb_friction") != r.effects.end());
  CHECK(std::find(r.effects.begin(), r.effects.end(), "quadratic_drag") == r.effects.end());
  bool dropped = false;
  for (const auto& s : r.steps)
    for (const auto& d : s.dropped) dropped = dropped || d == "quadratic_drag";
  CHECK(dropped);
}

TEST_CASE("explain: a change of terrain inside a held-out segment is placed there, not anywhere in the gap", "[slow]") {
  // 90 s: segments of 12.9 s, every third held out; 71 s lies in the held-out 64.3-77.1 s, where
  // no training segment can say when the terrain changed.
  SynthOptions o;
  o.seconds = 90;
  o.seed = 4;
  const Model truth = make_model(RobotParams{}, kSand, {entry("terrain_change").make({71.0, 0.65, 1.3})});
  ExplainOptions eo;
  eo.only = {"terrain_change", "coulomb_friction", "quadratic_drag"};
  const ExplainResult r = explain({synth(truth, o)}, {nominal()}, eo);
  INFO(r.verdict);
  REQUIRE(r.effects == std::vector<std::string>{"terrain_change"});
  REQUIRE(r.steps.size() >= 2);
  // The step that added the change reads its held-out segment at the noise: placed anywhere else
  // in the gap, that segment carries seconds of the wrong terrain.
  CHECK(r.steps[1].heldout_combined < 1.15);
  CHECK(param_of(r, "terrain_change", "t_change_s") == Approx(71.0).margin(0.5));
  for (int c = 0; c < kChannels; ++c) CHECK(r.final_ratio[static_cast<std::size_t>(c)] < 1.2);
}

TEST_CASE("explain: several logs of one robot are explained together with shared parameters", "[slow]") {
  SynthOptions o;
  o.seconds = 60;
  const Model truth = make_model(RobotParams{}, kSand, {std::make_shared<CoulombFriction>(Vec3(8, 5, 0.3))});
  std::vector<Dataset> logs;
  for (unsigned seed : {11u, 12u}) {
    o.seed = seed;
    logs.push_back(synth(truth, o));
    logs.back().path = "synthetic-" + std::to_string(seed);
  }
  ExplainOptions eo;
  eo.only = {"coulomb_friction", "quadratic_drag", "terrain_change"};
  const ExplainResult r = explain(logs, {nominal(), nominal()}, eo);
  INFO(r.verdict);
  REQUIRE(r.logs.size() == 2);
  REQUIRE(r.effects.size() == 1);
  CHECK(r.effects[0] == "coulomb_friction");
  CHECK(r.final_models.size() == 2);
  // One friction for both logs: the same parameters in both models.
  const auto a = r.final_models[0].model.effects.back()->params(), b = r.final_models[1].model.effects.back()->params();
  CHECK(a[0].second == b[0].second);
  CHECK(a[0].second == Approx(8).epsilon(0.15));
  for (int c = 0; c < kChannels; ++c) CHECK(r.final_ratio[static_cast<std::size_t>(c)] < 1.2);
}

namespace {

// Physics the library does not have, written here as a body would feel it (not in the term
// vocabulary's hard form): the rear-left screw's thread bites less when it turns backwards, its
// thrust falling by `loss` of eq. (7)'s through a smooth switch 0.5 rpm wide.
class BackwardThrustLoss final : public Effect {
 public:
  explicit BackwardThrustLoss(double loss) : loss_(loss) {}
  const std::string& id() const override {
    static const std::string s = "test_backward_thrust_loss";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override { return {{"loss", loss_}}; }
  void drive_force(const Model& model, const Vec4& omega_rpm, double sigma_scale, double, Vec3& tau_n,
                   double*) const override {
    const double w = omega_rpm[2];
    const double backward = 1.0 / (1.0 + std::exp(w / 0.25));  // 1 well below zero, 0 above
    tau_n -= loss_ * backward * sigma_scale * model.SB.col(2) * w;
  }

 private:
  double loss_;
};

// Turning churns the soil under the screws: every screw's thrust falls with the yaw rate, by loss
// at 0.15 rad/s and beyond (physics the library lacks, made here and not from its forms).
class TurnTractionLoss final : public Effect {
 public:
  explicit TurnTractionLoss(double loss) : loss_(loss) {}
  const std::string& id() const override {
    static const std::string s = "test_turn_traction_loss";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override { return {{"loss", loss_}}; }
  void body_force(const Model&, const EffectContext& ctx, Vec3& force_n, double*) const override {
    force_n = -loss_ * std::min(1.0, std::fabs(ctx.zeta.z()) / 0.15) * ctx.tau_drive_n;
  }

 private:
  double loss_;
};

// The batteries sag: every screw pushes less as the log goes on, by loss at t_end_s (physics the
// library lacks, made here and not from its forms).
class ThrustSag final : public Effect {
 public:
  ThrustSag(double loss, double t_end_s) : loss_(loss), t_end_s_(t_end_s) {}
  const std::string& id() const override {
    static const std::string s = "test_thrust_sag";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override { return {{"loss", loss_}}; }
  void body_force(const Model&, const EffectContext& ctx, Vec3& force_n, double*) const override {
    force_n = -loss_ * (ctx.t_s / t_end_s_) * ctx.tau_drive_n;
  }

 private:
  double loss_, t_end_s_;
};

// Whether a term explain discovered reads the input (a name of the dictionary's vocabulary).
bool discovered_reads(const ExplainResult& r, const std::string& input) {
  for (const auto& g : r.discovered)
    for (const auto& t : g.terms)
      if (std::find(t.inputs.begin(), t.inputs.end(), input) != t.inputs.end()) return true;
  return false;
}

}  // namespace

TEST_CASE("fit --add-term: a discovered term's coefficient recovered from physics made otherwise") {
  SynthOptions o;
  o.seconds = 90;
  o.seed = 7;
  const Model truth = make_model(RobotParams{}, kSand, {std::make_shared<BackwardThrustLoss>(0.35)});
  const Dataset d = synth(truth, o);
  const FitResult r = fit(d, nominal(), {}, false, {{"screw_2", "neg(omega_rpm)"}});
  REQUIRE(r.effects.size() == 2);
  CHECK(r.effects[1].effect == "term");
  INFO(r.effects[1].description);
  CHECK(r.effects[1].params[0].value == Approx(-0.35).epsilon(0.1));
  for (int c = 0; c < kChannels; ++c) CHECK(r.err_after.ratio_to_noise[static_cast<std::size_t>(c)] < 1.2);
  // The model file carries the term and reads back to the same error.
  const Model back = build_model(parse_model_file(r.model_toml, "fitted"), "sand");
  Prediction p;
  simulate(back, d, sim_options_for(back), p);
  const ErrorStats e = error_stats(d, p, r.noise_floor);
  for (int c = 0; c < kChannels; ++c)
    CHECK(e.ratio_to_noise[static_cast<std::size_t>(c)] == Approx(r.err_after.ratio_to_noise[static_cast<std::size_t>(c)]).epsilon(1e-6));
}

TEST_CASE("explain: physics outside the library is said so, with the missing term's form and no stand-in effect",
          "[slow]") {
  SynthOptions o;
  o.seconds = 90;
  o.seed = 8;
  const Model truth = make_model(RobotParams{}, kSand, {std::make_shared<BackwardThrustLoss>(0.35)});
  // (The library effects closest to it, which the search takes as stand-ins first: the whole
  // library takes four times as long and ends the same. On 90 s of log the search takes a slope
  // before the discovery removes it; on 120 s it takes all four and the paper's parameters, and
  // ends the same in 48 s against 4 s.)
  ExplainOptions eo;
  eo.only = {"screw_traction_loss", "traction_saturation", "terrain_slope", "resistance_offset"};
  const ExplainResult r = explain({synth(truth, o)}, {nominal()}, eo);
  INFO(r.verdict);
  CHECK(r.outside_library);
  CHECK(r.verdict_kind == "outside_library");
  REQUIRE(!r.discovered.empty());
  CHECK(discovered_reads(r, "omega_rpm_2"));
  // What the library's effects stood in for has left the model, and the terms reach the noise.
  CHECK(r.effects.empty());
  for (int c = 0; c < kChannels; ++c) CHECK(r.final_ratio[static_cast<std::size_t>(c)] < 1.2);
  // The model file carries the terms as effects `term`, and loads back.
  const Model back = build_model(parse_model_file(r.model_toml, "explained"), "sand");
  bool term = false;
  for (const auto& e : back.effects) term = term || e->id() == "term";
  CHECK(term);
}

TEST_CASE("explain: at the noise floor in size, a library effect the dictionary's term replaces is a stand-in",
          "[slow]") {
  // A traction that falls with the yaw rate is, in steady turning, the yaw part of a quadratic
  // drag (the same torque r |r|), and beside it a Coulomb friction takes up some of the thrust lost
  // in turns while driving: the library's model reaches the noise floor in size and leaves
  // residuals that are not noise. explain once ended there, "near the noise floor" with both
  // kept as findings; sought on the paper's model alone, a term of the turn (here u r, the thrust
  // lost along x in turns) predicts better without the friction.
  SynthOptions o;
  o.seconds = 90;
  o.seed = 3;
  const Model truth = make_model(RobotParams{}, kSand, {std::make_shared<TurnTractionLoss>(0.4)});
  ExplainOptions eo;
  eo.only = {"quadratic_drag", "terrain_change", "coulomb_friction"};
  const ExplainResult r = explain({synth(truth, o)}, {nominal()}, eo);
  INFO(r.verdict);
  CHECK(r.verdict_kind == "outside_library");
  CHECK(std::find(r.effects.begin(), r.effects.end(), "coulomb_friction") == r.effects.end());
  bool left = false;
  for (const RemovedEffect& e : r.removed)
    left = left || (e.effect == "coulomb_friction" && e.why.find("stood in") != std::string::npos);
  CHECK(left);
  CHECK(discovered_reads(r, "r_radps"));
  for (int c = 0; c < kChannels; ++c) CHECK(r.final_ratio[static_cast<std::size_t>(c)] < 1.2);
}

TEST_CASE("explain: a term's twin at steady speeds is named beside it (a thrust that sags, a drag that grows)",
          "[slow]") {
  // Every screw's thrust falling by 10 % over the log is, at steady speeds, the ground's drag
  // growing by 11 %: whichever of `screws: omega_rpm*t_s` and `drag: t_s` explain proposes, the
  // other predicts as well and is listed with it, so the inputs of the truth's form are named.
  // (At 20 % the two part: 1 / (1 - 0.2 t / T) is no straight line, and the twin is not listed.)
  SynthOptions o;
  o.seconds = 90;
  o.seed = 4;
  const Model truth = make_model(RobotParams{}, kSand, {std::make_shared<ThrustSag>(0.1, 90.0)});
  ExplainOptions eo;
  eo.only = {"terrain_change", "coulomb_friction"};
  const ExplainResult r = explain({synth(truth, o)}, {nominal()}, eo);
  INFO(r.verdict);
  CHECK(r.verdict_kind == "outside_library");
  const DiscoveredTerm* sag = nullptr;
  for (const auto& g : r.discovered)
    for (const auto& t : g.terms)
      if (t.form == "t_s" || t.form == "omega_rpm*t_s") sag = &t;
  REQUIRE(sag != nullptr);
  INFO(sag->dof << ": " << sag->form);
  REQUIRE(sag->alternatives.size() == 1);
  const auto& twin = sag->alternatives.front();
  CHECK(twin.dof == (sag->dof == "drag" ? "screws" : "drag"));
  // The twin's coefficient has the other sign (less thrust, more drag) and about the same size.
  CHECK(twin.coefficient * sag->coefficient < 0);
  CHECK(std::fabs(twin.coefficient) == Approx(std::fabs(sag->coefficient)).epsilon(0.35));
  CHECK(twin.ratio < 1.2);
  CHECK(r.verdict.find("or, as well") != std::string::npos);
  bool screws_named = std::find(twin.inputs.begin(), twin.inputs.end(), "omega_rpm_0") != twin.inputs.end();
  screws_named = screws_named || discovered_reads(r, "omega_rpm_0");
  CHECK(screws_named);
}

TEST_CASE("explain: discovered terms are proposed where they predict better, or as well with fewer parameters") {
  using explain_internal::terms_accepted;
  // The independent generator's traction falling with the yaw rate, seed 4 (turning mostly on the
  // spot): one term at 1.005 times the floor against a quadratic drag with two parameters at 1.026.
  // Within 2 % with one parameter fewer, one part for one: replaced, at the noise floor in size or not.
  CHECK(terms_accepted(1.005, 1, 1, 1.026, 2, 1, true));
  CHECK(terms_accepted(1.015, 1, 1, 1.026, 2, 1, false));
  // As well with as many parameters, or with more parts: the library's effects stay.
  CHECK_FALSE(terms_accepted(1.015, 2, 1, 1.026, 2, 1, false));
  CHECK_FALSE(terms_accepted(1.015, 1, 2, 1.026, 2, 1, false));
  // Fewer parameters but more than 2 % worse: stays.
  CHECK_FALSE(terms_accepted(1.05, 1, 1, 1.026, 2, 1, false));
  // 2 % better: accepted, but not when terms found on the paper's model alone would replace a
  // library model at the noise floor in size (the project's dead band and offset centre, 5
  // parameters in 2 effects: three terms, 3 parameters, at 1.030 against 1.051).
  CHECK(terms_accepted(1.2, 3, 3, 1.3, 3, 2, false));
  CHECK_FALSE(terms_accepted(1.030, 3, 3, 1.051, 5, 2, true));
}

TEST_CASE("explain: an effect the held-out segments do not show is sought where the rest of the log shows it",
          "[slow]") {
  // The robot turns only inside the search's training segments (90 s: seven segments of 12.9 s,
  // the third and sixth held out) and drives straight in the held-out ones, where a slower yaw
  // changes nothing: the paper's model is at the noise on the held-out third and far from it
  // over the log. explain once stopped there with nothing (a yaw time constant 4.8 times the
  // paper's on an open-loop log of the independent generator: 28 times the floor at the end).
  SynthOptions o;
  o.seconds = 90;
  o.seed = 4;
  o.drive = [](double t) {
    const double seg_s = 90.0 / 7.0, in_s = std::fmod(t, seg_s);
    const int k = static_cast<int>(t / seg_s);
    const Vec4 fwd(-1, -1, 1, 1), yaw(1, 1, 1, 1);
    const bool spin = k != 2 && k != 5 && in_s > 4 && in_s < 8;  // speeds ramped over 0.8 s
    const double ramp = std::min(1.0, (spin ? in_s - 4 : std::fmod(t, 4.0)) / 0.8);
    return Vec4(ramp * (spin ? 8.0 * yaw : (std::fmod(t, 8.0) < 4 ? 12.0 : -12.0) * fwd));
  };
  const Model truth = make_model(RobotParams{}, kSand, {entry("yaw_time_constant").make({1.5})});
  ExplainOptions eo;
  eo.only = {"yaw_time_constant", "force_lag", "pose_time_offset", "imu_heading_bias"};
  const ExplainResult r = explain({synth(truth, o)}, {nominal()}, eo);
  INFO(r.verdict);
  REQUIRE(!r.steps.empty());
  CHECK(r.steps.front().heldout_combined < 1.15);  // the held-out third shows nothing
  REQUIRE(!r.effects.empty());
  CHECK(r.effects.front() == "yaw_time_constant");
  for (int c = 0; c < kChannels; ++c) CHECK(r.final_ratio[static_cast<std::size_t>(c)] < 1.2);
}

TEST_CASE("explain: a robot heavier sideways is fitted with the added mass of its rigid-body coupling", "[slow]") {
  // Soil moved with the screws sideways: twice the robot's mass added in sway, with the Coriolis
  // terms and Munk moment that go with it (the form parameter added_sway, searched after the
  // coupling's size): named as the rigid-body coupling, its added mass found.
  SynthOptions o;
  o.seconds = 90;
  o.seed = 6;
  const Model truth = make_model(RobotParams{}, kSand, {entry("rigid_body_coupling").make({1.0, 2.0})});
  ExplainOptions eo;
  eo.only = {"rigid_body_coupling", "pose_time_offset", "yaw_time_constant", "force_lag"};
  const ExplainResult r = explain({synth(truth, o)}, {nominal()}, eo);
  INFO(r.verdict);
  CHECK(r.effects == std::vector<std::string>{"rigid_body_coupling"});
  CHECK(param_of(r, "rigid_body_coupling", "added_sway") == Approx(2.0).epsilon(0.25));
  for (int c = 0; c < kChannels; ++c) CHECK(r.final_ratio[static_cast<std::size_t>(c)] < 1.2);
}

TEST_CASE("explain: where no library effect is significant, the missing term is still sought", "[slow]") {
  // A library that cannot touch a drive force (an IMU bias alone): the search adds nothing, and
  // explain once ended "unexplained" without trying the dictionary.
  SynthOptions o;
  o.seconds = 90;
  o.seed = 8;
  const Model truth = make_model(RobotParams{}, kSand, {std::make_shared<BackwardThrustLoss>(0.5)});
  ExplainOptions eo;
  eo.only = {"imu_heading_bias"};
  const ExplainResult r = explain({synth(truth, o)}, {nominal()}, eo);
  INFO(r.verdict);
  CHECK(r.effects.empty());
  CHECK(r.verdict_kind == "outside_library");
  CHECK(discovered_reads(r, "omega_rpm_2"));
  for (int c = 0; c < kChannels; ++c) CHECK(r.final_ratio[static_cast<std::size_t>(c)] < 1.2);
}

TEST_CASE("explain: a parameter the log does not identify gives way to the simpler form; tiny effects leave",
          "[slow]") {
  // Hard Coulomb friction: stick-slip fits it with its Stribeck speed at the end of its range and
  // an uncertainty over its value; the final checks put Coulomb friction in its place.
  SynthOptions o;
  o.seconds = 90;
  o.seed = 3;
  const Model truth = make_model(RobotParams{}, kSand, {std::make_shared<CoulombFriction>(Vec3(8, 5, 0.3))});
  ExplainOptions eo;
  eo.only = {"coulomb_friction", "stick_slip_friction", "terrain_change", "pose_time_offset"};
  const ExplainResult r = explain({synth(truth, o)}, {nominal()}, eo);
  INFO(r.verdict);
  CHECK(r.effects == std::vector<std::string>{"coulomb_friction"});
  CHECK(r.verdict_kind == "noise");
  for (const auto& x : r.removed) {
    INFO(x.effect << ": " << x.why);
    CHECK(x.effect != "coulomb_friction");
  }
}

TEST_CASE("explain: the paper's parameters and a change of terrain are findings only when cross-validation confirms "
          "them", "[slow]") {
  SynthOptions o;
  o.seconds = 75;
  o.seed = 2;
  ExplainOptions eo;
  eo.only = {"coulomb_friction", "terrain_change"};
  auto paper_of = [](const ExplainResult& r) {
    for (const FittedEffect& fe : r.final_fitted)
      if (fe.effect == "paper_params") return fe;
    return FittedEffect{};
  };
  // Dry friction on the paper's own terrain: re-identified, sigma and D move a few per cent with
  // the noise; not confirmed on held-out segments, they are held at the paper's values (a reader
  // would take "sigma_long 0.79 N/rpm (was 0.812)" as a finding about this terrain).
  const Model friction = make_model(RobotParams{}, kSand, {std::make_shared<CoulombFriction>(Vec3(8, 5, 0.3))});
  const ExplainResult a = explain({synth(friction, o)}, {nominal()}, eo);
  INFO(a.verdict);
  CHECK(a.effects == std::vector<std::string>{"coulomb_friction"});
  CHECK(paper_of(a).effect == "paper_params");
  CHECK(paper_of(a).held);
  bool held_by_check = false;
  for (const RemovedEffect& x : a.removed) held_by_check = held_by_check || x.effect == "paper_params";
  CHECK(held_by_check);
  // The terrain's traction a third above the paper's throughout: re-identified, confirmed (and
  // not said as a change of terrain at some time).
  TerrainParams firmer = kSand;
  firmer.sigma_long *= 1.35;
  firmer.sigma_lat *= 1.35;
  const ExplainResult b = explain({synth(make_model(RobotParams{}, firmer), o)}, {nominal()}, eo);
  INFO(b.verdict);
  CHECK(b.effects.empty());
  CHECK_FALSE(paper_of(b).held);
  CHECK(param_of(b, "paper_params", "sigma_long") == Approx(0.812 * 1.35).epsilon(0.1));
}

TEST_CASE("explain: an effect taken in a near tie is named with its alternatives in the verdict", "[slow]") {
  // A dead band of 0.6 rpm costs about the constant force dry friction would on this driving
  // (screws well above the band): the log cannot tell them apart (1.5 rpm it can), and the
  // verdict must not pretend it can.
  SynthOptions o;
  o.seconds = 90;
  o.seed = 1;
  const Model truth = make_model(RobotParams{}, kSand, {entry("screw_dead_band").make({0.6, 1})});
  ExplainOptions eo;
  eo.only = {"screw_dead_band", "coulomb_friction", "stick_slip_friction"};
  const ExplainResult r = explain({synth(truth, o)}, {nominal()}, eo);
  INFO(r.verdict);
  for (const auto& st : r.steps) {
    if (st.added.empty() || st.alternatives.empty()) continue;
    INFO("step " << st.index << ": " << st.added << " with " << st.alternatives.size() << " alternatives");
    const bool kept = std::find(r.effects.begin(), r.effects.end(), st.added) != r.effects.end();
    const auto t = std::find_if(r.near_ties.begin(), r.near_ties.end(), [&](const NearTie& n) { return n.effect == st.added; });
    CHECK(kept == (t != r.near_ties.end()));
    if (t == r.near_ties.end()) continue;
    CHECK(t->with.size() == st.alternatives.size());
    CHECK(!t->tell_apart.empty());
    CHECK(r.verdict.find(st.added + " is a near tie with " + st.alternatives.front().fitted.effect) != std::string::npos);
  }
  CHECK(!r.near_ties.empty());
}

namespace {

// Added mass (docs/workbench-suite.md's rigid_body_coupling in its added-mass form): the soil
// moved with the screws makes the robot heavier sideways, the inertia of eq. (8) along y times
// 1 + k. The library's coupling is the Coriolis terms, and left out of the search here.
class AddedMass final : public Effect {
 public:
  explicit AddedMass(double k) : k_(k) {}
  const std::string& id() const override {
    static const std::string s = "test_added_mass";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override { return {{"k", k_}}; }
  void inertia(const Model&, Vec3& M_diag) const override { M_diag[1] *= 1.0 + k_; }

 private:
  double k_;
};

}  // namespace

TEST_CASE("explain: beside physics the library lacks, what is not confirmed in form is a possible stand-in",
          "[slow]") {
  // The robot 3.85 times heavier sideways, the library's coupling left out of the search: the
  // model cannot fit the log in form, and the paper's parameters re-identified take up part of
  // it (sigma_long and D_x stretched to the end of their range, three times the paper's: the
  // same steady speeds, other time constants). They were named as this terrain's before; now
  // they are held at the paper's values and listed as a possible stand-in, with the reason.
  SynthOptions o;
  o.seconds = 90;
  o.seed = 5;
  const Model truth = make_model(RobotParams{}, kSand, {std::make_shared<AddedMass>(2.85)});
  ExplainOptions eo;
  eo.only = {"terrain_change", "terrain_slope", "pose_time_offset", "quadratic_drag", "coulomb_friction",
             "imu_heading_drift"};
  const ExplainResult r = explain({synth(truth, o)}, {nominal()}, eo);
  INFO(r.verdict);
  CHECK(r.verdict_kind != "noise");
  CHECK(r.verdict_kind != "near_noise");
  REQUIRE(!r.stand_ins.empty());
  for (const StandIn& s : r.stand_ins) {
    INFO(s.effect << ": " << s.why);
    CHECK(!s.why.empty());
    CHECK(std::find(r.effects.begin(), r.effects.end(), s.effect) == r.effects.end());
  }
  CHECK(r.stand_ins.front().effect == "paper_params");
  CHECK(r.stand_ins.front().why.find("held at the paper's values") == 0);
  // (A pose time offset whose folds agree on its direction stays: docs/workbench.md "Limits".)
  for (const FittedEffect& fe : r.final_fitted)
    if (fe.effect == "paper_params") CHECK(fe.held);
  CHECK(r.verdict.find("possible stand-in") != std::string::npos);
}

TEST_CASE("explain: where the model stays above the noise floor, the paper's parameters re-identified are a "
          "possible stand-in", "[slow]") {
  // Dry friction reached over 8 mm/s of sliding (tanh), the friction left out of the search:
  // re-identified, sigma and D take up part of it, inside their ranges and alike on every fold,
  // and the model still leaves several times the noise floor. They are no finding of this log.
  SynthOptions o;
  o.seconds = 90;
  o.seed = 3;
  const Model truth = make_model(RobotParams{}, kSand, {std::make_shared<CoulombFriction>(Vec3(6, 2, 0.15), 0.008)});
  ExplainOptions eo;
  eo.only = {"terrain_slope", "imu_heading_drift"};
  const ExplainResult r = explain({synth(truth, o)}, {nominal()}, eo);
  INFO(r.verdict);
  double worst = 0;
  for (double v : r.library_ratio) worst = std::max(worst, v);
  CHECK(worst > 1.2);
  const auto s = std::find_if(r.stand_ins.begin(), r.stand_ins.end(),
                              [](const StandIn& x) { return x.effect == "paper_params"; });
  REQUIRE(s != r.stand_ins.end());
  INFO(s->why);
  CHECK(s->why.find("something is missing") != std::string::npos);
  // (Before, their folds agreed and they were named as this terrain's.) They did take up part of it.
  CHECK(*std::max_element(s->ratio_with.begin(), s->ratio_with.end()) <
        *std::max_element(s->ratio_without.begin(), s->ratio_without.end()));
  for (const FittedEffect& fe : r.final_fitted)
    if (fe.effect == "paper_params") CHECK(fe.held);
}

TEST_CASE("explain's verdict names the largest effect the cross-validation took out, if it mattered") {
  std::vector<RemovedEffect> removed{
      {"terrain_slope", "removed: it changes the prediction by at most 0.3 times the noise floor", 0.3, false},
      {"resistance_offset", "removed: a parameter of it is not identified", 30.0, false},
      {"pose_time_offset", "removed: not confirmed across the log's splits", 0.8, true},
      {"yaw_time_constant", "removed: not confirmed across the log's splits", 17.6, true},
      {"force_lag", "removed: not confirmed across the log's splits", 3.0, true}};
  const RemovedEffect* r = closest_unconfirmed(removed);
  REQUIRE(r != nullptr);
  CHECK(r->effect == "yaw_time_constant");
  // Below the noise floor it changed nothing a reader could see: no candidate is named.
  removed.erase(removed.begin() + 3, removed.end());
  CHECK(closest_unconfirmed(removed) == nullptr);
  CHECK(closest_unconfirmed({}) == nullptr);
}
