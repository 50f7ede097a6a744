// The online estimator and change detector (auger/online_estimator.hpp), docs/benchmarks.md
// "Online identification":
//   online_bench cost [CYCLES (20000)] [effects | twin]
//     time per 10 ms cycle of OnlineEstimator::step on recorded driving with terrain changes (the
//     inputs are made before the clock starts; scripts/bench-online.sh counts instructions from
//     two runs of different length, on x86 with callgrind and on aarch64 under qemu); `effects`:
//     with three effect parameters online as well (a slope's two inclines and a quadratic drag
//     along x, the truth on a 0.05 rad slope), the most a model file may mark;
//   online_bench cost [CYCLES] kinematic | kinematic-acc
//     the same for KinematicVelocity::step, the velocity augerd feeds the estimator with
//     `[online] velocity = "kinematic"`: a camera pose every third cycle and the IMU's heading and
//     rate every cycle; kinematic-acc also the IMU's acceleration (eq. (1)'s specific force) and
//     the camera's noise as coloured (0.3 s), as `make demo` runs it;
//   online_bench curve [RUNS (40)] [HOURS (1)] [VELOCITY_SD_MPS (0.002)]
//     batch runs of the core's model (bench/online_drive.hpp), for each detector threshold: the
//     detection delay of RUNS terrain changes (sand <-> frozen grass at a random time), the false
//     alarms in HOURS of uniform driving on each terrain, and the largest relative error of the
//     five parameters 3 s after each change;
//   online_bench track [RUNS (5)]
//     closed loop on the core's model (online_tracking_run): the tracking RMS with the fixed
//     configured terrain and with the online estimate, 120 s of 0.5 m squares per run.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "auger/args.hpp"
#include "auger/kinematic_velocity.hpp"
#include "auger/model_file.hpp"
#include "auger/online_estimator.hpp"
#include "online_drive.hpp"
#include "quantile.hpp"

using namespace auger;
using auger::bench::quantile;

namespace {

Vec5 params(const Model& m) {
  Vec5 p;
  p << m.terrain.sigma_long, m.terrain.sigma_lat, m.terrain.D_x, m.terrain.D_y, m.terrain.D_psi;
  return p;
}

int cost(const Model& sand_plain, const Model& grass_plain, long cycles, bool effects, bool twin) {
  // 30 s of driving with a change at 15 s, replayed as often as needed.
  constexpr int kRecorded = 3000;
  ModelFile file = load_model_file(AUGER_MODELS_DIR "/robot.toml");
  std::vector<OnlineEffectParam> online;
  if (effects) {
    const auto marked = [](const char* id, std::vector<const char*> names) {
      EffectConfig c;
      c.id = id;
      c.file = "bench";
      for (const char* n : names) {
        EffectParamValue p;
        p.name = n;
        p.online = true;
        c.params.push_back(p);
      }
      return c;
    };
    file.effects.push_back(marked("terrain_slope", {"incline_x_rad", "incline_y_rad"}));
    file.effects.push_back(marked("quadratic_drag", {"c_x_nspm2"}));
    online = online_effect_params(file, EffectRegistry::builtin());
  }
  const Model sand = effects ? build_model(file, "sand") : sand_plain;
  ModelFile truth = file;
  if (effects) truth.effects[0].params[0].value = 0.05;
  const Model grass = effects ? build_model(truth, "frozen_grass") : grass_plain;
  OnlineDriveOptions o;
  o.change_at_s = 15;
  OnlineDrive drive(sand, grass, o);
  std::vector<Vec4> omega(kRecorded);
  std::vector<Vec3> zeta(kRecorded), eta(kRecorded);
  for (int k = 0; k < kRecorded; ++k) {
    drive.next();
    omega[std::size_t(k)] = drive.omega_rpm;
    zeta[std::size_t(k)] = drive.zeta_meas;
    eta[std::size_t(k)] = drive.eta_true();
  }
  OnlineConfig c;
  c.enabled = true;
  if (twin) c.detect_memory_s = 1.0;  // the detector's twin (docs/daemon.md `detect_memory_s`)
  OnlineEstimator est(sand, c, online);
  double checksum = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (long k = 0; k < cycles; ++k) {
    const std::size_t i = std::size_t(k % kRecorded);
    est.step(omega[i], zeta[i], OnlineDrive::kDt, eta[i]);
    checksum += est.cusum();
  }
  const auto t1 = std::chrono::steady_clock::now();
  const double us = 1e6 * std::chrono::duration<double>(t1 - t0).count() / double(cycles);
  std::printf("online_bench: %ld cycles, %.3f us per cycle (estimator and detector%s), %llu changes%s\n", cycles, us,
              effects ? ", three effect parameters" : twin ? ", the detector's twin" : "", static_cast<unsigned long long>(est.changes()),
              std::isfinite(checksum) ? "" : " (non-finite!)");
  if (cycles < 100000) return 0;  // the instruction counts (scripts/bench-online.sh) need no more
  // The cycle that ends a window carries the RLS and CUSUM updates: each call timed alone (the
  // clock's own cost, tens of ns, included).
  std::vector<double> each_us(std::size_t(kRecorded) * 10);
  for (std::size_t k = 0; k < each_us.size(); ++k) {
    const std::size_t i = k % kRecorded;
    const auto a = std::chrono::steady_clock::now();
    est.step(omega[i], zeta[i], OnlineDrive::kDt, eta[i]);
    each_us[k] = 1e6 * std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count();
  }
  std::sort(each_us.begin(), each_us.end());
  auto q = [&](double f) { return each_us[std::min(each_us.size() - 1, std::size_t(f * double(each_us.size())))]; };
  std::printf("online_bench: each call timed: median %.3f us, 90th pct. %.3f us, 99th %.3f us, largest %.3f us\n",
              q(0.5), q(0.9), q(0.99), each_us.back());
  return 0;
}

int kinematic_cost(const Model& sand, const Model& grass, long cycles, bool acc) {
  constexpr int kRecorded = 3000;  // 30 s of driving, replayed as often as needed
  OnlineDriveOptions o;
  o.change_at_s = 15;
  OnlineDrive drive(sand, grass, o);
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0, 1);
  std::vector<SensorInput> in(kRecorded);
  Vec3 zeta_prev = Vec3::Zero();
  for (int k = 0; k < kRecorded; ++k) {
    drive.next();
    const Vec3& eta = drive.eta_true();
    const Vec3& z = drive.zeta_true();
    SensorInput& s = in[std::size_t(k)];
    if (k % 3 == 0) {  // a 33 Hz camera, 1 mm and 5 mrad
      s.has_pose = true;
      s.pose = eta + Vec3(0.001 * n(rng), 0.001 * n(rng), 0.005 * n(rng));
      s.pose_cov = Vec3(1e-6, 1e-6, 2.5e-5).asDiagonal();
    }
    s.has_imu_psi = s.has_imu_r = true;
    s.imu_psi_rad = eta[2] + 0.005 * n(rng);
    s.imu_r_radps = z[2] + 0.005 * n(rng);
    if (acc) {  // eq. (1): a_x = u' - r v, a_y = v' + r u, plus the IMU's noise
      const Vec3 dz = (z - zeta_prev) / OnlineDrive::kDt;
      s.has_imu_acc = true;
      s.imu_ax_mps2 = dz[0] - z[2] * z[1] + 0.015 * n(rng);
      s.imu_ay_mps2 = dz[1] + z[2] * z[0] + 0.015 * n(rng);
    }
    zeta_prev = z;
  }
  KinematicVelocityConfig c;
  c.use_accelerometer = acc;
  if (acc) c.pose_noise_corr_s = 0.3;
  KinematicVelocity kin(c);
  kin.reset(Vec3::Zero());
  double checksum = 0;
  long known = 0, inertial = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (long k = 0; k < cycles; ++k) {
    const Vec3& v = kin.step(in[std::size_t(k % kRecorded)], OnlineDrive::kDt);
    if (std::isfinite(v[0])) checksum += v[0], ++known;
    inertial += kin.inertial();
  }
  const auto t1 = std::chrono::steady_clock::now();
  std::printf("online_bench: %ld cycles, %.3f us per cycle (KinematicVelocity, %s), velocity known in %.1f %% of "
              "them, from the accelerometer's filter in %.1f %%%s\n",
              cycles, 1e6 * std::chrono::duration<double>(t1 - t0).count() / double(cycles),
              acc ? "camera, IMU heading, rate and acceleration" : "camera, IMU heading and rate",
              100.0 * double(known) / double(cycles), 100.0 * double(inertial) / double(cycles), std::isfinite(checksum) ? "" : " (non-finite!)");
  return 0;
}

int curve(const Model& sand, const Model& grass, int runs, double hours, double vel_sd) {
  const double thresholds[] = {4, 6, 8, 12, 16, 24, 32};
  std::printf("velocity noise %.4g m/s (%.4g rad/s in yaw), %d changes, %.3g h of uniform driving per terrain\n\n",
              vel_sd, 2.5 * vel_sd, runs, hours);
  std::printf("| threshold | median delay | 95th pct. delay | missed (none in 3 s) | false alarms per hour | "
              "error 3 s after: largest of five, median / 95th pct. | median error of sigma_long, sigma_lat, D_x, "
              "D_y, D_psi |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  for (double h : thresholds) {
    OnlineConfig c;
    c.enabled = true;
    c.cusum_threshold = h;
    c.velocity_sd = Vec3(vel_sd, vel_sd, 2.5 * vel_sd);  // configured for the noise it gets
    std::vector<double> delays, errors, per_param[5];
    int missed = 0;
    for (int r = 0; r < runs; ++r) {
      const bool to_grass = r % 2 == 0;
      const Model& a = to_grass ? sand : grass;
      const Model& b = to_grass ? grass : sand;
      OnlineDriveOptions o;
      o.seed = 1000u + unsigned(r);
      o.velocity_sd = Vec3(vel_sd, vel_sd, 2.5 * vel_sd);
      o.change_at_s = 15.0 + 0.37 * r - 10.0 * std::floor(0.037 * r);  // 15-25 s, spread over the window
      OnlineDrive drive(a, b, o);
      OnlineEstimator est(a, c);
      double detected = NAN;
      while (drive.t_s() < o.change_at_s + 3.0 - 1e-9) {
        drive.next();
        if (est.step(drive.omega_rpm, drive.zeta_meas, OnlineDrive::kDt) && drive.changed() && std::isnan(detected))
          detected = drive.t_s() - o.change_at_s;
      }
      if (std::isnan(detected)) ++missed;
      else delays.push_back(detected);
      const Vec5 truth = params(b);
      const Vec5 rel = (est.estimate().value - truth).cwiseQuotient(truth).cwiseAbs();
      errors.push_back(rel.maxCoeff());
      for (int k = 0; k < 5; ++k) per_param[k].push_back(rel[k]);
    }
    long alarms = 0;
    for (const Model* m : {&sand, &grass}) {
      OnlineDriveOptions o;
      o.seed = 7u;
      o.velocity_sd = Vec3(vel_sd, vel_sd, 2.5 * vel_sd);
      OnlineDrive drive(*m, *m, o);
      OnlineEstimator est(*m, c);
      const long n = long(hours * 3600 / OnlineDrive::kDt);
      for (long k = 0; k < n; ++k) {
        drive.next();
        est.step(drive.omega_rpm, drive.zeta_meas, OnlineDrive::kDt);
      }
      alarms += long(est.changes());
    }
    std::printf("| %g | %.2f s | %.2f s | %d of %d | %.2f | %.1f %% / %.1f %% | %.1f, %.1f, %.1f, %.1f, %.1f %% |\n", h,
                quantile(delays, 0.5), quantile(delays, 0.95), missed, runs, double(alarms) / (2 * hours),
                100 * quantile(errors, 0.5), 100 * quantile(errors, 0.95), 100 * quantile(per_param[0], 0.5),
                100 * quantile(per_param[1], 0.5), 100 * quantile(per_param[2], 0.5), 100 * quantile(per_param[3], 0.5),
                100 * quantile(per_param[4], 0.5));
    std::fflush(stdout);
  }
  return 0;
}

// Tracking RMS with the fixed configured terrain and with online identification, on uniform
// ground and across a change (online_tracking_run).
int track(const Model& sand, const Model& grass, const ModelFile& file, int runs) {
  std::printf("| truth | configured | velocity fed to the estimator | tracking RMS fixed | with [online] | heading RMS "
              "fixed | with [online] | changes detected (sum over runs) | sigma_long used at the end (mean) |\n"
              "|---|---|---|---|---|---|---|---|---|\n");
  struct Case {
    const char* truth;
    const Model *before, *after;
    double change_at_s;
    const char* configured_name;
    const Model* configured;
  };
  const Case cases[] = {{"sand", &sand, &sand, 1e9, "sand", &sand},
                        {"frozen grass", &grass, &grass, 1e9, "frozen_grass", &grass},
                        {"frozen grass", &grass, &grass, 1e9, "sand", &sand},
                        {"sand, frozen grass from 40 s", &sand, &grass, 40, "sand", &sand}};
  for (const Case& k : cases) {
    const ControllerConfig cc = controller_config(file, k.configured_name);
    for (const int velocity : {kEkfVelocity, kTrueVelocity, kKinematicVelocity}) {
      double fixed_m = 0, online_m = 0, fixed_rad = 0, online_rad = 0, sigma = 0;
      std::uint64_t changes = 0;
      for (int r = 0; r < runs; ++r) {
        const unsigned seed = 1u + unsigned(r);
        const TrackingRun f = online_tracking_run(*k.before, *k.after, k.change_at_s, *k.configured, cc, false, 120, seed);
        const TrackingRun o =
            online_tracking_run(*k.before, *k.after, k.change_at_s, *k.configured, cc, true, 120, seed, velocity);
        fixed_m += f.rms_m / runs;
        online_m += o.rms_m / runs;
        fixed_rad += f.rms_rad / runs;
        online_rad += o.rms_rad / runs;
        sigma += o.used[0] / runs;
        changes += o.changes;
      }
      std::printf("| %s | %s | %s | %.2f mm | %.2f mm | %.2f mrad | %.2f mrad | %llu | %.3f N/rpm |\n", k.truth,
                  k.configured_name,
                  velocity == kTrueVelocity        ? "true + 0.5 mm/s"
                  : velocity == kKinematicVelocity ? "kinematic (camera + IMU)"
                                                   : "the EKF's (as augerd)", 1e3 * fixed_m,
                  1e3 * online_m, 1e3 * fixed_rad, 1e3 * online_rad, static_cast<unsigned long long>(changes), sigma);
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const CommandLine cli{"online_bench", "cost [CYCLES] [effects | twin | kinematic | kinematic-acc] | curve [RUNS] [HOURS] [VELOCITY_SD_MPS] | track [RUNS]",
                        "The online estimator's cost per cycle, and the change detector's delay / false-alarm\n"
                        "curve over its threshold on the core's model (docs/benchmarks.md).\n",
                        {},
                        ""};
  Args args;
  if (const int rc = cli.parse_or_answer(argc, argv, args); rc >= 0) return rc;
  const auto& pos = args.positional;
  auto num = [&](std::size_t i, double def, const char* what) {
    double v = def;
    if (pos.size() > i && (!Args::to_number("online_bench", what, pos[i], v) || !(v > 0))) {
      std::fprintf(stderr, "online_bench: %s must be a positive number, not '%s'\n", what, pos[i].c_str());
      std::exit(2);
    }
    return v;
  };
  const ModelFile file = load_model_file(AUGER_MODELS_DIR "/robot.toml");
  const Model sand = build_model(file, "sand"), grass = build_model(file, "frozen_grass");
  const std::string what = pos.size() > 2 && !pos.empty() && pos[0] == "cost" ? pos[2] : "";
  if (!what.empty() && what != "effects" && what != "twin" && what != "kinematic" && what != "kinematic-acc") {
    std::fprintf(stderr, "online_bench: cost's third word is 'effects', 'twin', 'kinematic', 'kinematic-acc' or nothing, not '%s'\n",
                 what.c_str());
    return 2;
  }
  if (what == "kinematic" || what == "kinematic-acc")
    return kinematic_cost(sand, grass, long(num(1, 20000, "CYCLES")), what == "kinematic-acc");
  if (!pos.empty() && pos[0] == "cost")
    return cost(sand, grass, long(num(1, 20000, "CYCLES")), what == "effects", what == "twin");
  if (!pos.empty() && pos[0] == "track") return track(sand, grass, file, int(num(1, 5, "RUNS")));
  if (!pos.empty() && pos[0] == "curve")
    return curve(sand, grass, int(num(1, 40, "RUNS")), num(2, 1, "HOURS"), num(3, 0.002, "VELOCITY_SD_MPS"));
  std::fprintf(stderr, "online_bench: say cost or curve (--help)\n");
  return 2;
}
