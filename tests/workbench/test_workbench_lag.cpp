// The force lag's form (docs/workbench.md "`auger effects`", force_lag): a drive force that builds
// up slowly and falls back fast (soil compressed under the flights lets go at once), written here
// from its physics (not with the library's ForceLag), fitted by the workbench in form; a lag the
// same both ways keeps that form.
#include <catch2/catch.hpp>

#include <cmath>
#include <memory>

#include "engine_synth.hpp"
#include "workbench.hpp"

using namespace auger;
using namespace auger::wb;
using namespace auger::wb::test;

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
