// The figures of `auger step` (host/operator/step_metrics.cpp) against closed forms: a first-
// order response rises 10-90 % in tau ln 9 and settles into a 5 % band after tau ln 20; an
// underdamped second-order one overshoots by exp(-zeta pi / sqrt(1 - zeta^2)).
#include <catch2/catch.hpp>

#include <cmath>

#include "step_metrics.hpp"

using auger::op::StepSample;
using auger::op::summarize_step;

TEST_CASE("first-order step: rise time tau ln 9, no overshoot, settling tau ln 20", "[operator][unit]") {
  const double tau_s = 0.05, t_step_s = 0.5;
  std::vector<StepSample> s;
  for (int k = 0; k <= 2500; ++k) {
    const double t = k * 0.001;
    s.push_back({t, t < t_step_s ? 2.0 : 2.0 + 10.0 * (1 - std::exp(-(t - t_step_s) / tau_s))});
  }
  const auto r = summarize_step(s, t_step_s, 2.0, 12.0);
  CHECK(r.rise_time_s == Approx(tau_s * std::log(9.0)).margin(0.002));
  CHECK(r.overshoot_pct == 0.0);
  CHECK(r.steady_error_rpm < 1e-6);
  CHECK(r.settling_time_s == Approx(tau_s * std::log(20.0)).margin(0.002));
}

TEST_CASE("second-order step: overshoot, a downward step, a steady offset", "[operator][unit]") {
  const double zeta = 0.4, wn = 30.0, wd = wn * std::sqrt(1 - zeta * zeta);
  std::vector<StepSample> s;
  for (int k = 0; k <= 3000; ++k) {
    const double t = k * 0.001;
    const double y = 1 - std::exp(-zeta * wn * t) * (std::cos(wd * t) + zeta / std::sqrt(1 - zeta * zeta) * std::sin(wd * t));
    s.push_back({t, 5.0 - 15.0 * y + 0.3 * (1 - std::exp(-t))});  // 5 -> -10 rpm, plus a 0.3 rpm offset
  }
  const auto r = summarize_step(s, 0.0, 5.0, -10.0);
  const double expected_pct = 100 * std::exp(-zeta * M_PI / std::sqrt(1 - zeta * zeta));
  CHECK(r.overshoot_pct == Approx(expected_pct).margin(2.5));  // less the offset's 0.3 rpm
  CHECK(r.steady_error_rpm == Approx(0.3 * (1 - std::exp(-2.75))).margin(0.02));
  CHECK(std::isfinite(r.rise_time_s));
}

TEST_CASE("a step never reached has an infinite rise time", "[operator][unit]") {
  std::vector<StepSample> s;
  for (int k = 0; k < 200; ++k) s.push_back({k * 0.01, 0.5});
  const auto r = summarize_step(s, 0.0, 0.0, 10.0);
  CHECK(std::isinf(r.rise_time_s));
  CHECK(std::isinf(r.settling_time_s));
}
