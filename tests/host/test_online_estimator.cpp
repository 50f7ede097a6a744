// The online estimator (auger/online_estimator.hpp) on data of the core's own model
// (bench/online_drive.hpp): re-identification after a terrain change, the detector's delay and
// silence on uniform ground, excitation awareness, clamping and the fallback, no allocation.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "alloc_counter.hpp"
#include "auger/kinematic_velocity.hpp"
#include "auger/model_file.hpp"
#include "auger/online_estimator.hpp"
#include "online_drive.hpp"

using namespace auger;

namespace {
struct Terrains {
  ModelFile file = load_model_file(AUGER_MODELS_DIR "/robot.toml");
  Model sand = build_model(file, "sand");
  Model grass = build_model(file, "frozen_grass");
};
Vec5 params(const Model& m) {
  Vec5 p;
  p << m.terrain.sigma_long, m.terrain.sigma_lat, m.terrain.D_x, m.terrain.D_y, m.terrain.D_psi;
  return p;
}
// Drives and feeds the estimator for a number of cycles.
void drive_for(OnlineDrive& drive, OnlineEstimator& est, long cycles) {
  for (long k = 0; k < cycles; ++k) {
    drive.next();
    est.step(drive.omega_rpm, drive.zeta_meas, OnlineDrive::kDt);
  }
}
OnlineConfig on() {
  OnlineConfig c;
  c.enabled = true;
  return c;
}
// Gauss-Markov velocity noise per DOF: stationary SD sd, correlated over corr_s, one draw per cycle.
class ColouredNoise {
 public:
  ColouredNoise(double corr_s, const Vec3& sd, unsigned seed)
      : a_(std::exp(-OnlineDrive::kDt / corr_s)), b_(std::sqrt(1 - a_ * a_)), sd_(sd), rng_(seed) {}
  const Vec3& next() {
    for (int j = 0; j < 3; ++j) noise_[j] = a_ * noise_[j] + b_ * sd_[j] * n_(rng_);
    return noise_;
  }

 private:
  double a_, b_;
  Vec3 sd_, noise_ = Vec3::Zero();
  std::mt19937 rng_;
  std::normal_distribution<double> n_{0, 1};
};
}  // namespace

// The velocity fed in with 0.5 mm/s of noise and the estimator configured for it: the 3 s aim
// of issue 29 holds; with 2 mm/s the data of 3 s do not carry 5 % (docs/benchmarks.md), and the
// estimate's SD says so: the error stays within 3 SD.
TEST_CASE("online: a change sand -> frozen grass is detected within 0.5 s and re-identified within 5 % in 3 s") {
  Terrains t;
  const Vec5 truth = params(t.grass);
  for (double vel_sd : {0.0005, 0.002}) {
    for (unsigned seed = 1; seed <= 5; ++seed) {
      OnlineDriveOptions o;
      o.change_at_s = 20.0;
      o.seed = seed;
      o.velocity_sd = Vec3(vel_sd, vel_sd, 2.5 * vel_sd);
      OnlineDrive drive(t.sand, t.grass, o);
      OnlineConfig c = on();
      c.velocity_sd = o.velocity_sd;
      OnlineEstimator est(t.sand, c);
      double detected_s = NAN;
      while (drive.t_s() < 23.0 - 1e-9) {
        drive.next();
        if (est.step(drive.omega_rpm, drive.zeta_meas, OnlineDrive::kDt)) {
          INFO("seed " << seed << ": a change at " << drive.t_s() << " s");
          REQUIRE(drive.changed());  // no false alarm before the change
          if (std::isnan(detected_s)) detected_s = drive.t_s();
        }
      }
      INFO("velocity SD " << vel_sd << " m/s, seed " << seed);
      REQUIRE(std::isfinite(detected_s));
      // One seed's robot barely moves after the change at 2 mm/s: the detector waits for data.
      CHECK(detected_s - 20.0 <= (vel_sd < 0.001 ? 0.5 : 1.5));
      CHECK(est.changes() == 1);
      const Vec5 err = (est.estimate().value - truth).cwiseAbs();
      INFO("relative errors " << err.cwiseQuotient(truth).transpose() << ", SDs "
                              << est.estimate().sd.cwiseQuotient(truth).transpose());
      CHECK((err.array() <= 3 * est.estimate().sd.array()).all());
      if (vel_sd < 0.001) {
        // 3 s after the change: every parameter within 5 % of frozen grass, and the controller
        // has taken them (certain enough; an applied value moves again only by more than 2 SD,
        // so it may lag the estimate by that: 10 %).
        CHECK(err.cwiseQuotient(truth).maxCoeff() < 0.05);
        CHECK((est.control_parameters() - truth).cwiseQuotient(truth).cwiseAbs().maxCoeff() < 0.1);
      }
      CHECK(est.fallback().empty());
    }
  }
}

// detect_memory_s: the detector tests a faster twin of the estimate; the estimate the controller
// takes keeps its own memory (its SD as without the twin, not the twin's, about sqrt(5) larger).
TEST_CASE("online: a detector with a shorter memory leaves the estimate alone and finds the change") {
  Terrains t;
  OnlineDriveOptions o;
  o.change_at_s = 20.0;
  o.seed = 3;
  o.velocity_sd = Vec3(0.0005, 0.0005, 0.00125);
  OnlineDrive drive(t.sand, t.grass, o);
  OnlineConfig c = on();
  c.velocity_sd = o.velocity_sd;
  OnlineEstimator alone(t.sand, c);
  c.detect_memory_s = 1.0;
  OnlineEstimator twin(t.sand, c);
  bool innovations_differ = false;
  double detected_s = NAN;
  while (drive.t_s() < 23.0 - 1e-9) {
    drive.next();
    const bool a = alone.step(drive.omega_rpm, drive.zeta_meas, OnlineDrive::kDt);
    const bool b = twin.step(drive.omega_rpm, drive.zeta_meas, OnlineDrive::kDt);
    if (b && std::isnan(detected_s)) detected_s = drive.t_s();
    if (!drive.changed()) {
      REQUIRE(!a);
      REQUIRE(!b);
      if (drive.t_s() > 10) {
        const Vec5 sd = alone.estimate().sd;
        INFO("t " << drive.t_s() << " s: SD with the twin " << twin.estimate().sd.transpose() << ", without " << sd.transpose());
        REQUIRE(((twin.estimate().sd - sd).cwiseAbs().array() <= 0.1 * sd.array()).all());
        REQUIRE(((twin.estimate().value - alone.estimate().value).cwiseAbs().array() <= sd.array()).all());
      }
      const Vec3 ea = alone.last_innovation(), eb = twin.last_innovation();
      for (int j = 0; j < 3; ++j) innovations_differ = innovations_differ || (std::isfinite(ea[j]) && ea[j] != eb[j]);
    }
  }
  CHECK(innovations_differ);  // the detector tests the twin's innovation, not the estimate's
  REQUIRE(std::isfinite(detected_s));
  CHECK(detected_s - 20.0 <= 0.5);
  const Vec5 truth = params(t.grass);
  const Vec5 err = (twin.estimate().value - truth).cwiseAbs().cwiseQuotient(truth);
  INFO("relative errors 3 s after the change " << err.transpose());
  CHECK(err.maxCoeff() < 0.05);
}

TEST_CASE("online: no false alarm in 20 minutes on uniform sand, and the estimate stays on sand") {
  Terrains t;
  OnlineDriveOptions o;
  o.seed = 11;
  OnlineDrive drive(t.sand, t.sand, o);
  OnlineEstimator est(t.sand, on());
  drive_for(drive, est, 20 * 60 * 100);
  CHECK(est.changes() == 0);
  CHECK(est.fallback().empty());
  const Vec5 rel = (est.estimate().value - params(t.sand)).cwiseQuotient(params(t.sand)).cwiseAbs();
  INFO("relative errors " << rel.transpose());
  CHECK(rel.maxCoeff() < 0.05);
  CHECK(believed_terrain(est.estimate(), {t.sand.terrain, t.grass.terrain}) == "sand");
}

TEST_CASE("online: standing still and forward-only driving leave the uninformed parameters alone") {
  Terrains t;
  OnlineEstimator est(t.sand, on());
  const Vec5 prior_sd = est.estimate().sd;
  for (int k = 0; k < 500; ++k) est.step(Vec4::Zero(), Vec3(0.0005, -0.0003, 0.001), 0.01);  // noise only
  CHECK(est.estimate().sd == prior_sd);
  CHECK(est.estimate().value == params(t.sand));
  CHECK(est.last_rows() == 0);

  // Forward only on frozen grass: sigma_long and D_x move to the truth, lateral and yaw stay.
  OnlineDriveOptions o;
  o.forward_only = true;
  OnlineDrive drive(t.grass, t.grass, o);
  OnlineEstimator fwd(t.sand, on());
  drive_for(drive, fwd, 1000);
  const OnlineEstimate& e = fwd.estimate();
  CHECK(std::fabs(e.value[kSigmaLong] / t.grass.terrain.sigma_long - 1) < 0.05);
  CHECK(std::fabs(e.value[kDx] / t.grass.terrain.D_x - 1) < 0.05);
  CHECK(e.informed[kSigmaLong] == 1);
  CHECK(e.informed[kDy] == 0);
  CHECK(e.informed[kDpsi] == 0);
  // Not informed: the configured value and the prior SD, not wound up by the forgetting.
  CHECK(e.value[kDy] == t.sand.terrain.D_y);
  CHECK(e.sd[kDy] == prior_sd[kDy]);
  CHECK(e.sd[kSigmaLat] == prior_sd[kSigmaLat]);
  CHECK(fwd.control_parameters()[kDy] == t.sand.terrain.D_y);
}

// A window with a screw slower than slow_screw_rpm is outside eqs. (6)-(7) (a slow screw blocks
// in sand): it informs nothing. The same forward drive with the bar above its screws' speeds
// leaves every parameter at its prior; below them, as with no bar.
TEST_CASE("online: windows with a slow screw are left out") {
  Terrains t;
  for (const double bar : {0.0, 0.5, 1000.0}) {
    OnlineDriveOptions o;
    o.forward_only = true;
    OnlineDrive drive(t.grass, t.grass, o);
    OnlineConfig c = on();
    c.slow_screw_rpm = bar;
    OnlineEstimator est(t.sand, c);
    const Vec5 prior_sd = est.estimate().sd;
    drive_for(drive, est, 1000);
    INFO("slow_screw_rpm " << bar);
    if (bar > 100) {
      CHECK(est.estimate().informed.sum() == 0);
      CHECK(est.estimate().value == params(t.sand));
      CHECK(est.estimate().sd == prior_sd);
    } else {
      CHECK(std::fabs(est.estimate().value[kSigmaLong] / t.grass.terrain.sigma_long - 1) < 0.05);
    }
  }
}

// A screw stopped for two cycles blocks at once (a dry force against the motion, as the library's
// screw_blocking) but its logged speed, the encoder's, shows the stop two cycles late: the window
// that holds the blocking can have no slow logged speed in it. On the firmware-in-the-loop chain
// every false alarm on uniform sand with the true velocity was such a window
// (docs/benchmarks.md "Blocking next to slow windows"). slow_screw_guard_s also leaves out the
// windows within the guard of a slow logged speed: no false alarm on uniform ground then, and a
// real change is still found within 0.5 s.
namespace {
struct BlockingRun {
  std::uint64_t alarms_before_change = 0;
  double delay_s = NAN;  // first alarm after the change
};
BlockingRun drive_with_blocking(const Terrains& t, double guard_s, double change_at_s) {
  OnlineConfig c = on();
  c.velocity_sd = Vec3(0.0005, 0.0005, 0.00125);
  c.slow_screw_rpm = 2;
  c.slow_screw_guard_s = guard_s;
  OnlineEstimator est(t.sand, c);
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0, 1);
  constexpr double kDt = OnlineDrive::kDt, kBlockN = 15;
  constexpr int kLag = 2;  // cycles the logged stop lags the screw's
  Vec3 zeta = Vec3::Zero();
  BlockingRun out;
  for (long k = 0; k < 120 * 100; ++k) {
    const double t_s = k * kDt;
    const Model& truth = t_s < change_at_s ? t.sand : t.grass;
    // Diagonal driving, the force stepping every 0.5 s (sigma told from D), screws at 3-6 rpm.
    const double level = (k / 50) % 2 ? 1.0 : 2.0;
    Vec4 omega = t.sand.SB_pinv * Vec3(1.0, 0.6, 0.0);
    omega *= 3 * level / omega.cwiseAbs().minCoeff();
    Vec4 seen = omega;  // the logged speeds: the stop two cycles late
    const bool stopped = k % 137 < 2;
    if (stopped) omega[3] = 0;
    if (k % 137 >= kLag && k % 137 < kLag + 2) seen[3] = 0;
    // Eq. (6) over the cycle, exact for forces held over it.
    Vec3 f = truth.SB * omega;
    const double speed = zeta.head<2>().norm();
    if (stopped && speed > 1e-6) f.head<2>() -= kBlockN * zeta.head<2>() / speed;
    for (int j = 0; j < 3; ++j) {
      const double a = std::exp(-truth.D_diag[j] * kDt / truth.M_diag[j]);
      zeta[j] = a * zeta[j] + (1 - a) * f[j] / truth.D_diag[j];
    }
    const Vec3 meas = zeta + Vec3(n(rng), n(rng), 2.5 * n(rng)) * 0.0005;
    if (est.step(seen, meas, kDt)) {
      if (t_s < change_at_s) ++out.alarms_before_change;
      else if (std::isnan(out.delay_s)) out.delay_s = t_s - change_at_s;
    }
  }
  return out;
}
}  // namespace

TEST_CASE("online: windows next to a slow screw are left out: no false alarm from blocking, a change still found") {
  Terrains t;
  // Uniform sand for 120 s: alarms without the guard, none with it.
  CHECK(drive_with_blocking(t, 0.0, 1e9).alarms_before_change > 0);
  CHECK(drive_with_blocking(t, 0.02, 1e9).alarms_before_change == 0);
  // Sand, frozen grass from 60 s on: found within 0.5 s, no alarm before.
  const BlockingRun r = drive_with_blocking(t, 0.02, 60.0);
  CHECK(r.alarms_before_change == 0);
  CHECK(r.delay_s <= 0.5);
}

// The velocity of the firmware-in-the-loop chain errs in colour (docs/benchmarks.md "Online
// identification": the innovation's lag-1 correlation 0.8 over 0.1 s windows): Gauss-Markov
// velocity noise with a 1 s correlation time (30 min: 23 alarms plain, none prewhitened). The detector's prewhitening (learned lag-1
// correlation and variance) keeps it quiet where the plain normalised innovation alarms.
TEST_CASE("online: coloured velocity noise: the prewhitened detector raises fewer false alarms") {
  Terrains t;
  std::uint64_t alarms[2] = {0, 0};
  for (int whiten = 0; whiten < 2; ++whiten) {
    OnlineDriveOptions o;
    o.seed = 21;
    o.velocity_sd = Vec3::Constant(1e-9);
    OnlineDrive drive(t.sand, t.sand, o);
    OnlineConfig c = on();
    c.whiten = whiten == 1;
    c.velocity_sd = Vec3(0.002, 0.002, 0.005);  // the SD it gets, as if white
    OnlineEstimator est(t.sand, c);
    ColouredNoise noise(1.0, c.velocity_sd, 8);
    for (long k = 0; k < 30L * 60 * 100; ++k) {
      drive.next();
      est.step(drive.omega_rpm, drive.zeta_true() + noise.next(), OnlineDrive::kDt);
    }
    alarms[whiten] = est.changes();
  }
  INFO("false alarms in 30 min: plain " << alarms[0] << ", prewhitened " << alarms[1]);
  CHECK(alarms[0] >= 10);
  CHECK(alarms[1] <= 1);
}

// A terrain change is a step in the innovation; prewhitened against coloured noise, its first
// window carries nearly all its evidence, which the per-window clip (5 SD) would cut. The excess
// is credited once the next window holds the level (OnlineEstimator::update_row); a single wild
// velocity (a window's end sample off by 5 cm/s: the innovation jumps and falls back) is not.
TEST_CASE("online: a held step is credited beyond the clip, a single wild window is not") {
  Terrains t;
  Model half = t.sand;  // two screws on frozen grass: halfway
  set_terrain_parameters(half, 0.5 * (params(t.sand) + params(t.grass)));
  for (int run = 0; run < 2; ++run) {
    OnlineDriveOptions o;
    o.seed = 5;
    o.velocity_sd = Vec3::Constant(1e-9);
    o.change_at_s = run == 0 ? 1e9 : 90.0;
    OnlineDrive drive(t.sand, half, o);
    OnlineConfig c = on();
    c.velocity_sd = Vec3(0.002, 0.002, 0.005);
    OnlineEstimator est(t.sand, c);
    ColouredNoise noise(1.0, c.velocity_sd, 15);
    double first_s = NAN;
    int spikes = 0;
    double wild_n = 0;  // the largest surge innovation the wild samples made (N)
    while (drive.t_s() < 92.0) {
      drive.next();
      Vec3 z = drive.zeta_true() + noise.next();
      // Wild samples every 5 s from 60 s on: one 10 ms velocity 0.3 m/s off.
      const bool wild = run == 0 && drive.t_s() > 60 && drive.t_s() < 88 && std::fmod(drive.t_s() + 1e-6, 5.0) < 0.01;
      if (wild) z[0] += 0.3, ++spikes;
      if (est.step(drive.omega_rpm, z, OnlineDrive::kDt) && std::isnan(first_s)) first_s = drive.t_s();
      if (run == 0 && drive.t_s() > 60 && std::isfinite(est.last_innovation()[0]))
        wild_n = std::max(wild_n, std::fabs(est.last_innovation()[0]));
    }
    INFO("run " << run << ": first alarm at " << first_s << " s, " << spikes << " wild samples, the largest " << wild_n
                << " N");
    if (run == 0) {
      CHECK(spikes >= 5);
      CHECK(wild_n >= 8.0);  // 10 SD of the configured noise (0.8 N): far beyond the clip
      CHECK(std::isnan(first_s));
    } else {
      REQUIRE(std::isfinite(first_s));
      CHECK(first_s >= 90.0);
      CHECK(first_s - 90.0 <= 0.5);  // 1.4 s with the clip alone
    }
  }
}

// The drag held by its prior (drag_prior_rel_sd 0.01) must stay held however long the estimator
// runs: its forgetting also discounts the prior, and the velocity in the drag's column carries
// the camera's coloured error, which pulls a fitted drag, and with it sigma (their ratio is what
// slow driving identifies), away from the truth. The noise here is independent of everything.
TEST_CASE("online: coloured velocity noise leaves the held drag and sigma on the truth") {
  Terrains t;
  OnlineDriveOptions o;
  o.seed = 4;
  o.velocity_sd = Vec3::Constant(1e-9);
  OnlineDrive drive(t.sand, t.sand, o);
  OnlineConfig c = on();
  c.drag_prior_rel_sd = 0.01;
  c.velocity_sd = Vec3(0.002, 0.002, 0.005);
  OnlineEstimator est(t.sand, c);
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0, 1);
  // The simulated camera's: 0.3 s correlation; 10 mm/s against the drive's speeds up to 0.08 m/s,
  // the ratio of the camera's 2 mm/s to the firmware-in-the-loop courses' 0.02 m/s.
  const double a = std::exp(-OnlineDrive::kDt / 0.3), b = std::sqrt(1 - a * a);
  Vec3 noise = Vec3::Zero();
  std::vector<double> sigma, d_x;
  for (long k = 0; k < 10L * 60 * 100; ++k) {
    drive.next();
    for (int j = 0; j < 2; ++j) noise[j] = a * noise[j] + b * 0.01 * n(rng);
    est.step(drive.omega_rpm, drive.zeta_true() + noise, OnlineDrive::kDt);
    if (k % 100 == 0 && drive.t_s() > 60) {
      sigma.push_back(est.estimate().value[kSigmaLong]);
      d_x.push_back(est.estimate().value[kDx]);
    }
  }
  std::sort(sigma.begin(), sigma.end());
  std::sort(d_x.begin(), d_x.end());
  const double sigma_med = sigma[sigma.size() / 2], d_x_med = d_x[d_x.size() / 2];
  INFO("median sigma_long " << sigma_med << " N/rpm (truth " << t.sand.terrain.sigma_long << "), D_x " << d_x_med
                            << " N/(m/s) (truth " << t.sand.terrain.D_x << ")");
  CHECK(std::fabs(d_x_med / t.sand.terrain.D_x - 1) < 0.02);
  CHECK(std::fabs(sigma_med / t.sand.terrain.sigma_long - 1) < 0.05);
}

TEST_CASE("online: the estimate stays in the physical range; divergence falls back to the configured terrain") {
  Terrains t;
  // A velocity 20 times what the screws can give (a broken velocity source): sigma/D would go far
  // out of range; it is clamped, and held at the bound it latches the fallback.
  OnlineEstimator est(t.sand, on());
  OnlineDriveOptions o;
  OnlineDrive drive(t.sand, t.sand, o);
  for (int k = 0; k < 1500; ++k) {
    drive.next();
    est.step(drive.omega_rpm, 20.0 * drive.zeta_meas, OnlineDrive::kDt);
    for (int p = 0; p < 5; ++p) {
      REQUIRE(est.estimate().value[p] >= terrain_range(p).lower);
      REQUIRE(est.estimate().value[p] <= terrain_range(p).upper);
    }
  }
  REQUIRE_FALSE(est.fallback().empty());
  INFO(est.fallback());
  CHECK(est.control_parameters() == params(t.sand));  // the configured terrain
  // Latched: good data afterwards do not clear it; reset() does.
  drive_for(drive, est, 500);
  CHECK_FALSE(est.fallback().empty());
  CHECK(est.control_parameters() == params(t.sand));
  est.reset();
  CHECK(est.fallback().empty());

  // Non-finite input is skipped, never reaches the estimate.
  OnlineEstimator nan_in(t.sand, on());
  for (int k = 0; k < 100; ++k) nan_in.step(Vec4::Constant(10), Vec3(NAN, 0, 0), 0.01);
  CHECK(nan_in.estimate().value.allFinite());
  CHECK(nan_in.fallback().empty());
}

TEST_CASE("online: the believed terrain names the closest row or says unknown with the values") {
  Terrains t;
  OnlineEstimate e;
  e.value = params(t.grass) * 1.05;
  e.sd = params(t.grass) * 0.01;
  CHECK(believed_terrain(e, {t.sand.terrain, t.grass.terrain}) == "frozen_grass");
  e.value = params(t.grass) * 2.0;
  const std::string s = believed_terrain(e, {t.sand.terrain, t.grass.terrain});
  CHECK_THAT(s, Catch::StartsWith("unknown, sigma_long 0.8 N/rpm"));
  CHECK_THAT(s, Catch::Contains("D_psi 9.04 N m/(rad/s)"));
}

// With the drag held (drag_prior_rel_sd 0.01, as scripts/online-fil.sh and make demo run) the
// data identify sigma / D per DOF; the name compares those ratios, not D (held at sand's, which
// is within 15 % of grass's D_x but not of its D_psi: the old rule said "unknown" on grass).
TEST_CASE("online: with the drag held the believed terrain is named by sigma / D") {
  Terrains t;
  OnlineConfig held = on();
  held.drag_prior_rel_sd = 0.01;
  OnlineEstimator est(t.sand, held);
  CHECK(est.estimate().held == (Vec5() << 0, 0, 1, 1, 1).finished());
  CHECK(std::string(believed_basis(est.estimate())) == "sigma / D (D held)");
  CHECK(std::string(believed_basis(OnlineEstimator(t.sand, on()).estimate())) == "sigma, D");
  // At the prior (sigma_long's SD 50 %) both rows fit: not a name given with confidence.
  CHECK(believed_terrain(est.estimate(), {t.grass.terrain, t.sand.terrain}) ==
        "undecided, sand or frozen_grass within the estimate's uncertainty");

  // Grass seen through sand's drag: sigma_long carries grass's sigma_long / D_x (0.4 * 560.33 /
  // 509.81 = 0.440 N/rpm); sigma_lat lightly informed (SD 0.1 N/rpm), so its yaw ratio is loose.
  OnlineEstimate e = est.estimate();
  e.value[kSigmaLong] = 0.4 * 560.33 / 509.81;
  e.sd[kSigmaLong] = 0.01;
  e.sd[kSigmaLat] = 0.1;
  CHECK(believed_terrain(e, {t.sand.terrain, t.grass.terrain}) == "frozen_grass");
  OnlineEstimate not_held = e;
  not_held.held.setZero();
  CHECK_THAT(believed_terrain(not_held, {t.sand.terrain, t.grass.terrain}), Catch::StartsWith("unknown"));
  // A well-informed sigma_lat (sand's) fits both rows' lateral ratio but not grass's yaw ratio
  // (sigma_lat / D_psi: 0.0216 against 0.0354, 39 % off), and sigma_long not sand's: unknown.
  e.sd[kSigmaLat] = 0.005;
  const std::string s = believed_terrain(e, {t.sand.terrain, t.grass.terrain});
  CHECK_THAT(s, Catch::StartsWith("unknown, sigma_long 0.44 N/rpm, sigma_lat 0.247 N/rpm, D_x 560 N/(m/s) (held)"));
  CHECK_THAT(s, Catch::EndsWith("D_psi 11.5 N m/(rad/s) (held)"));
  // Between the rows in sigma_long / D_x: neither.
  e.sd[kSigmaLat] = 0.1;
  e.value[kSigmaLong] = 0.62;
  CHECK_THAT(believed_terrain(e, {t.sand.terrain, t.grass.terrain}), Catch::StartsWith("unknown, sigma_long 0.62"));
  // Sand's ratio, informed: sand alone.
  e.value[kSigmaLong] = 0.8;
  CHECK(believed_terrain(e, {t.sand.terrain, t.grass.terrain}) == "sand");
  // Nothing estimated names nothing.
  e.held.setOnes();
  CHECK_THAT(believed_terrain(e, {t.sand.terrain, t.grass.terrain}), Catch::StartsWith("unknown"));
}

TEST_CASE("online: set_terrain_parameters gives the model make_model would build") {
  Terrains t;
  Model m = t.sand;
  alloc_counter::start();
  set_terrain_parameters(m, params(t.grass));
  CHECK(alloc_counter::stop() == 0);
  CHECK(m.SB.isApprox(t.grass.SB));
  CHECK(m.SB_pinv.isApprox(t.grass.SB_pinv));
  CHECK(m.D_diag == t.grass.D_diag);
  CHECK_THROWS(set_terrain_parameters(m, Vec5::Zero()));
}

TEST_CASE("online: a step allocates nothing on the heap, change and fallback included") {
  Terrains t;
  OnlineDrive drive(t.sand, t.grass, OnlineDriveOptions{5.0});  // a change at 5 s
  OnlineEstimator est(t.sand, on());
  alloc_counter::start();
  drive_for(drive, est, 800);
  for (int k = 0; k < 800; ++k) est.step(drive.omega_rpm, Vec3(5, 5, 5), OnlineDrive::kDt);  // diverges
  const long n = alloc_counter::stop();
  CHECK(est.changes() >= 1);
  CHECK_FALSE(est.fallback().empty());
  CHECK(n == 0);
}

// Issue 29 point 3 on the core's model (online_tracking_run, ideal screws): with a velocity that
// does not come from the controller's model, the identified parameters in the controller's model
// cut the tracking error after a change and cost nothing on uniform ground. Fed with the EKF's
// own velocity the estimate follows the configured model instead (docs/benchmarks.md), which is
// why augerd's `[online] apply` is off by default.
TEST_CASE("online: the controller with the identified terrain tracks better after a change, never worse on uniform ground") {
  Terrains t;
  const ControllerConfig cc = controller_config(t.file, "sand");
  double fixed_change = 0, online_change = 0, fixed_uniform = 0, online_uniform = 0;
  for (unsigned seed = 1; seed <= 2; ++seed) {
    fixed_change += online_tracking_run(t.sand, t.grass, 40, t.sand, cc, false, 120, seed).rms_m;
    const TrackingRun o = online_tracking_run(t.sand, t.grass, 40, t.sand, cc, true, 120, seed, true);
    online_change += o.rms_m;
    CHECK(std::fabs(o.used[kSigmaLong] / t.grass.terrain.sigma_long - 1) < 0.1);  // the controller is on grass
    fixed_uniform += online_tracking_run(t.sand, t.sand, 1e9, t.sand, cc, false, 120, seed).rms_m;
    online_uniform += online_tracking_run(t.sand, t.sand, 1e9, t.sand, cc, true, 120, seed, true).rms_m;
  }
  INFO("tracking RMS across the change: fixed " << fixed_change / 2 << " m, online " << online_change / 2
                                                << " m; uniform sand: fixed " << fixed_uniform / 2 << " m, online "
                                                << online_uniform / 2 << " m");
  CHECK(online_change < 0.8 * fixed_change);
  CHECK(online_uniform <= 1.02 * fixed_uniform);
}

// The terrain-free velocity (auger/kinematic_velocity.hpp): a robot driving an arc (0.05 m/s
// forward, 0.02 m/s sideways, 0.1 rad/s), the camera (2 mm, 2 mrad) every third cycle, the IMU's
// rate (5 mrad/s) every cycle: the body velocity it gives is within 3 of its SDs of the truth
// (the turn from world to body, eq. (1)), and a step allocates nothing.
// A camera dropout: the velocity is unknown (NaN) once the last pose is older than
// max_pose_age_s, rather than the extrapolation of the last acceleration; the next pose ends it.
TEST_CASE("online: the kinematic velocity is unknown in a camera dropout") {
  KinematicVelocity kin;
  SensorInput in;
  in.pose_cov = Mat3::Identity() * 4e-6;
  in.has_imu_r = true;
  Vec3 eta = Vec3::Zero();
  for (int k = 0; k < 100; ++k) {
    eta.x() += 0.0005;  // 0.05 m/s
    in.has_pose = (k < 40 && k % 3 == 0) || k >= 70;
    in.pose = eta;
    const Vec3 v = kin.step(in, 0.01);
    if (k < 3) continue;
    INFO("cycle " << k);
    if (k < 40 || k >= 70) CHECK(std::fabs(v.x() - 0.05) < 0.02);
    else if (k >= 40 + 12) CHECK(std::isnan(v.x()));  // no pose since cycle 39: 0.12 s later
  }
}

TEST_CASE("online: the kinematic velocity follows an arc from the camera and IMU alone") {
  KinematicVelocity kin;
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0, 1);
  const Vec3 zeta(0.05, 0.02, 0.1);
  Vec3 eta = Vec3::Zero();
  const double dt = 0.01;
  Vec3 err2 = Vec3::Zero();
  long counted = 0;
  for (int k = 0; k < 3000; ++k) {
    const double c = std::cos(eta.z()), s = std::sin(eta.z());
    eta += dt * Vec3(c * zeta.x() - s * zeta.y(), s * zeta.x() + c * zeta.y(), zeta.z());
    SensorInput in;
    in.has_pose = k % 3 == 0;
    in.pose = eta + Vec3(0.002 * n(rng), 0.002 * n(rng), 0.002 * n(rng));
    in.pose_cov = Mat3::Identity() * 4e-6;
    in.has_imu_r = true;
    in.imu_r_radps = zeta.z() + 0.005 * n(rng);
    alloc_counter::start();
    const Vec3 v = kin.step(in, dt);
    REQUIRE(alloc_counter::stop() == 0);
    if (k >= 1000) {
      err2 += (v - zeta).cwiseAbs2();
      ++counted;
    }
  }
  const Vec3 rms = (err2 / double(counted)).cwiseSqrt();
  const Vec3 sd = kin.body_velocity_sd();
  INFO("RMS error " << rms.transpose() << ", SD " << sd.transpose());
  CHECK(rms.x() < 3 * sd.x());
  CHECK(rms.y() < 3 * sd.y());
  CHECK(rms.z() < 3 * sd.z());
  CHECK(sd.x() < 0.01);  // 2 mm at 33 Hz: below 1 cm/s
}
