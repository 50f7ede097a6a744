// The workbench engine's datasets (dataset.hpp): a log read into the channels the workbench
// compares, and the noise floor estimated from the data.
#include "dataset.hpp"
#include "simulation.hpp"

#include "daemon_log.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <stdexcept>

#include <Eigen/Dense>

namespace auger::wb {

const char* channel_name(int c) {
  static const char* names[kChannels] = {"x", "y", "psi", "imu_psi"};
  return names[c];
}
const char* channel_unit(int c) { return c < 2 ? "m" : "rad"; }

namespace {

bool finite(double v) { return std::isfinite(v); }

// The screw speeds between measured samples (docs/workbench.md "How the model is run against a log"): a module that reports
// at 5 Hz leaves 19 empty rows of 20. Held, the speed lagged the truth by half a report period
// on average (0.1 s: what a force lag or a pose time offset would be fitted to); linear between
// two reports less than kOmegaInterpolateS apart it is the truth to second order in the speed's
// change. A longer silence (a module that dropped out) is held from its last value, and before
// the first report the speed is 0.
void fill_screw_speeds(Dataset& d) {
  for (int i = 0; i < 4; ++i) {
    std::size_t last = d.size();  // the last measured row
    for (std::size_t k = 0; k < d.size(); ++k) {
      double& w = d.omega_rpm[k][i];
      if (finite(w)) {
        if (last < d.size() && k > last + 1 && d.t_s[k] - d.t_s[last] <= kOmegaInterpolateS) {
          const double w0 = d.omega_rpm[last][i], span = d.t_s[k] - d.t_s[last];
          for (std::size_t j = last + 1; j < k; ++j) d.omega_rpm[j][i] = w0 + (w - w0) * (d.t_s[j] - d.t_s[last]) / span;
        }
        last = k;
      } else {
        w = last < d.size() ? d.omega_rpm[last][i] : 0.0;  // held (replaced above if the next report is close)
      }
    }
  }
}

}  // namespace

// ------------------------------------------------------------------------------- dataset
Dataset load_dataset(const std::string& path) {
  Dataset d;
  d.path = path;
  std::string format;
  {
    CsvLogReader probe(path);  // throws LogError if it cannot be opened or has no header
    format = probe.meta("format").value_or("");
  }
  if (format == kGantryLogFormat) {
    GantryLogReader r(path);
    d.gantry = true;
    // The reader has checked the metadata (docs/log-format.md "Gantry log").
    d.axis = r.axis();
    d.terrain = r.metadata().terrain;
    d.gantry_mass_kg = r.metadata().mass_kg.value_or(d.gantry_mass_kg);
    const int ch = d.axis == "longitudinal" ? kX : kY;
    GantrySample s;
    while (r.next(s)) {
      d.t_s.push_back(s.t_s);
      d.omega_rpm.push_back(Vec4(s.omega_rpm[0], s.omega_rpm[1], 0.0, 0.0));
      ChannelValues m{kNaN, kNaN, kNaN, kNaN};
      if (finite(s.position_m)) {
        m[static_cast<std::size_t>(ch)] = s.position_m;
        m[ch == kX ? kY : kX] = 0.0;  // the rail holds the other DOF and the heading
        m[kPsi] = 0.0;
      }
      d.meas.push_back(m);
      d.force_n.push_back(s.force_n);
    }
  } else {
    RobotLogReader r(path);
    d.terrain = r.csv().meta("terrain").value_or("");
    const int capture = r.csv().column_index(daemon::pose_capture_column());
    // The online estimate's columns, all ten or none (augerd writes them together).
    int online[10];
    bool has_online = true;
    for (int k = 0; k < 10; ++k) has_online &= (online[k] = r.csv().column_index(daemon::online_columns()[std::size_t(k)])) >= 0;
    RobotSample s;
    while (r.next(s)) {
      if (capture >= 0) {
        // A capture time is on the log's clock, a little before the row (a camera's latency; a
        // little after it where the camera's clock runs ahead of augerd's: up to 0.13 s in the
        // demo's logs); one seconds away is not a time of this row's pose but an error.
        const double tc = r.csv().value(capture);
        if (finite(tc) && !(tc <= s.t_s + 1.0 && tc >= s.t_s - 2.0))
          r.csv().fail_at_field(capture, "pose_capture_t_s " + std::to_string(tc) +
                                             " is not within 2 s before or 1 s after the row's t_s " + std::to_string(s.t_s));
        d.pose_t_s.push_back(finite(tc) && finite(s.x_m) ? tc : kNaN);
      }
      if (has_online) {
        std::array<double, 5> v, sd;
        for (int k = 0; k < 5; ++k) v[std::size_t(k)] = r.csv().value(online[k]), sd[std::size_t(k)] = r.csv().value(online[5 + k]);
        d.online_value.push_back(v);
        d.online_sd.push_back(sd);
      }
      d.t_s.push_back(s.t_s);
      d.omega_rpm.push_back(Vec4(s.omega_rpm[0], s.omega_rpm[1], s.omega_rpm[2], s.omega_rpm[3]));
      d.meas.push_back({s.x_m, s.y_m, s.psi_rad, s.imu_psi_rad});
      d.imu_r_radps.push_back(s.imu_r_radps);
    }
  }
  if (d.t_s.size() < 3) throw LogError(path, 1, 1, "the log has fewer than 3 samples");
  // A screw whose speed is measured in no row would run the model on the gaps' fill (0 rpm): a
  // wrong answer given with confidence. Refused, naming the columns.
  std::string empty;
  for (int i = 0; i < (d.gantry ? 2 : 4); ++i) {
    bool measured = false;
    for (const Vec4& w : d.omega_rpm) measured = measured || finite(w[i]);
    if (!measured) empty += (empty.empty() ? "omega_rpm_" : ", omega_rpm_") + std::to_string(i);
  }
  if (!empty.empty())
    throw LogError(path, 1, 1,
                   "no row has a screw speed in " + empty +
                       ": the model runs on the measured screw speeds (docs/log-format.md); a log of poses alone "
                       "can be merged with the screws' log (auger merge) or exported (auger export), not compared");
  fill_screw_speeds(d);
  std::array<std::size_t, kChannels> count{};
  for (const auto& m : d.meas)
    for (int c = 0; c < kChannels; ++c) count[static_cast<std::size_t>(c)] += finite(m[static_cast<std::size_t>(c)]);
  for (int c = 0; c < kChannels; ++c) d.active[static_cast<std::size_t>(c)] = count[static_cast<std::size_t>(c)] >= 10;
  if (d.gantry) {
    d.active = {false, false, false, false};
    d.active[d.axis == "longitudinal" ? kX : kY] = true;
  }
  // (A gantry's channel is active whatever it holds: the rail is its pose.)
  if (!d.has_pose() && !d.active[kImuPsi])
    throw LogError(path, 1, 1,
                   "the log has (almost) no pose measurements (x_m, y_m, psi_rad) and no IMU heading (imu_psi_rad): "
                   "nothing to compare the model with (auger merge brings a pose recorded elsewhere, "
                   "docs/workbench-tools.md)");
  return d;
}

bool is_start_row(const Dataset& d, std::size_t k) {
  const auto& m = d.meas[k];
  if (d.has_pose()) return finite(m[kX]) && finite(m[kY]) && finite(m[kPsi]);
  return finite(m[kImuPsi]);
}

Vec3 start_pose(const Dataset& d, std::size_t k) {
  const auto& m = d.meas[k];
  return d.has_pose() ? Vec3(m[kX], m[kY], m[kPsi]) : Vec3(0.0, 0.0, m[kImuPsi]);
}

// ------------------------------------------------------------------------------- noise floor
double estimate_noise(const std::vector<double>& t_s, const std::vector<double>& values, bool is_angle) {
  std::vector<std::size_t> idx;
  for (std::size_t k = 0; k < values.size(); ++k)
    if (finite(values[k])) idx.push_back(k);
  std::vector<double> r;
  // Each measured sample against the cubic through its two measured neighbours on each side
  // (Lagrange, exact for any cubic): the motion of a 29 kg robot is smooth at these scales,
  // so what is left is measurement noise, with variance sigma^2 (1 + sum of weights^2).
  for (std::size_t j = 2; j + 2 < idx.size(); ++j) {
    const std::size_t n[4] = {idx[j - 2], idx[j - 1], idx[j + 1], idx[j + 2]};
    const double t = t_s[idx[j]];
    if (t_s[n[3]] - t_s[n[0]] > 0.5) continue;  // across a gap the motion is not smooth
    const double y0 = values[idx[j]];
    double pred = 0, w2 = 0;
    for (int a = 0; a < 4; ++a) {
      double w = 1;
      for (int b = 0; b < 4; ++b)
        if (b != a) w *= (t - t_s[n[b]]) / (t_s[n[a]] - t_s[n[b]]);
      const double ya = values[n[a]];
      pred += w * (is_angle ? y0 + wrap_angle(ya - y0) : ya);
      w2 += w * w;
    }
    r.push_back(std::fabs(y0 - pred) / std::sqrt(1.0 + w2));
  }
  if (r.size() < 5) return kNaN;
  auto mid = r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2);
  std::nth_element(r.begin(), mid, r.end());
  return std::max(1.4826 * *mid, 1e-9);  // MAD of a normal
}

namespace {

// The camera noise's autoregressive filter from the same differences: their autocovariance at
// lags of 1..kMaxOrder frames is the camera's own (the averaged IMU noise of two frames does not
// overlap), at lag 0 it is the camera's whole variance (passed in). Levinson-Durbin, the order by
// the Bayesian information criterion: a generic description of the colour, not the form of any
// one camera, and no more terms than the data carry (Akaike's criterion took 6 on a 60 s log,
// whose extra terms, fitted to the autocovariance's own scatter, left the camera's true noise
// far from white).
WhiteningFilter camera_noise_filter(const std::vector<double>& t_s, const std::vector<double>& e,
                                    const std::vector<long>& group, double var0, double frame_s) {
  constexpr int kMaxOrder = 6;
  WhiteningFilter f;
  // Every pair within kMaxOrder frames of each other in one group, once, to the lag of its
  // nearest whole number of frames.
  std::array<double, kMaxOrder + 1> gamma{}, acc{};
  std::array<std::size_t, kMaxOrder + 1> pairs{};
  for (std::size_t i = 0; i < e.size(); ++i)
    for (std::size_t j = i + 1; j < e.size() && group[j] == group[i] && t_s[j] - t_s[i] < (kMaxOrder + 0.5) * frame_s; ++j) {
      const double frames = (t_s[j] - t_s[i]) / frame_s;
      const double lag = std::floor(frames + 0.5);
      if (lag < 1 || !(std::fabs(frames - lag) < 0.5)) continue;
      acc[static_cast<std::size_t>(lag)] += e[i] * e[j];
      ++pairs[static_cast<std::size_t>(lag)];
    }
  gamma[0] = var0;
  for (std::size_t lag = 1; lag <= kMaxOrder; ++lag) {
    if (pairs[lag] < 100) return f;
    gamma[lag] = acc[lag] / static_cast<double>(pairs[lag]);
  }
  // Levinson-Durbin: a[1..p] of e_k = sum a_j e_{k-j} + w_k, innovation variance v.
  // The autocovariances scatter as if from n (1 - rho_1) / (1 + rho_1) independent samples, not
  // n: the criterion counts those.
  const double rho1 = std::clamp(gamma[1] / gamma[0], 0.0, 0.99);
  const double n_eff = static_cast<double>(e.size()) * (1.0 - rho1) / (1.0 + rho1);
  std::vector<double> a, best;
  double v = gamma[0], best_bic = n_eff * std::log(v);
  for (int p = 1; p <= kMaxOrder; ++p) {
    double acc = gamma[static_cast<std::size_t>(p)];
    for (int j = 1; j < p; ++j) acc -= a[static_cast<std::size_t>(j - 1)] * gamma[static_cast<std::size_t>(p - j)];
    const double k = acc / v;
    if (!(std::fabs(k) < 1.0)) break;  // not a valid autocovariance (estimation noise)
    std::vector<double> next(static_cast<std::size_t>(p));
    for (int j = 1; j < p; ++j)
      next[static_cast<std::size_t>(j - 1)] = a[static_cast<std::size_t>(j - 1)] - k * a[static_cast<std::size_t>(p - j - 1)];
    next[static_cast<std::size_t>(p - 1)] = k;
    a = next;
    v *= 1.0 - k * k;
    const double bic = n_eff * std::log(v) + p * std::log(n_eff);
    if (bic < best_bic) {
      best_bic = bic;
      best = a;
    }
  }
  f.ar = best;
  f.frame_s = frame_s;
  return f;
}

}  // namespace

NoiseColour camera_noise_colour(const Dataset& d, const ChannelValues& white) {
  // A tracking camera's error is often coloured (it wanders over a fraction of a second), and
  // the sample-to-sample estimate above sees only its fast part. The IMU heading is a second,
  // independent heading: while the robot does not turn (so a time offset between the two does
  // not matter), camera psi minus IMU heading, its mean and trend removed per 60 s of log (an
  // IMU bias or drift), has the variance of both sensors' whole errors. Less the IMU's own
  // (white) noise, that is the camera's whole heading noise; its ratio to the fast part is the
  // colour factor, taken to hold for x and y too (one pose solver makes all three).
  // An IMU usually reports faster than the camera: the IMU headings within half a camera period
  // of a frame are averaged (n of them), so its white noise enters the difference with variance
  // white^2 / n. On a 60 s log that halves the estimate's spread: the IMU's own noise, and its
  // chance correlation with the camera's, would otherwise be as large as what is estimated.
  NoiseColour nc;
  if (d.gantry || !d.active[kPsi] || !d.active[kImuPsi] || !finite(white[kPsi]) || !finite(white[kImuPsi])) return nc;
  const bool have_r = d.imu_r_radps.size() == d.size();
  std::vector<double> frame_dt;
  for (std::size_t k = 0, last = d.size(); k < d.size(); ++k) {
    if (!finite(d.meas[k][kPsi])) continue;
    if (last < d.size()) frame_dt.push_back(d.t_s[k] - d.t_s[last]);
    last = k;
  }
  if (frame_dt.empty()) return nc;
  auto mid_dt = frame_dt.begin() + static_cast<std::ptrdiff_t>(frame_dt.size() / 2);
  std::nth_element(frame_dt.begin(), mid_dt, frame_dt.end());
  const double half_frame_s = 0.5 * *mid_dt * (1.0 - 1e-6);
  std::vector<double> t, diff;
  double sum = 0, imu_share = 0;  // imu_share: sum of 1 / n over the pairs kept
  std::vector<double> stretch_share;
  std::vector<double> kept_t, kept_e;  // every detrended difference, with its time
  std::vector<long> kept_group;
  long group = -1;
  std::size_t n = 0;
  auto flush = [&]() {
    if (diff.size() >= 40) {
      // Least-squares line through the stretch, removed.
      double mt = 0, md = 0;
      for (std::size_t i = 0; i < diff.size(); ++i) {
        mt += t[i];
        md += diff[i];
      }
      mt /= static_cast<double>(diff.size());
      md /= static_cast<double>(diff.size());
      double stt = 0, std_ = 0;
      for (std::size_t i = 0; i < diff.size(); ++i) {
        stt += (t[i] - mt) * (t[i] - mt);
        std_ += (t[i] - mt) * (diff[i] - md);
      }
      const double slope = stt > 0 ? std_ / stt : 0.0;
      std::vector<double> es(diff.size());
      for (std::size_t i = 0; i < diff.size(); ++i) es[i] = diff[i] - md - slope * (t[i] - mt);
      // A jump of the IMU heading's bias (re-initialised, a magnetic disturbance) is no camera
      // noise: where a line and a jump (5 s and 10 samples or more on either side) leave less than
      // half of what the line alone leaves (a noise that wanders over a second or two loses a
      // tenth or so to a split of a minute), the stretch is their residual instead. Before, a 44
      // mrad jump set the floor 2-3 times too high (a line through either side took most of it).
      const JumpSplit j = split_jump(t, diff, 5.0, 10);
      if (j.line_jump_ss >= 0 && j.total_ss - j.line_jump_ss < 0.5 * (j.total_ss - j.line_ss))
        for (std::size_t i = 0; i < diff.size(); ++i)
          es[i] = diff[i] - j.line_jump[0] - j.line_jump[1] * (t[i] - j.t0_s) - (i >= j.line_jump_at ? j.line_jump[2] : 0.0);
      for (std::size_t i = 0; i < diff.size(); ++i) {
        const double e = es[i];
        sum += e * e;
        imu_share += stretch_share[i];
        kept_t.push_back(t[i]);
        kept_e.push_back(e);
        kept_group.push_back(group);
        ++n;
      }
    }
    t.clear();
    diff.clear();
    stretch_share.clear();
  };
  // Samples grouped by 60 s of log time (not by contiguous stretch: the mean of a short stretch
  // would take away much of a slow noise's variance).
  for (std::size_t k = 0; k < d.size(); ++k) {
    const auto& m = d.meas[k];
    if (!finite(m[kPsi])) continue;
    // The IMU's mean heading over the frame's neighbourhood (angles relative to this row's, or to
    // the first within half a frame where an IMU slower than the log left this row empty), and
    // its yaw rate at this row or the nearest one measured.
    const double ref = finite(m[kImuPsi]) ? m[kImuPsi] : kNaN;
    double acc = 0, first = ref, rate = have_r ? d.imu_r_radps[k] : kNaN, rate_dt = 0;
    int in = 0;
    auto add = [&](std::size_t j) {
      const double dt = std::fabs(d.t_s[j] - d.t_s[k]);
      if (have_r && finite(d.imu_r_radps[j]) && (!finite(rate) || dt < rate_dt)) rate = d.imu_r_radps[j], rate_dt = dt;
      if (!finite(d.meas[j][kImuPsi])) return;
      if (!finite(first)) first = d.meas[j][kImuPsi];
      acc += wrap_angle(d.meas[j][kImuPsi] - first);
      ++in;
    };
    for (std::size_t j = k; j-- > 0 && d.t_s[k] - d.t_s[j] <= half_frame_s;) add(j);
    for (std::size_t j = k; j < d.size() && d.t_s[j] - d.t_s[k] <= half_frame_s; ++j) add(j);
    if (!in) continue;
    // Not turning: the IMU's rate below 0.01 rad/s (or, without it, the screws' yaw pattern, their
    // mean speed, below 0.5 rpm: eq. (10)'s yaw row is the same for every screw).
    const bool still = finite(rate) ? std::fabs(rate) < 0.01 : std::fabs(d.omega_rpm[k].mean()) < 0.5;
    if (!still) continue;
    const long g = static_cast<long>(std::floor((d.t_s[k] - d.t_s.front()) / 60.0));
    if (g != group) {
      flush();
      group = g;
    }
    t.push_back(d.t_s[k]);
    diff.push_back(wrap_angle(m[kPsi] - first - acc / in));
    stretch_share.push_back(1.0 / in);
  }
  flush();
  nc.samples = n;
  if (n < 200) return nc;
  const double whole2 = sum / static_cast<double>(n) - white[kImuPsi] * white[kImuPsi] * imu_share / static_cast<double>(n);
  if (!(whole2 > 0)) return nc;
  nc.factor = std::sqrt(whole2) / white[kPsi];
  // Within what white noise gives (the estimate's own spread is a few %): not coloured.
  nc.applied = nc.factor > 1.25;
  if (nc.applied) {
    nc.whiten = camera_noise_filter(kept_t, kept_e, kept_group, whole2, 2.0 * half_frame_s);
    // The same differences' means over consecutive 2 s windows (each 60 s group's mean removed,
    // as above): the variance of the camera noise's 2 s mean, less the IMU's white share.
    const double window_s = SimOptions{}.anchor_s;
    double s2 = 0, imu2 = 0;
    std::size_t windows = 0;
    for (std::size_t i = 0; i < kept_e.size();) {
      std::size_t j = i;
      double acc = 0;
      while (j < kept_e.size() && kept_group[j] == kept_group[i] && kept_t[j] - kept_t[i] < window_s &&
             (j == i || kept_t[j] - kept_t[j - 1] < 0.5))
        acc += kept_e[j++];
      const double m = static_cast<double>(j - i);
      if (m >= 10) {
        s2 += (acc / m) * (acc / m);
        imu2 += white[kImuPsi] * white[kImuPsi] / m;
        ++windows;
      }
      i = j;
    }
    if (windows >= 10) {
      nc.anchor_windows = windows;
      nc.anchor_share = std::max(0.0, (s2 - imu2) / static_cast<double>(windows)) / whole2;
    }
  }
  return nc;
}

ChannelValues segment_floor(const ChannelValues& noise_floor, const NoiseColour& colour) {
  ChannelValues out = noise_floor;
  if (colour.applied)
    for (int c : {kX, kY}) out[static_cast<std::size_t>(c)] *= std::sqrt(1.0 + colour.anchor_share);
  return out;
}

ChannelValues estimate_noise_floor(const Dataset& data, NoiseColour* colour) {
  ChannelValues out{kNaN, kNaN, kNaN, kNaN};
  std::vector<double> v(data.size());
  for (int c = 0; c < kChannels; ++c) {
    if (!data.active[static_cast<std::size_t>(c)]) continue;
    for (std::size_t k = 0; k < data.size(); ++k) v[k] = data.meas[k][static_cast<std::size_t>(c)];
    out[static_cast<std::size_t>(c)] = estimate_noise(data.t_s, v, c >= kPsi);
  }
  const NoiseColour nc = camera_noise_colour(data, out);
  if (nc.applied)
    for (int c : {kX, kY, kPsi}) out[static_cast<std::size_t>(c)] *= nc.factor;
  if (colour) *colour = nc;
  return out;
}

JumpSplit split_jump(const std::vector<double>& t_s, const std::vector<double>& d, double margin_s,
                     std::size_t min_rows) {
  JumpSplit j;
  const std::size_t n = std::min(t_s.size(), d.size());
  if (n < 2 * std::max<std::size_t>(min_rows, 1)) return j;
  j.t0_s = t_s[n / 2];
  const double d0 = d[0];  // (sums of d - d0: no cancellation on a large offset)
  // Sums over the rows from k on (the jump's indicator): count, t, d.
  std::vector<double> cnt(n + 1, 0.0), st(n + 1, 0.0), sd(n + 1, 0.0);
  double S1 = 0, St = 0, Stt = 0, Sd = 0, Std = 0, Sdd = 0;
  for (std::size_t i = n; i-- > 0;) {
    const double x = t_s[i] - j.t0_s, y = d[i] - d0;
    cnt[i] = cnt[i + 1] + 1;
    st[i] = st[i + 1] + x;
    sd[i] = sd[i + 1] + y;
    S1 += 1, St += x, Stt += x * x, Sd += y, Std += x * y, Sdd += y * y;
  }
  const double mean_ss = Sd * Sd / S1;
  j.total_ss = Sdd - mean_ss;
  const double det = S1 * Stt - St * St;
  j.line_ss = det > 0 ? std::pow(S1 * Std - St * Sd, 2) / (S1 * det) : 0.0;
  double best_line_jump = -1;
  for (std::size_t k = std::max<std::size_t>(min_rows, 1); k + min_rows <= n; ++k) {  // split before row k
    if (t_s[k] - t_s.front() < margin_s || t_s.back() - t_s[k - 1] < margin_s) continue;
    const double na = S1 - cnt[k], nb = cnt[k], a = Sd - sd[k], b = sd[k];
    const double levels = a * a / na + b * b / nb - mean_ss;
    if (levels > j.levels_ss) {
      j.levels_ss = levels;
      j.levels_t_s = 0.5 * (t_s[k - 1] + t_s[k]);
    }
    Eigen::Matrix3d A;
    A << S1, St, cnt[k], St, Stt, st[k], cnt[k], st[k], cnt[k];
    const Eigen::Vector3d rhs(Sd, Std, sd[k]);
    const Eigen::Vector3d c = A.ldlt().solve(rhs);
    const double taken = c.dot(rhs);  // least squares: what the fit takes of Sdd
    if (std::isfinite(taken) && taken > best_line_jump) {
      best_line_jump = taken;
      j.line_jump = c;
      j.line_jump_at = k;
    }
  }
  if (best_line_jump >= 0) {
    j.line_jump_ss = best_line_jump - mean_ss;
    j.line_jump[0] += d0;
  }
  return j;
}

}  // namespace auger::wb
