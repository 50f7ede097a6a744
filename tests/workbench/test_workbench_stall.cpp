// Large effects and stalls (issue 25, point 3; docs/workbench.md "Plausibility", "A stalled robot",
// and explain's point 3, far from the noise):
// synthetic logs made with the host model (engine_synth.hpp) on a slow drive, where dry friction
// above the drive force holds the robot still, or on which two large effects leave the model far
// from the noise floor.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

#include "engine_synth.hpp"
#include "explain_internal.hpp"  // significant_gain, the rule itself
#include "workbench.hpp"

using namespace auger;
using namespace auger::wb;
using namespace auger::wb::test;

namespace {

const FitParam& param(const FittedEffect& e, const std::string& name) {
  for (const FitParam& p : e.params)
    if (p.name == name) return p;
  FAIL("no parameter " << name << " in " << e.effect);
  return e.params.front();
}

}  // namespace

TEST_CASE("fit: dry friction above the drive force, the robot stuck: a lower bound, not the start value") {
  // Half of drive_profile's speeds: the lateral drive stays below 5 N, the yaw torque well below
  // the friction's, so the robot never slides sideways nor turns; along x it does (the drive of
  // 9 rpm forward is 29 N, above the 20 N level).
  SynthOptions o;
  o.seconds = 64;
  o.drive_scale = 0.5;
  const Model truth = make_model(RobotParams{}, kSand, {entry("coulomb_friction").make({20, 12, 0.9})});
  const FitResult r = fit(synth(truth, o), nominal(), {"coulomb_friction"});
  for (int c = 0; c < kChannels; ++c) CHECK(r.err_after.ratio_to_noise[static_cast<std::size_t>(c)] < 1.2);
  const FittedEffect& e = r.effects.back();
  INFO(e.description);
  CHECK(param(e, "force_x_n").value == Approx(20).epsilon(0.2));
  CHECK(param(e, "force_x_n").flag.empty());
  // Along y and in yaw the log says only "at least": the fit reports the lowest level that holds
  // the robot still, below the truth, and says it is a bound. (Before, LM left both at their
  // starting values, 10 N and 0.5 N m, unflagged bounds below the truth, +- 1e7.)
  for (const char* name : {"force_y_n", "torque_psi_nm"}) {
    const FitParam& p = param(e, name);
    INFO(name << " = " << p.value << " (" << p.flag << ")");
    CHECK(p.flag.rfind("a lower bound", 0) == 0);
    CHECK(p.value < (std::string(name) == "force_y_n" ? 12.0 : 0.9));
  }
  // The bound is the level at which the robot just stays still: 10 % less and it slides.
  const FitParam& y = param(e, "force_y_n");
  CHECK(y.value > 2.0);
  const Model lower = make_model(RobotParams{}, kSand,
                                 {entry("coulomb_friction").make({param(e, "force_x_n").value, 0.9 * y.value,
                                                                  param(e, "torque_psi_nm").value})});
  const Model at = make_model(RobotParams{}, kSand,
                              {entry("coulomb_friction").make({param(e, "force_x_n").value, y.value,
                                                               param(e, "torque_psi_nm").value})});
  const Dataset d = synth(truth, o);
  Prediction p_at, p_lower;
  simulate(at, d, sim_options_for(at), p_at);
  simulate(lower, d, sim_options_for(lower), p_lower);
  double moved = 0;
  for (std::size_t k = 0; k < d.size(); ++k)
    if (std::isfinite(p_at.pred[k][kY]) && std::isfinite(p_lower.pred[k][kY]))
      moved = std::max(moved, std::fabs(p_at.pred[k][kY] - p_lower.pred[k][kY]));
  CHECK(moved > 1e-4);
}

TEST_CASE("fit: a friction level whose start holds the model's robot where the log's moves is started again from zero") {
  // Dry friction along x and y, none in yaw, on a slow drive: the yaw friction's starts (0.5 and
  // 0.15 N m) are above the slow drive's yaw torque, so the model's robot cannot turn where the
  // log's does, and any start value predicts the same (a zero Jacobian column): LM kept it, the
  // turns unexplained (here 2.08 times the noise floor, 0.15 N m; the independent generator's
  // Coulomb log: 9.2 times on held-out data, 1.08 started again from zero).
  SynthOptions o;
  o.seconds = 64;
  o.drive_scale = 0.1;
  const Model truth = make_model(RobotParams{}, kSand, {entry("coulomb_friction").make({2, 1, 0})});
  const FitResult r = fit(synth(truth, o), nominal(), {"coulomb_friction"});
  const FittedEffect& e = r.effects.back();
  INFO(e.description);
  for (int c = 0; c < kChannels; ++c) CHECK(r.err_after.ratio_to_noise[static_cast<std::size_t>(c)] < 1.2);
  CHECK(param(e, "torque_psi_nm").value < 0.02);
  // Along x the level trades with sigma_long and D_x, re-identified with it, at these few slow
  // speeds (1.53 +- 0.18 N).
  CHECK(param(e, "force_x_n").value == Approx(2).epsilon(0.3));
  CHECK(param(e, "force_y_n").value == Approx(1).epsilon(0.15));
}

TEST_CASE("explain: two large effects on a slow drive, the robot stalling; both are taken", "[slow]") {
  // A slope of 0.7 deg and a dead band of 4 rpm on a drive at 0.6 times drive_profile's speeds:
  // the screws below 4 rpm push nothing and the robot slides downhill (3 s; [slow]: an explain run,
  // left out of the sanitizer build).
  SynthOptions o;
  o.seconds = 90;
  o.drive_scale = 0.6;
  const Model truth = make_model(RobotParams{}, kSand,
                                 {entry("terrain_slope").make({0.0, 0.0122}), entry("screw_dead_band").make({4.0, 1})});
  ExplainOptions opt;
  opt.only = {"terrain_slope", "screw_dead_band", "coulomb_friction", "imu_heading_drift"};
  opt.threads = 1;
  const ExplainResult r = explain({synth(truth, o)}, {nominal()}, opt);
  INFO(r.verdict);
  CHECK(std::find(r.effects.begin(), r.effects.end(), "terrain_slope") != r.effects.end());
  CHECK(std::find(r.effects.begin(), r.effects.end(), "screw_dead_band") != r.effects.end());
  CHECK(param_of(r, "screw_dead_band", "omega_dead_rpm") == Approx(4.0).epsilon(0.1));
}

TEST_CASE("explain's significance far from the noise: a large held-out gain counts without the BIC's") {
  using explain_internal::significant_gain;
  // The indep generator's log of an offset centre of resistance and a 0.7 deg slope on frozen
  // grass (docs/workbench-suite.md "Results: large effects and stalls"): the slope took the
  // held-out error from 63.31 to 31.69 times the floor with delta BIC +5.7 (n_eff at its floor).
  CHECK(significant_gain(5.7, 63.31, 31.69));
  // Near the noise the BIC still decides: the same halving at 2 times the floor is not enough.
  CHECK_FALSE(significant_gain(5.7, 2.0, 1.0));
  CHECK(significant_gain(-12.0, 2.0, 1.9));
  // Far from it, a small gain is not (23.6 %: an offset centre after that slope).
  CHECK_FALSE(significant_gain(-6.3, 31.69, 24.21));
  // The held-out error must fall in every case (a BIC gain alone does not do).
  CHECK_FALSE(significant_gain(-50.0, 40.0, 39.9));
}

TEST_CASE("explain's beam: a structure far behind the best is not carried on, and not as far once the best is at "
          "the noise") {
  using explain_internal::beam_gap;
  using explain_internal::kVerdictNoise;
  auto carried = [](double best_h, bool best_implausible, double h, bool implausible) {
    return ranking_heldout(h, implausible) <= beam_gap(best_h) * ranking_heldout(best_h, best_implausible);
  };
  // The independent generator's 240 s pair log (docs/benchmarks.md "Model workbench: explain"):
  // after step 1 a dead band at 1.035 times the floor and a sinking blocking at 1.362. The blocking's
  // branch took 40 s more to the same answer.
  CHECK_FALSE(carried(1.035, false, 1.362, false));
  // Far from the noise the same ratio is carried: a later step may still show it was right.
  CHECK(carried(3.0, false, 3.0 * 1.362 / 1.035, false));
  CHECK_FALSE(carried(3.0, false, 4.6, false));
  // At the noise a close second goes on, as a near tie must; an implausible one counts worse.
  CHECK(carried(1.035, false, 1.2, false));
  CHECK_FALSE(carried(1.035, false, 1.2, true));
  // The boundary is the verdict's noise threshold.
  CHECK(beam_gap(kVerdictNoise) < beam_gap(kVerdictNoise * 1.001));
}
