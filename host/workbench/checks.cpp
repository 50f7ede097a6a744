// The subcommands' checks (checks.hpp).
#include "checks.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace auger::wb {

void require_fit_data(const Dataset& d, const char* command) {
  // A log without pose is compared in its IMU heading (docs/workbench.md "A log without pose"):
  // its segments start on IMU headings.
  const bool pose = d.gantry || d.has_pose();
  std::size_t poses = 0;
  for (const auto& m : d.meas) poses += pose ? std::isfinite(m[kX]) || std::isfinite(m[kY]) : std::isfinite(m[kImuPsi]);
  const char* what = pose ? "poses" : "IMU headings (the log has no pose)";
  char b[400];
  if (d.duration_s() < kMinFitSeconds || poses < std::size_t(kMinFitPoses)) {
    std::snprintf(b, sizeof b,
                  "%s: %.3g s of log with %zu measured %s: `auger %s` needs at least %.0f s and %d of them "
                  "(segments of 5 s for training and held-out errors); `auger compare` works on shorter logs",
                  d.path.c_str(), d.duration_s(), poses, what, command, kMinFitSeconds, kMinFitPoses);
    throw std::runtime_error(b);
  }
}

std::string unchecked_warning(const Dataset& d) {
  if (d.gantry || d.has_pose()) return "";
  std::string out, held;
  for (const auto& le : effect_library()) {
    if (le.needs_pose) out += (out.empty() ? "" : ", ") + le.id;
    for (const auto& p : le.held_without_pose) held += (held.empty() ? "" : ", ") + le.id + "." + p;
  }
  return "the log has no pose (x_m, y_m, psi_rad empty): only the IMU heading (imu_psi_rad) is compared with the "
         "model, each 25 s segment started on it. Not checked: the model's x and y; left out, as only a pose shows "
         "them: " + out + "; held at the model's values (they act along x and y alone): " + held +
         " (auger merge LOG CAMERA_LOG brings a pose recorded elsewhere)";
}

void require_finite(const Dataset& d, const ErrorStats& e, const ModelChoice& m, const std::string& what) {
  for (int c = 0; c < kChannels; ++c) {
    const auto k = static_cast<std::size_t>(c);
    if (!d.active[k]) continue;
    // Compared over most of the measurements: a prediction that turns NaN after its first
    // sample left one sample, an RMS of exactly 0 and a "perfect" model.
    std::size_t measured = 0;
    for (const auto& v : d.meas) measured += std::isfinite(v[k]);
    if (std::isfinite(e.rms[k]) && 2 * e.n[k] >= measured) continue;
    const TerrainParams& t = m.model.terrain;
    char b[600];
    std::snprintf(b, sizeof b,
                  "the model (%s) predicts no finite %s for %s over %s: check its parameters (terrain %s: "
                  "sigma_long %g, sigma_lat %g N/rpm, D_x %g, D_y %g N/(m/s), D_psi %g N m/(rad/s); eq. (6) needs "
                  "damping for a steady speed)",
                  m.source.c_str(), channel_name(c), d.path.c_str(), what.c_str(), t.name.c_str(), t.sigma_long,
                  t.sigma_lat, t.D_x, t.D_y, t.D_psi);
    throw std::runtime_error(b);
  }
}

void require_noise_floor(const Dataset& d, const ChannelValues& noise) {
  for (int c = 0; c < kChannels; ++c) {
    const auto k = static_cast<std::size_t>(c);
    if (!d.active[k] || (std::isfinite(noise[k]) && noise[k] > 0)) continue;
    throw std::runtime_error(d.path + ": no noise floor for " + channel_name(c) +
                             ": it needs runs of measurements less than 0.5 s apart (every error is stated as a "
                             "multiple of it)");
  }
}

}  // namespace auger::wb
