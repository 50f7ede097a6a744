// The force lag's form (docs/workbench.md "`auger effects`", force_lag): a drive force that builds
// up slowly and falls back fast (soil compressed under the flights lets go at once), written here
// from its physics (not with the library's ForceLag), fitted by the workbench in form; a lag the
// same both ways keeps that form. And a form at the end of its physical range (soil moved with the
// screws as added mass, also written from its physics) is kept where it takes most of the cost,
// in a joint fit of several effects as in one of one.
#include <catch2/catch.hpp>

#include <cmath>
#include <memory>

#include "engine_synth.hpp"
#include "fitting.hpp"
#include "workbench.hpp"

using namespace auger;
using namespace auger::wb;
using namespace auger::wb::test;
using namespace auger::wb::search;

namespace {

// Each generalized force follows the drive's with build_s while the drive's magnitude is above
// its own, else with release_s.
class TwoWayLag final : public Effect {
 public:
  TwoWayLag(double build_s, double release_s) : build_s_(build_s), release_s_(release_s) {}
  const std::string& id() const override {
    static const std::string s = "test_two_way_lag";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override { return {}; }
  std::size_t state_size() const override { return 4; }
  void reset_state(double* state) const override { std::fill(state, state + 4, 0.0); }
  void drive_force(const Model&, const Vec4&, double, double dt_s, Vec3& tau_n, double* state) const override {
    if (state[0] == 0) {  // the force the drive had before the run
      state[0] = 1;
      for (int k = 0; k < 3; ++k) state[1 + k] = tau_n[k];
    }
    for (int k = 0; k < 3; ++k) {
      double& f = state[1 + k];
      const double tau_s = std::fabs(tau_n[k]) > std::fabs(f) ? build_s_ : release_s_;
      f += (tau_n[k] - f) * (1 - std::exp(-dt_s / tau_s));
      tau_n[k] = f;
    }
  }

 private:
  double build_s_, release_s_;
};

}  // namespace

TEST_CASE("force lag: a force that builds up slowly and falls back fast is fitted in form; a lag the same both ways keeps it") {
  SynthOptions o;
  o.seconds = 64;
  o.steps = true;
  const Dataset d = synth(make_model(RobotParams{}, kSand, {std::make_shared<TwoWayLag>(0.25, 0.05)}), o);
  const FitResult r = fit(d, nominal(), {"force_lag"});
  const FittedEffect& e = r.effects.back();
  REQUIRE(e.effect == "force_lag");
  INFO(e.description);
  CHECK(value_of(e, "tau_s") == Approx(0.25).epsilon(0.15));
  CHECK(value_of(e, "release_ratio") == Approx(0.2).margin(0.06));
  for (int c = 0; c < kChannels; ++c) CHECK(r.err_after.ratio_to_noise[static_cast<std::size_t>(c)] < 1.15);
  // The same lag both ways: release_ratio stays at 1 (or near it).
  const Dataset same = synth(make_model(RobotParams{}, kSand, {std::make_shared<TwoWayLag>(0.25, 0.25)}), o);
  const FitResult s = fit(same, nominal(), {"force_lag"});
  INFO(s.effects.back().description);
  CHECK(value_of(s.effects.back(), "tau_s") == Approx(0.25).epsilon(0.15));
  CHECK(std::fabs(value_of(s.effects.back(), "release_ratio") - 1) < 0.15);
}

namespace {

// Soil moved with the screws as added mass (Fossen's diagonal mass matrix): surge_x and sway_x
// times the robot's mass ahead and sideways, in the inertia and in the Coriolis and centripetal
// forces of a body of mass m + that, with the Munk moment (m11 - m22) u v, a real moment, in the
// model's lumped yaw units (yaw_lumping: the paper's yaw row is the screws' real moments scaled).
class AddedMass final : public Effect {
 public:
  AddedMass(double surge_x, double sway_x) : surge_x_(surge_x), sway_x_(sway_x) {}
  const std::string& id() const override {
    static const std::string s = "test_added_mass";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override { return {}; }
  void inertia(const Model& model, Vec3& M_diag) const override {
    M_diag[0] += surge_x_ * model.robot.m_kg;
    M_diag[1] += sway_x_ * model.robot.m_kg;
  }
  void body_force(const Model& model, const EffectContext& ctx, Vec3& force_n, double*) const override {
    const double m11 = (1 + surge_x_) * model.robot.m_kg, m22 = (1 + sway_x_) * model.robot.m_kg;
    const double u = ctx.zeta.x(), v = ctx.zeta.y(), r = ctx.zeta.z();
    force_n += Vec3(m22 * r * v, -m11 * r * u, yaw_lumping(model) * (m11 - m22) * u * v);
  }

 private:
  double surge_x_, sway_x_;
};

}  // namespace

// A form freed to the end of its physical range gives way to the default form only where it gains
// little: held to the default form, soil moved sideways beyond that range (4 times the robot's
// mass, the range ends at 3) is no added mass at all (checked: added_sway 0).
TEST_CASE("forms: a form at the end of its physical range that takes most of the cost is kept") {
  SynthOptions o;
  o.seconds = 64;
  o.steps = true;
  // Sway added mass beyond the physical range (0-3): the fit must stop at its end.
  const Dataset d = synth(make_model(RobotParams{}, kSand, {std::make_shared<AddedMass>(0.4, 4.0)}), o);
  const FitResult r = fit(d, nominal(), {"rigid_body_coupling"});
  const FittedEffect& e = r.effects.back();
  REQUIRE(e.effect == "rigid_body_coupling");
  INFO(e.description);
  CHECK(value_of(e, "added_sway") == Approx(3.0).margin(0.01));
  CHECK(value_of(e, "added_surge") > 0.2);
}

namespace {

// A part of a builtin effect with the values given, all its parameters free.
Part part_with(const std::string& id, std::vector<double> values) {
  const EffectRegistry::Entry* e = &EffectRegistry::builtin().entries().at(id);
  Part p;
  p.id = id;
  p.entry = e;
  p.specs = e->params;
  p.values = std::move(values);
  for (std::size_t i = 0; i < p.values.size(); ++i) p.free.push_back(static_cast<int>(i));
  return p;
}

}  // namespace

TEST_CASE("forms: in a joint fit, a form run to its end is seen behind another part's form that moved") {
  // Freed: the force lag's release (0.6, inside its range) and the added mass ahead (1.5, the end
  // of its physical range); held in the sized fit: both.
  FitOutcome out;
  out.parts = {part_with("force_lag", {0.2, 0.0, 0.6}), part_with("rigid_body_coupling", {1.0, 0.4, 1.5})};
  std::vector<Part> sized = out.parts;
  sized[0].free = {0, 1};
  sized[1].free = {0};
  out.cost = 90;
  // A tenth off the cost: the form at its end is no form the log identifies.
  CHECK(keep_sized_fit(sized, 100, out));
  // The same parts the other way round.
  std::swap(out.parts[0], out.parts[1]);
  std::swap(sized[0], sized[1]);
  CHECK(keep_sized_fit(sized, 100, out));
  // Half the cost: the forms are kept.
  out.cost = 50;
  CHECK_FALSE(keep_sized_fit(sized, 100, out));
  // Inside their ranges, a tenth is enough.
  out.parts[0].values[2] = 1.2;  // the added mass ahead
  out.cost = 90;
  CHECK_FALSE(keep_sized_fit(sized, 100, out));
  // Forms within 5 % of their typical sizes from their defaults are the defaults.
  out.parts[0].values = {1.0, 0.02, 0.005};  // the rigid body: added mass 0.02 m sideways
  out.parts[1].values = {0.2, 0.01, 1.01};   // the force lag: release 1.01 of the build-up
  CHECK(keep_sized_fit(sized, 100, out));
  // No gain at all.
  out.parts[1].values[2] = 0.6;
  out.cost = 100;
  CHECK(keep_sized_fit(sized, 100, out));
}
