// The IMU drift's settling form (docs/workbench.md "`auger effects`", imu_heading_drift): a gyro
// bias settling while the IMU warms up, written here from its physics (not with the library's
// ImuHeadingDrift), fitted by the workbench in form; a linear drift keeps the linear form.
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

}  // namespace

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
