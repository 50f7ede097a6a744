#include "step_metrics.hpp"

#include <algorithm>
#include <cmath>

namespace auger::op {

StepSummary summarize_step(const std::vector<StepSample>& samples, double t_step_s, double from_rpm, double to_rpm) {
  const double step = to_rpm - from_rpm;
  const double dir = step >= 0 ? 1.0 : -1.0;
  const double band = std::max(0.05 * std::fabs(step), 0.5);
  double t10 = NAN, t90 = NAN, peak = from_rpm, last_out_s = t_step_s;
  const double t_end = samples.empty() ? 0 : samples.back().t_s;
  double err_sum = 0;  // signed: the steady-state error is the mean offset, not the jitter
  int err_n = 0, n = 0;
  bool outside_at_end = true;
  for (const auto& s : samples) {
    if (s.t_s < t_step_s) continue;
    ++n;
    const double progress = (s.omega_rpm - from_rpm) / step;
    if (std::isnan(t10) && progress >= 0.1) t10 = s.t_s;
    if (std::isnan(t90) && progress >= 0.9) t90 = s.t_s;
    if (dir * (s.omega_rpm - peak) > 0) peak = s.omega_rpm;
    outside_at_end = std::fabs(s.omega_rpm - to_rpm) > band;
    if (outside_at_end) last_out_s = s.t_s;
    if (s.t_s >= t_end - 0.5) {
      err_sum += s.omega_rpm - to_rpm;
      ++err_n;
    }
  }
  StepSummary r;
  r.rise_time_s = (std::isnan(t10) || std::isnan(t90)) ? INFINITY : t90 - t10;
  r.overshoot_pct = std::max(0.0, dir * (peak - to_rpm) / std::fabs(step) * 100.0);
  r.steady_error_rpm = err_n ? std::fabs(err_sum / err_n) : INFINITY;
  r.settling_time_s = (n == 0 || outside_at_end) ? INFINITY : last_out_s - t_step_s;
  r.samples = n;
  return r;
}

}  // namespace auger::op
