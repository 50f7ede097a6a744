// Camera-to-robot time alignment (merge.hpp): t0_unix_s, then the yaw-rate cross-correlation.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "auger/args.hpp"
#include "auger/input_limits.hpp"
#include "auger/log.hpp"
#include "auger/measured.hpp"
#include "auger/model.hpp"
#include "merge.hpp"

namespace auger::wb {
namespace {

// Values of a (possibly sparse) series at uniform times t0 + k dt, linear between measured
// samples; NaN outside them and across gaps longer than max_gap_s.
std::vector<double> resample(const std::vector<double>& t, const std::vector<double>& v, double t0,
                             double dt, std::size_t n, double max_gap_s) {
  std::vector<double> out(n, kNotMeasured);
  std::vector<double> tm, vm;
  for (std::size_t i = 0; i < t.size(); ++i)
    if (measured(v[i])) tm.push_back(t[i]), vm.push_back(v[i]);
  if (tm.size() < 2) return out;
  std::size_t j = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double tk = t0 + static_cast<double>(k) * dt;
    if (tk < tm.front() || tk > tm.back()) continue;
    while (j + 2 < tm.size() && tm[j + 1] < tk) ++j;
    const double span = tm[j + 1] - tm[j];
    if (span > max_gap_s) continue;
    const double a = (tk - tm[j]) / span;
    out[k] = vm[j] + a * (vm[j + 1] - vm[j]);
  }
  return out;
}

// Mean over [k - h, k + h]; NaN if any sample in the window is missing.
std::vector<double> box_mean(const std::vector<double>& v, std::size_t h) {
  const std::size_t n = v.size();
  std::vector<double> sum(n + 1, 0), bad(n + 1, 0);
  for (std::size_t i = 0; i < n; ++i) {
    sum[i + 1] = sum[i] + (measured(v[i]) ? v[i] : 0);
    bad[i + 1] = bad[i] + (measured(v[i]) ? 0 : 1);
  }
  std::vector<double> out(n, kNotMeasured);
  for (std::size_t k = h; k + h < n; ++k)
    if (bad[k + h + 1] - bad[k - h] == 0) out[k] = (sum[k + h + 1] - sum[k - h]) / static_cast<double>(2 * h + 1);
  return out;
}

double stddev_measured(const std::vector<double>& v) {
  double s = 0, ss = 0, n = 0;
  for (double x : v)
    if (measured(x)) s += x, ss += x * x, ++n;
  return n > 1 ? std::sqrt(std::max(0.0, ss / n - (s / n) * (s / n))) : 0;
}

struct LagScore {
  double r = -2;
  std::size_t n = 0;
};

// Pearson correlation of a[k] with b[k - lag] over the pairs both have, every step-th k.
LagScore correlate(const std::vector<double>& a, const std::vector<double>& b, long lag, std::size_t step,
                   std::size_t min_pairs) {
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  std::size_t n = 0;
  const long na = static_cast<long>(a.size()), nb = static_cast<long>(b.size());
  const long k0 = std::max(0L, lag), k1 = std::min(na, nb + lag);
  for (long k = k0; k < k1; k += static_cast<long>(step)) {
    const double x = a[static_cast<std::size_t>(k)], y = b[static_cast<std::size_t>(k - lag)];
    if (!measured(x) || !measured(y)) continue;
    sa += x, sb += y, saa += x * x, sbb += y * y, sab += x * y, ++n;
  }
  LagScore s;
  s.n = n * step;
  if (n * step < min_pairs || n < 3) return s;
  const double dn = static_cast<double>(n);
  const double va = saa - sa * sa / dn, vb = sbb - sb * sb / dn;
  if (!(va > 0) || !(vb > 0)) return s;
  s.r = (sab - sa * sb / dn) / std::sqrt(va * vb);
  return s;
}

}  // namespace

double parse_t0_unix_s(const std::string& path, const MetadataEntry& m) {
  double v = 0;
  if (!decimal_number(m.value, v)) throw LogError(path, m.line, 1, "t0_unix_s " + quote_input(m.value) + " is not a number");
  if (const std::string e = check_bound("t0_unix_s", v, limits::kLogTime); !e.empty()) throw LogError(path, m.line, 1, e);
  return v;
}

PoseTrack read_pose_track(const std::string& path, double* t0_unix_s, bool* has_t0) {
  CsvLogReader csv(path);
  csv.check_format(kRobotLogFormat);
  csv.require_columns({"t_s", "x_m", "y_m", "psi_rad"});
  if (has_t0) *has_t0 = false;
  for (const auto& m : csv.metadata()) {
    if (m.key != "t0_unix_s") continue;
    const double v = parse_t0_unix_s(path, m);
    if (t0_unix_s) *t0_unix_s = v;
    if (has_t0) *has_t0 = true;
  }
  const int cols[3] = {csv.column_index("x_m"), csv.column_index("y_m"), csv.column_index("psi_rad")};
  PoseTrack track;
  double last_wrapped = 0;
  while (csv.next()) {
    double v[3];
    int n_measured = 0;
    for (int c = 0; c < 3; ++c) {
      v[c] = csv.value(cols[c]);
      const std::string& text = csv.field_text(cols[c]);
      if (!measured(v[c]) && !text.empty() && text != "nan" && text != "NaN" && text != "NAN")
        csv.fail_at_field(cols[c], "bad number '" + text + "'");
      n_measured += measured(v[c]);
    }
    if (n_measured < 3) continue;  // a row without a whole pose carries no camera sample
    // Unwrap: the heading moves less than pi between two camera frames.
    const double psi = track.psi_rad.empty() ? v[2] : track.psi_rad.back() + wrap_angle(v[2] - last_wrapped);
    last_wrapped = v[2];
    track.t_s.push_back(csv.t_s());
    track.x_m.push_back(v[0]);
    track.y_m.push_back(v[1]);
    track.psi_rad.push_back(psi);
  }
  if (track.t_s.size() < 2)
    throw LogError(path, csv.line() + 1, 1, "fewer than two rows with x_m, y_m and psi_rad all measured");
  return track;
}

Alignment align_camera(const std::vector<double>& robot_t_s, const std::vector<double>& imu_r_radps,
                       const PoseTrack& camera, double coarse_offset_s, bool t0_used,
                       const MergeOptions& o) {
  Alignment al;
  al.coarse_offset_s = coarse_offset_s;
  al.offset_s = coarse_offset_s;
  al.t0_used = t0_used;
  al.quality = "t0 only";
  if (robot_t_s.size() < 10) {
    al.note = "the robot log has fewer than 10 samples";
    return al;
  }
  // Grid at the robot's median sample period.
  std::vector<double> dts;
  for (std::size_t i = 1; i < robot_t_s.size(); ++i) dts.push_back(robot_t_s[i] - robot_t_s[i - 1]);
  std::nth_element(dts.begin(), dts.begin() + static_cast<long>(dts.size() / 2), dts.end());
  const double dt = std::clamp(dts[dts.size() / 2], 1e-3, 0.1);
  al.grid_dt_s = dt;
  const double tr0 = robot_t_s.front();
  // The search holds both logs on a uniform grid: bounded, or a log with steps of 1e6 s asks for
  // terabytes (it aborted with bad_alloc).
  auto check_grid = [&](double span_s, const char* which) {
    if (span_s / dt + 1 <= double(o.max_grid)) return;
    char b[240];
    std::snprintf(b, sizeof b, "the %s log spans %.4g s: more than %zu samples at the %.3g s steps of the alignment; "
                  "cut it into runs before merging", which, span_s, o.max_grid, dt);
    throw std::invalid_argument(b);
  };
  check_grid(robot_t_s.back() - tr0, "robot");
  check_grid(camera.t_s.back() - camera.t_s.front(), "camera");
  const std::size_t nr = static_cast<std::size_t>((robot_t_s.back() - tr0) / dt) + 1;
  const std::size_t h = std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(o.smooth_s / dt)));

  // Robot: IMU yaw rate averaged over the same 2h the camera's heading difference spans.
  const std::vector<double> imu = box_mean(resample(robot_t_s, imu_r_radps, tr0, dt, nr, o.max_gap_s), h);
  std::size_t n_imu = 0;
  for (double x : imu) n_imu += measured(x);
  if (n_imu < 100) {
    al.note = "no IMU yaw rate (imu_r_radps) in the robot log: only t0_unix_s aligns the logs";
    return al;
  }
  // Camera: heading on the robot's grid shifted by the coarse offset (camera time
  // tr0 - coarse + m dt), differenced over +-h: its mean rate over the window.
  const double tc0 = tr0 - coarse_offset_s;
  const long m_first = static_cast<long>(std::ceil((camera.t_s.front() - tc0) / dt));
  const long m_last = static_cast<long>(std::floor((camera.t_s.back() - tc0) / dt));
  if (m_last - m_first < 20) {
    al.note = "the camera log is shorter than 20 samples of the robot's grid";
    return al;
  }
  const std::size_t nc = static_cast<std::size_t>(m_last - m_first + 1);
  const double cam_t0 = tc0 + static_cast<double>(m_first) * dt;
  const std::vector<double> psi = resample(camera.t_s, camera.psi_rad, cam_t0, dt, nc, o.max_gap_s);
  std::vector<double> cam_rate(nc, kNotMeasured);
  for (std::size_t m = h; m + h < nc; ++m)
    if (measured(psi[m + h]) && measured(psi[m - h]))
      cam_rate[m] = (psi[m + h] - psi[m - h]) / (2.0 * static_cast<double>(h) * dt);
  if (stddev_measured(imu) < 0.01 || stddev_measured(cam_rate) < 0.01) {
    al.note = "the robot hardly turns (yaw rate spread below 0.01 rad/s): nothing to correlate, t0_unix_s kept";
    return al;
  }

  // The camera grid index m pairs with robot index k = m + m_first + lag, offset = coarse + lag dt.
  const long max_lag = static_cast<long>(std::ceil(o.max_shift_s / dt));
  const std::size_t min_pairs = std::max<std::size_t>(
      static_cast<std::size_t>(5.0 / dt), std::min(n_imu, nc) / 4);  // 5 s and a quarter of the shorter
  // Coarse pass every `step` samples and lags (the rates are smoothed over 2h), then every lag
  // around the best one.
  const long step = std::max(1L, static_cast<long>(h / 2));
  std::vector<std::pair<long, double>> coarse;
  long best = 0;
  double best_r = -2;
  for (long lag = -max_lag; lag <= max_lag; lag += step) {
    const LagScore s = correlate(imu, cam_rate, lag + m_first, static_cast<std::size_t>(step), min_pairs);
    coarse.push_back({lag, s.r});
    if (s.r > best_r) best_r = s.r, best = lag;
  }
  if (best_r <= -1.5) {
    al.note = "the logs overlap too little (need 5 s and a quarter of the shorter log) within +-" +
              std::to_string(o.max_shift_s) + " s of the t0_unix_s offset";
    al.quality = "poor";
    al.refined = true;
    return al;
  }
  LagScore fine_best;
  long fine = best;
  for (long lag = best - step; lag <= best + step; ++lag) {
    const LagScore s = correlate(imu, cam_rate, lag + m_first, 1, min_pairs);
    if (s.r > fine_best.r) fine_best = s, fine = lag;
  }
  // Sub-sample: the vertex of the parabola through the peak and its neighbours.
  double frac = 0;
  const double rm = correlate(imu, cam_rate, fine - 1 + m_first, 1, min_pairs).r;
  const double rp = correlate(imu, cam_rate, fine + 1 + m_first, 1, min_pairs).r;
  const double curv = rm - 2 * fine_best.r + rp;
  if (rm > -1.5 && rp > -1.5 && curv < 0) frac = std::clamp(0.5 * (rm - rp) / curv, -0.5, 0.5);

  al.refined = true;
  al.offset_s = coarse_offset_s + (static_cast<double>(fine) + frac) * dt;
  al.correlation = fine_best.r;
  al.overlap_s = static_cast<double>(fine_best.n) * dt;
  al.second_peak = -1;
  for (const auto& [lag, r] : coarse)
    if (std::fabs(static_cast<double>(lag - fine) * dt) > 1.0) al.second_peak = std::max(al.second_peak, r);
  if (al.correlation < 0.4) {
    al.quality = "poor";
    al.note = "the IMU yaw rate and the camera's heading rate correlate weakly at best (r < 0.4)";
  } else if (al.second_peak > 0.9 * al.correlation) {
    al.quality = "ambiguous";
    al.note = "another offset more than 1 s away correlates almost as well (periodic turning?)";
  } else {
    al.quality = "good";
  }
  return al;
}

bool camera_pose_at(const PoseTrack& cam, double t_robot_s, double offset_s, double max_gap_s, double& x_m,
                    double& y_m, double& psi_rad) {
  const double tc = t_robot_s - offset_s;
  if (cam.t_s.empty() || tc < cam.t_s.front() || tc > cam.t_s.back()) return false;
  const auto it = std::upper_bound(cam.t_s.begin(), cam.t_s.end(), tc);
  std::size_t j1 = static_cast<std::size_t>(it - cam.t_s.begin());
  if (j1 >= cam.t_s.size()) j1 = cam.t_s.size() - 1;
  const std::size_t j0 = j1 > 0 ? j1 - 1 : 0;
  const double span = cam.t_s[j1] - cam.t_s[j0];
  double a = 0;
  if (span > 0) {
    if (span > max_gap_s) return false;
    a = (tc - cam.t_s[j0]) / span;
  }
  x_m = cam.x_m[j0] + a * (cam.x_m[j1] - cam.x_m[j0]);
  y_m = cam.y_m[j0] + a * (cam.y_m[j1] - cam.y_m[j0]);
  psi_rad = wrap_angle(cam.psi_rad[j0] + a * (cam.psi_rad[j1] - cam.psi_rad[j0]));
  return true;
}

}  // namespace auger::wb
