// The online estimator and change detector replayed on firmware-in-the-loop logs
// (docs/benchmarks.md "Online identification"): the logs of scripts/sim-batch.py (auger-sim-drive,
// the controller on its configured terrain, apply off), each fed as augerd feeds its
// OnlineEstimator (host/augerd/online_link.cpp): the logged screw speeds, the camera poses and
// the IMU through KinematicVelocity (velocity = "kinematic") or, to tell the velocity's errors
// from the model's, the true velocity of the truth log.
//   online_fil stats DIR [options]   the innovation's statistics per DOF on the uniform logs
//   online_fil curve DIR [options]   detection delay and false alarms over the threshold, and
//                                    sigma_long / D_x 3 s after the robot reached a terrain
// With apply off the controller never sees the estimate, so replaying the estimator on a log is
// what augerd with [online] would have computed on it.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "auger/args.hpp"
#include "auger/kinematic_velocity.hpp"
#include "auger/log.hpp"
#include "auger/model_file.hpp"
#include "auger/online_estimator.hpp"
#include "quantile.hpp"

using namespace auger;
using auger::bench::quantile;

namespace {

constexpr double kDt = 0.01;
constexpr double kMergeS = 0.5;  // contacts crossing an edge within this are one change (scripts/demo-field.py)

struct Entry {
  std::string log, truth, kind, terrain, drive;
};

std::vector<std::vector<std::string>> read_csv(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error(path + ": cannot open");
  std::vector<std::vector<std::string>> rows;
  std::string line;
  std::getline(f, line);  // header
  while (std::getline(f, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) cells.push_back(c);
    if (!cells.empty()) rows.push_back(cells);
  }
  return rows;
}

struct Options {
  OnlineConfig cfg;
  KinematicVelocityConfig kin;
  int omega_delay = 0;  // cycles the screw speeds are delayed against the velocity
  bool truth = false;
  double truth_noise_mps = 0, truth_noise_tau_s = 0;  // --truth-noise
  std::vector<double> thresholds{8, 16, 24, 32, 40, 60, 80};
  bool thresholds_given = false;  // --trace: the detector at the first of them
  double detect_s = 3.0;  // an alarm later than this after a change is a miss
  bool list_missed = false;
};

// One log's inputs to the estimator, cycle by cycle.
struct Replay {
  std::vector<Vec4> omega;
  std::vector<Vec3> zeta;
  std::vector<double> t;
  std::vector<double> sd;  // the kinematic filter's SD of u (m/s)
  std::vector<Vec3> zeta_true;
  // Cycles in which a screw's command (cmd_rpm_i) reversed for that one cycle: -3, +4.8, -3 rpm
  // passes the screw through zero, where it blocks in sand; -1: the log has no commands.
  long command_blips = -1;
};

// The true body velocity at each truth row (central differences of the true pose, eq. (1) turned back).
std::vector<Vec3> true_velocity(const std::string& path) {
  CsvLogReader r(path);
  const int cx = r.column_index("x_m"), cy = r.column_index("y_m"), cp = r.column_index("psi_rad");
  std::vector<Vec3> eta;
  while (r.next()) eta.emplace_back(r.value(cx), r.value(cy), r.value(cp));
  std::vector<Vec3> z(eta.size(), Vec3::Zero());
  for (std::size_t k = 1; k + 1 < eta.size(); ++k) {
    const Vec3 d = (eta[k + 1] - eta[k - 1]) / (2 * kDt);
    const double c = std::cos(eta[k][2]), s = std::sin(eta[k][2]);
    z[k] << c * d[0] + s * d[1], -s * d[0] + c * d[1], std::remainder(eta[k + 1][2] - eta[k - 1][2], 2 * M_PI) / (2 * kDt);
  }
  return z;
}

Replay load(const std::string& dir, const Entry& e, const Options& o) {
  const bool use_truth = o.truth;
  const int omega_delay = o.omega_delay;
  CsvLogReader r(dir + "/" + e.log);
  auto col = [&](const std::string& n) {
    const int c = r.column_index(n);
    if (c < 0) throw std::runtime_error(e.log + ": no column " + n);
    return c;
  };
  const int cx = col("x_m"), cy = col("y_m"), cp = col("psi_rad"), cip = col("imu_psi_rad"), cir = col("imu_r_radps");
  // The accelerometer's columns, absent from logs written before the simulated IMU had one.
  const int cax = r.column_index("imu_ax_mps2"), cay = r.column_index("imu_ay_mps2");
  int co[4], cc[4];
  for (int i = 0; i < 4; ++i) co[i] = col("omega_rpm_" + std::to_string(i));
  for (int i = 0; i < 4; ++i) cc[i] = r.column_index("cmd_rpm_" + std::to_string(i));
  Vec4 cmd1 = Vec4::Zero(), cmd2 = Vec4::Zero();  // the command one and two cycles back
  const std::vector<Vec3> vt = true_velocity(dir + "/" + e.truth);
  KinematicVelocity kin(o.kin);  // augerd's online_kin_ (default configuration)
  Replay out;
  std::vector<Vec4> raw;
  const Vec3 cam_sd(0.003, 0.003, 0.005);  // what the simulated camera reports (sim/robot/sensors.hpp)
  std::mt19937 rng(std::hash<std::string>{}(e.log));
  std::normal_distribution<double> gauss(0.0, 1.0);
  Vec3 noise = Vec3::Zero();
  while (r.next()) {
    SensorInput s;
    if (!std::isnan(r.value(cx))) {
      s.has_pose = true;
      s.pose = Vec3(r.value(cx), r.value(cy), r.value(cp));
      s.pose_cov = cam_sd.cwiseProduct(cam_sd).asDiagonal();
    }
    if (!std::isnan(r.value(cip))) {
      s.has_imu_psi = s.has_imu_r = true;
      s.imu_psi_rad = r.value(cip);
      s.imu_r_radps = r.value(cir);
    }
    if (cax >= 0 && cay >= 0 && !std::isnan(r.value(cax)) && !std::isnan(r.value(cay))) {
      s.has_imu_acc = true;
      s.imu_ax_mps2 = r.value(cax);
      s.imu_ay_mps2 = r.value(cay);
    }
    Vec4 om;
    for (int i = 0; i < 4; ++i) om[i] = r.value(co[i]);
    if (cc[0] >= 0 && cc[1] >= 0 && cc[2] >= 0 && cc[3] >= 0) {
      if (out.command_blips < 0) out.command_blips = 0;
      for (int i = 0; i < 4; ++i) {
        const double c = r.value(cc[i]);
        if (cmd2[i] * cmd1[i] < 0 && cmd2[i] * c > 0) ++out.command_blips;
        cmd2[i] = cmd1[i];
        cmd1[i] = std::isnan(c) ? 0.0 : c;
      }
    }
    const Vec3 zk = kin.step(s, kDt);
    out.sd.push_back(kin.body_velocity_sd()[0]);
    const std::size_t k = out.t.size();
    out.zeta_true.push_back(k < vt.size() ? vt[k] : Vec3::Constant(NAN));
    // --truth-noise: the true velocity plus an independent first-order Gauss-Markov error.
    const double phi = o.truth_noise_tau_s > 0 ? std::exp(-kDt / o.truth_noise_tau_s) : 0.0;
    noise = phi * noise + std::sqrt(1 - phi * phi) * o.truth_noise_mps * Vec3(gauss(rng), gauss(rng), 0.0);
    out.zeta.push_back(use_truth ? (k < vt.size() ? Vec3(vt[k] + noise) : Vec3::Constant(NAN)) : zk);
    raw.push_back(om);
    out.omega.push_back(raw.size() > std::size_t(omega_delay) ? raw[raw.size() - 1 - std::size_t(omega_delay)] : Vec4::Zero());
    out.t.push_back(r.t_s());
  }
  return out;
}

// The changes of the ground under the contacts (changes.csv), merged as scripts/demo-field.py
// does, with how many contacts stood on the band (terrain id 1) before and after.
struct Change {
  double t_s;
  int before, after;
};
// A change's kind, as curve's table names it: "drive, before -> after".
std::string kind_of(const std::string& drive, const Change& c) {
  return drive + ", " + std::to_string(c.before) + " -> " + std::to_string(c.after);
}
std::map<std::string, std::vector<Change>> read_changes(const std::string& dir) {
  std::map<std::string, std::vector<Change>> out;
  for (const auto& row : read_csv(dir + "/changes.csv")) {
    if (row.size() < 4 || row[2] != "contacts") continue;
    auto& v = out[row[0] + ".csv"];
    const double t = std::stod(row[1]);
    const int on_band = int(std::count(row[3].begin(), row[3].end(), '1'));
    if (v.empty() || t - v.back().t_s >= kMergeS) v.push_back({t, v.empty() ? 0 : v.back().after, on_band});
    else v.back().after = on_band;
  }
  return out;
}

// The stretches of a field log with all four contacts on one terrain (changes.csv's contacts rows
// whose ids are all equal): from, until the next contacts row, and the terrain (0: the field's
// sand, 1: its frozen-grass band).
struct Stretch {
  double from_s, to_s;
  int terrain;
};
std::map<std::string, std::vector<Stretch>> read_stretches(const std::string& dir) {
  std::map<std::string, std::vector<Stretch>> out;
  std::map<std::string, std::string> last_ids;
  for (const auto& row : read_csv(dir + "/changes.csv")) {
    if (row.size() < 4 || row[2] != "contacts") continue;
    auto& v = out[row[0] + ".csv"];
    const double t = std::stod(row[1]);
    if (!v.empty() && std::isnan(v.back().to_s)) v.back().to_s = t;
    std::string ids = row[3];
    while (!ids.empty() && (ids.back() == '\r' || ids.back() == ' ')) ids.pop_back();  // the csv module's CRLF
    if (ids == "0 0 0 0" || ids == "1 1 1 1") v.push_back({t, NAN, ids[0] - '0'});
  }
  return out;
}

// Per-DOF statistics of the innovation on the uniform logs.
struct InnovStats {
  double n = 0, sum = 0, sum2 = 0, nis0 = 0;  // nis0: e^2 / (configured noise + phi^T P phi)
  static constexpr int kLags = 6;
  const int lags[kLags] = {1, 2, 3, 5, 10, 30};
  double lag_sum[kLags] = {}, lag_n[kLags] = {};
};

int stats(const std::string& dir, const std::vector<Entry>& logs, const Options& o, const Model& sand, const Model& grass) {
  InnovStats st[3];
  double hours = 0;
  std::vector<std::vector<double>> series[3];  // per log, per window (NaN: not informative)
  std::map<std::string, std::vector<double>> sigma;  // terrain and drive: sigma_long each window from 10 s
  std::map<std::string, std::pair<long, long>> blips;  // terrain and drive: command reversals, cycles
  Vec3 verr2 = Vec3::Zero(), dverr2 = Vec3::Zero();  // the velocity's error against the truth, squared
  double verr_n = 0, dverr_n = 0;
  for (const Entry& e : logs) {
    if (e.kind != "uniform") continue;
    std::vector<double>& sig = sigma[e.terrain + ", " + e.drive];
    const Replay rp = load(dir, e, o);
    OnlineEstimator est(e.terrain == "sand" ? sand : grass, o.cfg);
    for (auto& s : series) s.emplace_back();
    std::uint64_t w = est.windows();
    for (std::size_t k = 0; k < rp.t.size(); ++k) {
      est.step(rp.omega[k], rp.zeta[k], kDt);
      if (est.windows() == w) continue;
      w = est.windows();
      if (est.t_s() < 5) continue;  // the kinematic filter's and the estimator's start
      if (est.t_s() >= 10) sig.push_back(est.estimate().value[kSigmaLong]);
      for (int j = 0; j < 3; ++j) {
        const double ej = est.last_innovation()[j];
        series[j].back().push_back(ej);
        if (std::isnan(ej)) continue;
        st[j].n += 1, st[j].sum += ej, st[j].sum2 += ej * ej;
        st[j].nis0 += ej * ej / (est.configured_noise_var()[j] + est.last_innovation_param_var()[j]);
      }
    }
    hours += rp.t.size() * kDt / 3600;
    if (rp.command_blips >= 0) {
      auto& b = blips[e.terrain + ", " + e.drive];
      b.first += rp.command_blips;
      b.second += long(rp.t.size());
    }
    for (std::size_t k = 0; k < rp.t.size(); ++k) {
      if (rp.t[k] < 5) continue;
      const Vec3 d = rp.zeta[k] - rp.zeta_true[k];
      if (!d.allFinite()) continue;
      verr2 += d.cwiseProduct(d), ++verr_n;
      // The velocity's change over a regression window (0.1 s) against the truth's: what eq. (6)'s
      // left side sees.
      const std::size_t w = std::size_t(std::lround(o.cfg.window_s / kDt));
      if (k >= w) {
        const Vec3 dd = d - (rp.zeta[k - w] - rp.zeta_true[k - w]);
        if (dd.allFinite()) dverr2 += dd.cwiseProduct(dd), ++dverr_n;
      }
    }
  }
  const Vec3 vrms = (verr2 / verr_n).cwiseSqrt(), dvrms = (dverr2 / dverr_n).cwiseSqrt();
  std::printf("velocity fed against the truth from 5 s on (%s): RMS u %.2f mm/s, v %.2f mm/s, r %.2f mrad/s; "
              "its change over %.2f s: RMS u %.2f mm/s, v %.2f mm/s\n\n",
              o.truth ? "the truth itself" : o.kin.use_accelerometer ? "kinematic, accelerometer where logged" : "kinematic, no accelerometer",
              1e3 * vrms[0], 1e3 * vrms[1], 1e3 * vrms[2], o.cfg.window_s, 1e3 * dvrms[0], 1e3 * dvrms[1]);
  const char* dof[3] = {"surge (x)", "sway (y)", "yaw"};
  const char* unit[3] = {"N", "N", "N m"};
  std::printf("innovation on the uniform logs (%.2f h, %s velocity), per 0.1 s window:\n\n", hours,
              o.truth ? "the true" : "the kinematic");
  std::printf("| DOF | windows informative | mean | SD | SD assumed (velocity_sd) | mean NIS (1 if as assumed) "
              "| autocorrelation at lag 1, 2, 3, 5, 10, 30 windows |\n|---|---|---|---|---|---|---|\n");
  for (int j = 0; j < 3; ++j) {
    InnovStats& s = st[j];
    const double mean = s.sum / s.n, var = s.sum2 / s.n - mean * mean;
    std::string ac;
    for (int l = 0; l < InnovStats::kLags; ++l) {
      double num = 0, n = 0;
      for (const auto& v : series[j])
        for (std::size_t k = std::size_t(s.lags[l]); k < v.size(); ++k)
          if (!std::isnan(v[k]) && !std::isnan(v[k - std::size_t(s.lags[l])]))
            num += (v[k] - mean) * (v[k - std::size_t(s.lags[l])] - mean), n += 1;
      char b[32];
      std::snprintf(b, sizeof b, "%s%.2f", l ? ", " : "", num / n / var);
      ac += b;
    }
    OnlineEstimator probe(sand, o.cfg);
    std::printf("| %s | %.0f %% | %.3g %s | %.3g %s | %.3g %s | %.2f | %s |\n", dof[j],
                100 * s.n / double(series[j].empty() ? 1 : [&] {
                  std::size_t n = 0;
                  for (const auto& v : series[j]) n += v.size();
                  return n;
                }()),
                mean, unit[j], std::sqrt(var), unit[j], std::sqrt(probe.configured_noise_var()[j]), unit[j], s.nis0 / s.n,
                ac.c_str());
  }
  std::printf("\nsigma_long estimated on the uniform logs (every window from 10 s on; the truth: sand %.3f, frozen "
              "grass %.3f N/rpm):\n\n| terrain, drive | median | 5th-95th pct. |\n|---|---|---|\n",
              sand.terrain.sigma_long, grass.terrain.sigma_long);
  for (const auto& [k, v] : sigma)
    std::printf("| %s | %.3f N/rpm | %.3f-%.3f N/rpm |\n", k.c_str(), quantile(v, 0.5), quantile(v, 0.05), quantile(v, 0.95));
  if (!blips.empty()) {
    std::printf("\nscrew commands reversed for one cycle (cmd_rpm_i: a sign change undone the next cycle), per 100 "
                "cycles:\n\n| terrain, drive | reversals per 100 cycles |\n|---|---|\n");
    for (const auto& [k, b] : blips) std::printf("| %s | %.1f |\n", k.c_str(), 100.0 * double(b.first) / double(b.second));
  }
  return 0;
}

// How far each change moves the surge innovation, with no detector restarting the estimate: the
// mean over the windows 0.1-1 s after the change less the mean over 1.5-0.1 s before it (each of 3
// windows or more), in N, per kind of change (drive, contacts on the band before -> after). Set
// against the innovation's own SD on uniform ground (`online_fil stats`), it says which changes a
// detector could see within a second.
void innovation_shifts(const Replay& rp, const Model& m, OnlineConfig c, const std::vector<Change>& ch,
                       const std::string& drive, std::map<std::string, std::vector<double>>& out) {
  c.cusum_threshold = 1e300;
  OnlineEstimator est(m, c);
  std::vector<double> t_s, e_n;
  std::uint64_t w = est.windows();
  for (std::size_t k = 0; k < rp.t.size(); ++k) {
    est.step(rp.omega[k], rp.zeta[k], kDt);
    if (est.windows() == w) continue;
    w = est.windows();
    if (std::isfinite(est.last_innovation()[0])) t_s.push_back(rp.t[k]), e_n.push_back(est.last_innovation()[0]);
  }
  for (const Change& x : ch) {
    double sum[2] = {0, 0};
    int n[2] = {0, 0};
    for (std::size_t k = 0; k < t_s.size(); ++k) {
      const double dt = t_s[k] - x.t_s;
      const int side = dt > -1.5 && dt < -0.1 ? 0 : dt > 0.1 && dt < 1.0 ? 1 : -1;
      if (side >= 0) sum[side] += e_n[k], ++n[side];
    }
    if (n[0] >= 3 && n[1] >= 3)
      out[kind_of(drive, x)].push_back(std::fabs(sum[1] / n[1] - sum[0] / n[0]));
  }
}

int curve(const std::string& dir, const std::vector<Entry>& logs, const Options& o, const Model& sand, const Model& grass) {
  const auto changes = read_changes(dir);
  const auto stretches = read_stretches(dir);
  const std::size_t nt = o.thresholds.size();
  // Point 2's re-identification: sigma_long / D_x (the steady speed per rpm, what a held drag
  // leaves to identify) 3 s after all four contacts reached a terrain, against that terrain's.
  std::vector<std::vector<double>> ratio_err(nt);
  std::vector<std::vector<double>> delays(nt);
  std::vector<int> missed(nt, 0), n_changes(nt, 0);
  std::vector<long> alarms_uniform(nt, 0), alarms_field_extra(nt, 0);
  std::vector<std::string> missed_list(nt);  // "log t_s" of each missed change
  // Missed / all per drive and contacts on the band before -> after, per threshold.
  std::map<std::string, std::vector<std::pair<int, int>>> by_kind;
  std::map<std::string, std::vector<double>> shifts;  // per kind, innovation_shifts
  double h_uniform = 0, h_field = 0;
  for (const Entry& e : logs) {
    const Replay rp = load(dir, e, o);
    const double hours = rp.t.size() * kDt / 3600;
    (e.kind == "uniform" ? h_uniform : h_field) += hours;
    const Model& m = e.terrain == "frozen_grass" ? grass : sand;  // a field's controller is on its background, sand
    const auto it = changes.find(e.log);
    const std::vector<Change> none;
    const std::vector<Change>& ch = it == changes.end() ? none : it->second;
    if (e.kind != "uniform") innovation_shifts(rp, m, o.cfg, ch, e.drive, shifts);
    for (std::size_t i = 0; i < nt; ++i) {
      OnlineConfig c = o.cfg;
      c.cusum_threshold = o.thresholds[i];
      OnlineEstimator est(m, c);
      std::vector<double> alarms;
      const auto st = stretches.find(e.log);
      std::size_t next_stretch = 0;
      for (std::size_t k = 0; k < rp.t.size(); ++k) {
        if (est.step(rp.omega[k], rp.zeta[k], kDt)) alarms.push_back(rp.t[k]);
        if (st == stretches.end() || next_stretch >= st->second.size()) continue;
        const Stretch& s = st->second[next_stretch];
        if (rp.t[k] < s.from_s + 3.0) continue;
        ++next_stretch;
        if (!(s.to_s >= s.from_s + 3.0) || s.from_s < 10) continue;  // left before 3 s, or the start
        const Model& truth = s.terrain == 1 ? grass : sand;
        const Vec5& v = est.estimate().value;
        ratio_err[i].push_back(std::fabs((v[kSigmaLong] / v[kDx]) / (truth.terrain.sigma_long / truth.terrain.D_x) - 1));
      }
      if (e.kind == "uniform") {
        alarms_uniform[i] += long(alarms.size());
        continue;
      }
      std::vector<bool> used(alarms.size(), false);
      for (std::size_t c2 = 0; c2 < ch.size(); ++c2) {
        const double t_ch = ch[c2].t_s;
        if (t_ch < 5) continue;  // before the detector has started
        ++n_changes[i];
        const double next = c2 + 1 < ch.size() ? ch[c2 + 1].t_s : 1e300;
        double d = NAN;
        for (std::size_t a = 0; a < alarms.size(); ++a)
          if (alarms[a] >= t_ch && alarms[a] < next && alarms[a] - t_ch <= o.detect_s) {
            if (std::isnan(d)) d = alarms[a] - t_ch;
            used[a] = true;
          }
        auto& kind = by_kind[kind_of(e.drive, ch[c2])];
        kind.resize(nt);
        ++kind[i].second;
        if (std::isnan(d)) {
          ++kind[i].first;
          char b[160];
          std::snprintf(b, sizeof b, "%s%s %.2f s", missed_list[i].empty() ? "" : ", ", e.log.c_str(), t_ch);
          missed_list[i] += b;
          ++missed[i];
          delays[i].push_back(INFINITY);
        } else {
          delays[i].push_back(d);
        }
      }
      for (std::size_t a = 0; a < alarms.size(); ++a) alarms_field_extra[i] += used[a] ? 0 : 1;
    }
  }
  std::printf("%s velocity; %.2f h on uniform ground, %.2f h across the field\n\n", o.truth ? "true" : "kinematic",
              h_uniform, h_field);
  std::printf("| threshold | median delay | 95th pct. delay | missed (none in %.0f s) | false alarms per hour, uniform "
              "| alarms per hour across the field not after a change |\n|---|---|---|---|---|---|\n",
              o.detect_s);
  for (std::size_t i = 0; i < nt; ++i)
    std::printf("| %g | %.2f s | %.2f s | %d of %d | %.2f | %.1f |\n", o.thresholds[i], quantile(delays[i], 0.5),
                quantile(delays[i], 0.95), missed[i], n_changes[i], double(alarms_uniform[i]) / h_uniform,
                double(alarms_field_extra[i]) / h_field);
  std::printf("\nsigma_long / D_x 3 s after all four contacts reached a terrain (stretches of 3 s or more), error "
              "against that terrain's:\n\n| threshold | stretches | median | 95th pct. | within 5 %% |\n|---|---|---|---|---|\n");
  for (std::size_t i = 0; i < nt; ++i) {
    const std::vector<double>& r = ratio_err[i];
    const auto within = std::count_if(r.begin(), r.end(), [](double x) { return x <= 0.05; });
    std::printf("| %g | %zu | %.1f %% | %.1f %% | %ld of %zu |\n", o.thresholds[i], r.size(), 100 * quantile(r, 0.5),
                100 * quantile(r, 0.95), long(within), r.size());
  }
  std::printf("\nmissed of each kind of change (the drive; contacts on the field's band, before -> after):\n\n| kind |");
  for (std::size_t i = 0; i < nt; ++i) std::printf(" threshold %g |", o.thresholds[i]);
  std::printf(" the surge innovation's shift, median (no detector) |\n|---|");
  for (std::size_t i = 0; i < nt; ++i) std::printf("---|");
  std::printf("---|\n");
  for (const auto& [kind, n] : by_kind) {
    std::printf("| %s |", kind.c_str());
    for (std::size_t i = 0; i < nt; ++i) std::printf(" %d of %d |", n[i].first, n[i].second);
    const auto sh = shifts.find(kind);
    if (sh == shifts.end() || sh->second.empty()) std::printf(" - |\n");  // no change with windows on both sides
    else std::printf(" %.2f N |\n", quantile(sh->second, 0.5));
  }
  if (o.list_missed)
    for (std::size_t i = 0; i < nt; ++i) std::printf("\nmissed at threshold %g: %s\n", o.thresholds[i], missed_list[i].c_str());
  return 0;
}

// One log's windows: t, innovation and its assumed SD per DOF, sigma_long, the CUSUM.
int trace(const std::string& dir, const std::string& log, const Options& o, const Model& sand, const Model& grass) {
  const Entry e{log, log.substr(0, log.size() - 4) + ".truth.csv", "",
                log.find("frozen_grass") != std::string::npos ? "frozen_grass" : "sand", ""};
  const Replay rp = load(dir, e, o);
  OnlineConfig cfg = o.cfg;
  if (o.thresholds_given) cfg.cusum_threshold = o.thresholds.front();
  OnlineEstimator est(e.terrain == "sand" ? sand : grass, cfg);
  std::uint64_t w = est.windows();
  std::printf("t_s,e_x,e_y,e_psi,sd_x,sd_y,u,v,sigma_long,cusum,change,kin_sd,u_true,v_true,omega_min_rpm\n");
  double omega_min = INFINITY;  // the slowest screw over the window (rpm)
  for (std::size_t k = 0; k < rp.t.size(); ++k) {
    const bool ch = est.step(rp.omega[k], rp.zeta[k], kDt);
    omega_min = std::min(omega_min, rp.omega[k].cwiseAbs().minCoeff());
    if (est.windows() == w) continue;
    w = est.windows();
    const Vec3& iv = est.last_innovation();
    std::printf("%.2f,%.3g,%.3g,%.3g,%.3g,%.3g,%.4f,%.4f,%.4f,%.2f,%d,%.4f,%.4f,%.4f,%.2f\n", rp.t[k], iv[0], iv[1], iv[2],
                std::sqrt(est.configured_noise_var()[0] + est.last_innovation_param_var()[0]),
                std::sqrt(est.configured_noise_var()[1] + est.last_innovation_param_var()[1]), rp.zeta[k][0], rp.zeta[k][1],
                est.estimate().value[0], est.cusum(), ch ? 1 : 0, rp.sd[k], rp.zeta_true[k][0], rp.zeta_true[k][1], omega_min);
    omega_min = INFINITY;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const CommandLine cli{
      "online_fil",
      "stats|curve DIR [OPTIONS]",
      "The online estimator and its change detector replayed on scripts/sim-batch.py's logs in DIR\n"
      "(manifest.csv, changes.csv), as augerd with [online] velocity = \"kinematic\" would run them.\n",
      {{"--truth", "", "feed the true velocity (truth log) instead of the kinematic filter's"},
       {"--velocity-sd", "U,V,R", "[online] velocity_sd (default 0.012,0.012,0.01, scripts/online-fil.sh)"},
       {"--drag-prior", "X", "[online] drag_prior_rel_sd (default 0.01)"},
       {"--memory-s", "S", "[online] memory_s (default 5)"},
       {"--detect-memory-s", "S", "[online] detect_memory_s (default 0: the detector tests the estimate's own)"},
       {"--window-s", "S", "OnlineConfig::window_s, the regression's window (default 0.1)"},
       {"--detect-s", "S", "an alarm later than S after a change is a miss (default 3)"},
       {"--slow-screw-rpm", "X", "OnlineConfig::slow_screw_rpm (default 2; 0: every window)"},
       {"--slow-screw-guard-s", "S", "OnlineConfig::slow_screw_guard_s (default 0.02; 0: as before it)"},
       {"--max-pose-age", "S", "KinematicVelocityConfig::max_pose_age_s (default 0.12; 1e9: never unknown)"},
       {"--omega-delay", "N", "the screw speeds fed N cycles late (the velocity's lag)"},
       {"--no-acc", "", "leave the logged accelerometer out (KinematicVelocityConfig::use_accelerometer off)"},
       {"--acc-noise", "D", "KinematicVelocityConfig::acc_noise_mps2_per_sqrt_hz (default 1.5e-3)"},
       {"--acc-bias-walk", "W", "KinematicVelocityConfig::acc_bias_walk_mps2_per_sqrt_s (default 5e-4)"},
       {"--camera-corr-s", "S", "KinematicVelocityConfig::pose_noise_corr_s (default 0: white)"},
       {"--no-whiten", "", "the detector on the innovation as it is (OnlineConfig::whiten off)"},
       {"--truth-noise", "SD,TAU", "with --truth: add an independent error of SD m/s in u and v, correlated over TAU s"},
       {"--thresholds", "A,B,...", "the detector's thresholds for curve"},
       {"--list-missed", "", "curve: name each missed change (log and time) per threshold"},
       {"--trace", "LOG", "instead: every window of LOG (CSV: innovation, sigma_long, CUSUM; the detector at the first of --thresholds)"}},
      "Exit 2: bad usage.\n"};
  Args args;
  if (const int rc = cli.parse_or_answer(argc, argv, args); rc >= 0) return rc;
  if (args.positional.size() != 2 || (args.positional[0] != "stats" && args.positional[0] != "curve")) {
    cli.print_usage(stderr);
    return 2;
  }
  Options o;
  o.cfg.enabled = true;
  o.cfg.velocity_sd = Vec3(0.012, 0.012, 0.01);
  o.cfg.drag_prior_rel_sd = 0.01;
  o.truth = args.has("--truth");
  o.list_missed = args.has("--list-missed");
  o.cfg.whiten = !args.has("--no-whiten");
  long delay = 0;
  if (!args.whole("online_fil", "--omega-delay", 0, 0, 100, delay)) return 2;
  o.omega_delay = int(delay);
  if (!args.number("online_fil", "--memory-s", 5.0, o.cfg.memory_s) ||
      !args.number("online_fil", "--detect-memory-s", 0.0, o.cfg.detect_memory_s) ||
      !args.number("online_fil", "--detect-s", 3.0, o.detect_s) ||
      !args.number("online_fil", "--window-s", 0.1, o.cfg.window_s) ||
      !args.number("online_fil", "--slow-screw-rpm", 2.0, o.cfg.slow_screw_rpm) ||
      !args.number("online_fil", "--slow-screw-guard-s", o.cfg.slow_screw_guard_s, o.cfg.slow_screw_guard_s) ||
      !args.number("online_fil", "--max-pose-age", o.kin.max_pose_age_s, o.kin.max_pose_age_s) ||
      !args.number("online_fil", "--camera-corr-s", 0.0, o.kin.pose_noise_corr_s) ||
      !args.number("online_fil", "--acc-noise", o.kin.acc_noise_mps2_per_sqrt_hz, o.kin.acc_noise_mps2_per_sqrt_hz) ||
      !args.number("online_fil", "--acc-bias-walk", o.kin.acc_bias_walk_mps2_per_sqrt_s,
                   o.kin.acc_bias_walk_mps2_per_sqrt_s))
    return 2;
  o.kin.use_accelerometer = !args.has("--no-acc");
  std::vector<double> sd{o.cfg.velocity_sd[0], o.cfg.velocity_sd[1], o.cfg.velocity_sd[2]};
  if (!args.numbers("online_fil", "--velocity-sd", 3, sd) ||
      !args.number("online_fil", "--drag-prior", 0.01, o.cfg.drag_prior_rel_sd) ||
      !args.numbers("online_fil", "--thresholds", 0, o.thresholds))
    return 2;
  o.cfg.velocity_sd = Vec3(sd[0], sd[1], sd[2]);
  o.thresholds_given = args.has("--thresholds");
  std::vector<double> tn{0.0, 0.0};
  if (!args.numbers("online_fil", "--truth-noise", 2, tn)) return 2;
  if (!(tn[0] >= 0) || !(tn[1] >= 0) || (tn[0] > 0 && !o.truth)) {
    std::fprintf(stderr, "online_fil: --truth-noise needs --truth and SD, TAU >= 0\n");
    return 2;
  }
  o.truth_noise_mps = tn[0], o.truth_noise_tau_s = tn[1];
  const std::string dir = args.positional[1];
  try {
    std::vector<Entry> logs;
    for (const auto& r : read_csv(dir + "/manifest.csv"))
      if (r.size() >= 5) logs.push_back({r[0], r[1], r[2], r[3], r[4]});
    const ModelFile file = load_model_file(AUGER_MODELS_DIR "/robot.toml");
    const Model sand = build_model(file, "sand"), grass = build_model(file, "frozen_grass");
    if (args.has("--trace")) return trace(dir, args.get("--trace"), o, sand, grass);
    return args.positional[0] == "stats" ? stats(dir, logs, o, sand, grass) : curve(dir, logs, o, sand, grass);
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "online_fil: %s\n", ex.what());
    return 1;
  }
}
