// The IMU heading's forms (docs/workbench.md "`auger effects`"), written here from their physics
// (not with the library's ImuHeadingDrift or ImuHeadingBias) and fitted by the workbench in form:
// a gyro bias settling while the IMU warms up (imu_heading_drift; a linear drift keeps the linear
// form), and a bias that jumps once (imu_heading_bias; a constant one keeps no jump).
#include <catch2/catch.hpp>

#include <cmath>
#include <memory>

#include "engine_synth.hpp"
#include "workbench.hpp"

using namespace auger;
using namespace auger::wb;
using namespace auger::wb::test;

namespace {

// The heading error of an IMU whose bias settles exponentially from start_rad to end_rad with the
// time constant settle_s.
class SettlingBias final : public Effect {
 public:
  SettlingBias(double start_rad, double end_rad, double settle_s) : start_(start_rad), end_(end_rad), tau_(settle_s) {}
  const std::string& id() const override {
    static const std::string s = "test_settling_bias";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override { return {}; }
  void sensors(const Model&, const Vec3&, const Vec3&, SensorValues& v) const override {
    const double e = std::exp(-v.t_s / tau_);
    v.imu_psi_rad = wrap_angle(v.imu_psi_rad + end_ + (start_ - end_) * e);
    v.imu_r_radps += -(start_ - end_) * e / tau_;
  }

 private:
  double start_, end_, tau_;
};

// The heading error of an IMU re-initialised (or disturbed) once: before_rad until t_jump_s, then
// after_rad.
class JumpingBias final : public Effect {
 public:
  JumpingBias(double before_rad, double after_rad, double t_jump_s) : before_(before_rad), after_(after_rad), t_(t_jump_s) {}
  const std::string& id() const override {
    static const std::string s = "test_jumping_bias";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override { return {}; }
  void sensors(const Model&, const Vec3&, const Vec3&, SensorValues& v) const override {
    v.imu_psi_rad = wrap_angle(v.imu_psi_rad + (v.t_s < t_ ? before_ : after_));
  }

 private:
  double before_, after_, t_;
};

}  // namespace

TEST_CASE("IMU bias: a jump is placed and fitted in form; a constant bias keeps no jump") {
  SynthOptions o;
  o.seconds = 64;
  const Dataset d = synth(make_model(RobotParams{}, kSand, {std::make_shared<JumpingBias>(0.006, 0.04, 27.33)}), o);
  const FitResult r = fit(d, nominal(), {"imu_heading_bias"});
  const FittedEffect& e = r.effects.back();
  REQUIRE(e.effect == "imu_heading_bias");
  INFO(e.description);
  CHECK(value_of(e, "t_step_s") == Approx(27.33).margin(0.1));
  CHECK(value_of(e, "bias_rad") == Approx(0.04).margin(0.002));
  CHECK(value_of(e, "before_rad") == Approx(0.006).margin(0.002));
  CHECK(r.err_after.ratio_to_noise[kImuPsi] < 1.15);
  const Dataset c = synth(make_model(RobotParams{}, kSand, {std::make_shared<JumpingBias>(0.04, 0.04, 0)}), o);
  const FitResult k = fit(c, nominal(), {"imu_heading_bias"});
  INFO(k.effects.back().description);
  CHECK(value_of(k.effects.back(), "t_step_s") == 0);
  CHECK(value_of(k.effects.back(), "bias_rad") == Approx(0.04).margin(0.002));
}

TEST_CASE("noise floor: a jump of the IMU heading's bias is not taken for camera noise") {
  SynthOptions o;
  o.seconds = 120;
  NoiseColour plain_colour, jump_colour;
  const ChannelValues plain = estimate_noise_floor(synth(nominal().model, o), &plain_colour);
  const ChannelValues jump = estimate_noise_floor(
      synth(make_model(RobotParams{}, kSand, {std::make_shared<JumpingBias>(0.0, 0.05, 41.7)}), o), &jump_colour);
  CAPTURE(plain[kPsi], jump[kPsi], plain_colour.factor, jump_colour.factor);
  CHECK(jump_colour.applied == plain_colour.applied);
  CHECK(jump[kPsi] == Approx(plain[kPsi]).epsilon(0.05));
  CHECK(jump[kX] == Approx(plain[kX]).epsilon(0.05));
}

TEST_CASE("IMU drift: a bias settling over 15 s is fitted in form, far better than a constant bias") {
  SynthOptions o;
  o.seconds = 64;
  const Dataset d = synth(make_model(RobotParams{}, kSand, {std::make_shared<SettlingBias>(0.0, 0.05, 15.0)}), o);
  const FitResult r = fit(d, nominal(), {"imu_heading_drift"});
  const FittedEffect& e = r.effects.back();
  REQUIRE(e.effect == "imu_heading_drift");
  INFO(e.description);
  CHECK(value_of(e, "settle_per_s") == Approx(1.0 / 15).epsilon(0.15));
  CHECK(value_of(e, "bias_rad") + value_of(e, "drift_radps") / value_of(e, "settle_per_s") == Approx(0.05).epsilon(0.05));
  CHECK(r.err_after.ratio_to_noise[kImuPsi] < 1.15);
  // A constant bias on the same log.
  const FitResult lin = fit(d, nominal(), {"imu_heading_bias"});
  CHECK(lin.err_after.ratio_to_noise[kImuPsi] > 1.5 * r.err_after.ratio_to_noise[kImuPsi]);
}

TEST_CASE("IMU drift: a linear drift is explained as the linear drift, its settling not kept") {
  SynthOptions o;
  o.seconds = 64;
  const Dataset d = synth(make_model(RobotParams{}, kSand, {entry("imu_heading_drift").make({0.01, 6e-4, 0})}), o);
  ExplainOptions opt;
  opt.only = {"imu_heading_drift", "imu_heading_bias"};
  opt.threads = 1;
  const ExplainResult x = explain({d}, {nominal()}, opt);
  INFO(x.verdict);
  REQUIRE(x.effects == std::vector<std::string>{"imu_heading_drift"});
  CHECK(param_of(x, "imu_heading_drift", "drift_radps") == Approx(6e-4).epsilon(0.1));
  CHECK(param_of(x, "imu_heading_drift", "settle_per_s") < 2e-3);
}
