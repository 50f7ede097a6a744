// The figures of `auger step` (host/operator/step_metrics.cpp) against closed forms: a first-
// order response rises 10-90 % in tau ln 9 and settles into a 5 % band after tau ln 20; an
// underdamped second-order one overshoots by exp(-zeta pi / sqrt(1 - zeta^2)).
#include <catch2/catch.hpp>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "gnuplot.hpp"
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

// auger step --plot: the user's path goes into a gnuplot script, never to a shell. A path with
// quotes, ';', backquotes and $(...) in it must be plotted to, and nothing in it run (~0.1 s).
TEST_CASE("auger step's plot: a hostile path is a file name, not a command", "[operator][unit]") {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("auger-step-plot-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  // What a shell or gnuplot's `!`/system() would run creates "pwned" in the working directory.
  const fs::path marker = fs::current_path() / "pwned";
  fs::remove(marker);
  const std::string csv = (dir / "it's; a \"csv\".csv").string();
  auger::op::write_step_csv(csv, {0.0, 0.01, 0.02, 0.03}, {0.0, 4.5, 9.25, 10.0}, {0.0, 10.0, 10.0, 10.0});
  const std::string svg =
      (dir / "o'q\"; !touch pwned; `touch pwned` $(touch pwned) ;system('touch pwned');.svg").string();
  auger::io::Gnuplot gp;
  auger::op::plot_step(gp, csv, svg);
  CHECK(fs::exists(svg));
  CHECK(fs::file_size(svg) > 100);
  CHECK_FALSE(fs::exists(marker));
  const std::string text = auger::op::plot_step(gp, csv, "-");  // the terminal plot comes back
  CHECK(text.find("omega_rpm") != std::string::npos);
  CHECK_FALSE(fs::exists(marker));
  fs::remove_all(dir);
}

TEST_CASE("auger step's CSV: the core's CSV writer, shortest round-trip numbers", "[operator][unit]") {
  namespace fs = std::filesystem;
  const fs::path p = fs::temp_directory_path() / ("auger-step-csv-" + std::to_string(::getpid()) + ".csv");
  auger::op::write_step_csv(p.string(), {0.0, 0.01}, {1.0 / 3.0, 123.456789}, {5.0, 5.0});
  std::ifstream f(p);
  std::string head, r0, r1;
  std::getline(f, head);
  std::getline(f, r0);
  std::getline(f, r1);
  CHECK(head == "t_s,omega_rpm,omega_cmd_rpm");
  CHECK(std::stod(r0.substr(r0.find(',') + 1)) == 1.0 / 3.0);  // 6 digits would not read back
  CHECK(r1 == "0.01,123.456789,5");
  fs::remove(p);
}
