// The yaw time constant's soil-spring form (docs/workbench.md "`auger effects`", yaw_time_constant):
// the screws turn the body through the soil around them, a torsional spring with damping, so the
// yaw torque reaches the body through a second-order response and a turn overshoots. Written here
// from that physics (RK4 on the spring's equation, 1 ms steps), not with the library's effect, and
// fitted by the workbench in form.
#include <catch2/catch.hpp>

#include <cmath>
#include <memory>

#include "engine_synth.hpp"
#include "workbench.hpp"

using namespace auger;
using namespace auger::wb;
using namespace auger::wb::test;

namespace {

// T_body'' = w^2 (T - T_body) - 2 zeta w T_body': the torque on the body of a spring (stiffness
// w^2) and damper twisted by the screws' torque T.
class SoilSpring final : public Effect {
 public:
  SoilSpring(double period_s, double zeta) : w_(1 / period_s), zeta_(zeta) {}
  const std::string& id() const override {
    static const std::string s = "test_soil_spring";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override { return {}; }
  std::size_t state_size() const override { return 3; }
  void reset_state(double* s) const override { s[0] = s[1] = s[2] = 0; }
  void drive_force(const Model&, const Vec4&, double, double dt_s, Vec3& tau_n, double* s) const override {
    const double T = tau_n[2];
    if (s[0] == 0) {
      s[0] = 1;
      s[1] = T;
    }
    auto f = [&](double y, double v, double& dy, double& dv) {
      dy = v;
      dv = w_ * w_ * (T - y) - 2 * zeta_ * w_ * v;
    };
    const int n = static_cast<int>(std::ceil(dt_s / 1e-3));
    const double h = n > 0 ? dt_s / n : 0;
    for (int i = 0; i < n; ++i) {
      double k1y, k1v, k2y, k2v, k3y, k3v, k4y, k4v;
      f(s[1], s[2], k1y, k1v);
      f(s[1] + 0.5 * h * k1y, s[2] + 0.5 * h * k1v, k2y, k2v);
      f(s[1] + 0.5 * h * k2y, s[2] + 0.5 * h * k2v, k3y, k3v);
      f(s[1] + h * k3y, s[2] + h * k3v, k4y, k4v);
      s[1] += h / 6 * (k1y + 2 * k2y + 2 * k3y + k4y);
      s[2] += h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
    }
    tau_n[2] = s[1];
  }

 private:
  double w_, zeta_;
};

}  // namespace

TEST_CASE("yaw time constant: a turn that overshoots on a soil spring is fitted in form", "[slow]") {
  // Natural period 0.45 s, damping ratio 0.4 (the torque overshoots by a quarter), the paper's
  // yaw inertia: the first-order yaw time constant cannot ring.
  SynthOptions o;
  o.seconds = 64;
  const Dataset d = synth(make_model(RobotParams{}, kSand, {std::make_shared<SoilSpring>(0.45, 0.4)}), o);
  const FitResult r = fit(d, nominal(), {"yaw_time_constant"});
  const FittedEffect& e = r.effects.back();
  REQUIRE(e.effect == "yaw_time_constant");
  INFO(e.description);
  CHECK(value_of(e, "spring_s") == Approx(0.45).epsilon(0.15));
  CHECK(value_of(e, "damping") == Approx(0.4).epsilon(0.2));
  for (int c = 0; c < kChannels; ++c) CHECK(r.err_after.ratio_to_noise[static_cast<std::size_t>(c)] < 1.15);
  // explain keeps the form: its simpler form (the first-order time constant) predicts worse.
  ExplainOptions opt;
  opt.only = {"yaw_time_constant", "force_lag", "imu_heading_bias"};
  opt.threads = 1;
  const ExplainResult x = explain({d}, {nominal()}, opt);
  INFO(x.verdict);
  REQUIRE(x.effects == std::vector<std::string>{"yaw_time_constant"});
  CHECK(param_of(x, "yaw_time_constant", "spring_s") == Approx(0.45).epsilon(0.15));
  CHECK(x.verdict_kind == "noise");
}
