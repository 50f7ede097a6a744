// The step-response figures of `auger step` and of the firmware's step tests (sim/rig/fil_rig.cpp
// step_metrics calls this, docs/firmware.md): rise time 10-90 %, overshoot past
// the target in % of the step, steady-state error as the mean offset over the last 0.5 s;
// plus the settling time (last exit from a band of 5 % of the step, at least 0.5 rpm).
#pragma once

#include <string>
#include <vector>

namespace auger::io {
class Gnuplot;
}

namespace auger::op {

struct StepSample {
  double t_s;
  double omega_rpm;
};

struct StepSummary {
  double rise_time_s;      // infinity if 10 % or 90 % was never reached
  double overshoot_pct;
  double steady_error_rpm;
  double settling_time_s;  // from the step; infinity if the last sample is outside the band
  int samples;
};

// The firmware's test criteria (tests/fil/test_fil_step.cpp).
constexpr double kRiseMax_s = 0.3, kOvershootMax_pct = 10.0, kSteadyErrorMax_rpm = 0.5;

StepSummary summarize_step(const std::vector<StepSample>& samples, double t_step_s, double from_rpm, double to_rpm);

// The recorded step as CSV (t_s, omega_rpm, omega_cmd_rpm; the core's CsvLogWriter: shortest
// round-trip numbers). Throws std::runtime_error naming the file. step.cpp.
void write_step_csv(const std::string& path, const std::vector<double>& t_s, const std::vector<double>& omega_rpm,
                    const std::vector<double>& omega_cmd_rpm);
// Plots that CSV with gnuplot (host/io's driver): an SVG at `plot`, or "-" a terminal plot,
// returned as text. Throws io::PlotError with gnuplot's messages. step.cpp.
std::string plot_step(io::Gnuplot& gp, const std::string& csv_path, const std::string& plot);

}  // namespace auger::op
