// Allocation eq. (22): pseudo-inverse and the null-space allocator against brute force over
// the null-space coefficient.
#include <catch2/catch.hpp>

#include <random>

#include "auger/allocation.hpp"

using namespace auger;

namespace {
Model sand() { return make_model(RobotParams{}, TerrainParams{"sand", 0.812, 0.247, 560.33, 320.08, 11.46}); }

bool within(const Vec4& w, double wmax, double tol = 1e-9) { return w.cwiseAbs().maxCoeff() <= wmax + tol; }

// Brute force: over a fine grid of lambda, the smallest |lambda| that keeps every screw within
// the limit and above wmin; or, if none, the best slowest-screw speed.
struct Brute {
  bool met = false;
  double best_abs_lambda = 1e9;
  double best_min_speed = -1;
};
Brute brute(const Vec4& base, const Vec4& n, double wmax, double wmin) {
  Brute b;
  // Saturated cases leave a single admissible lambda, which a grid only hits within its step.
  for (double l = -100; l <= 100; l += 1e-3) {
    const Vec4 w = base + l * n;
    if (!within(w, wmax, 6e-4)) continue;
    const double slowest = w.cwiseAbs().minCoeff();
    b.best_min_speed = std::max(b.best_min_speed, slowest);
    if (slowest >= wmin - 6e-4 && std::fabs(l) < b.best_abs_lambda) b.met = true, b.best_abs_lambda = std::fabs(l);
  }
  return b;
}
}  // namespace

TEST_CASE("pseudo-inverse reproduces tau and stops two screws on the helix diagonal") {
  const Model m = sand();
  AllocatorConfig cfg;
  cfg.kind = AllocatorKind::pseudo_inverse;
  AllocationResult r;
  const Vec3 tau(5, -3, 0.2);
  allocate(m, cfg, tau, r);
  CHECK((m.SB * r.omega_rpm - tau).norm() < 1e-12);
  // The paper's stuck case: a force only screws 0 and 2 produce.
  const Vec3 diag = m.SB * Vec4(-10, 0, 10, 0);
  allocate(m, cfg, diag, r);
  CHECK(r.omega_rpm[1] == Approx(0).margin(1e-12));
  CHECK(r.omega_rpm[3] == Approx(0).margin(1e-12));
  // Saturation keeps the direction.
  allocate(m, cfg, tau * 100, r);
  CHECK(r.omega_rpm.cwiseAbs().maxCoeff() == Approx(23));
  CHECK((m.SB * r.omega_rpm).normalized().dot(tau.normalized()) == Approx(1.0));
}

TEST_CASE("null-space allocator keeps every screw turning on the diagonal, same nominal force") {
  const Model m = sand();
  AllocatorConfig cfg;  // null_space, omega_min 3 rpm
  AllocationResult r;
  const Vec3 diag = m.SB * Vec4(-10, 0, 10, 0);
  allocate(m, cfg, diag, r);
  CHECK(r.min_speed_met);
  CHECK(r.omega_rpm.cwiseAbs().minCoeff() >= 3.0 - 1e-9);
  CHECK((m.SB * r.omega_rpm - diag).norm() < 1e-9);
  CHECK(std::fabs(r.lambda) == Approx(6.0));  // 3 rpm on screws 1, 3 along n = [-1,1,-1,1]/2
  // A stop is a stop: no churning when nothing is asked.
  allocate(m, cfg, Vec3::Zero(), r);
  CHECK(r.omega_rpm.norm() == 0.0);
}

TEST_CASE("null-space allocator equals brute force over lambda on random forces") {
  const Model m = sand();
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> fx(-150, 150), fy(-30, 30), fpsi(-2, 2), wmin(0.5, 6);
  int met = 0, unmet = 0, saturated = 0;
  for (int trial = 0; trial < 150; ++trial) {
    AllocatorConfig cfg;
    cfg.omega_min_rpm = wmin(rng);
    cfg.engage_rpm = 0;
    cfg.priority = trial % 2 ? AllocationPriority::yaw : AllocationPriority::translation;
    const Vec3 tau(fx(rng), fy(rng), fpsi(rng));
    AllocationResult r;
    allocate(m, cfg, tau, r);
    REQUIRE(within(r.omega_rpm, cfg.omega_max_rpm));
    const Vec4 base = r.omega_rpm - r.lambda * m.null_space;
    const Brute b = brute(base, m.null_space, cfg.omega_max_rpm, cfg.omega_min_rpm);
    REQUIRE(b.met == r.min_speed_met);
    if (b.met) {
      ++met;
      CHECK(std::fabs(r.lambda) == Approx(b.best_abs_lambda).margin(2e-3));
    } else {
      ++unmet;
      CHECK(r.omega_rpm.cwiseAbs().minCoeff() == Approx(b.best_min_speed).margin(2e-3));
    }
    if (r.scale_secondary < 1) ++saturated;
    // Unsaturated: the nominal force is delivered exactly.
    if (r.scale_primary == 1 && r.scale_secondary == 1) CHECK((m.SB * r.omega_rpm - tau).norm() < 1e-8);
  }
  CHECK(met > 10);
  CHECK(unmet >= 2);  // best-effort branch: the priority part alone leaves no room
  CHECK(saturated > 10);
}

TEST_CASE("saturation honours the priority and delivers the largest feasible share") {
  const Model m = sand();
  const Vec3 tau(200, 0, 1.0);  // far beyond the screws' reach in x
  for (auto prio : {AllocationPriority::yaw, AllocationPriority::translation}) {
    AllocatorConfig cfg;
    cfg.priority = prio;
    cfg.omega_min_rpm = 0;  // saturation alone here; the trade with the minimum speed below
    AllocationResult r;
    allocate(m, cfg, tau, r);
    CHECK(within(r.omega_rpm, 23));
    const Vec3 got = m.SB * r.omega_rpm;
    if (prio == AllocationPriority::yaw) {
      CHECK(r.scale_primary == 1.0);
      CHECK(got.z() == Approx(1.0));
      CHECK(got.x() == Approx(200 * r.scale_secondary));
    } else {
      CHECK(r.scale_primary < 1.0);  // even x alone saturates
      CHECK(got.z() == Approx(0).margin(1e-9));
    }
    // Brute force: a slightly larger share of the second part fits for no lambda.
    const Vec3 t_primary = prio == AllocationPriority::yaw ? Vec3(0, 0, 1.0) : Vec3(200, 0, 0);
    const Vec3 t_second = tau - t_primary;
    const double sp = r.scale_primary, ss = std::min(1.0, r.scale_secondary + 0.01);
    const Vec4 base = m.SB_pinv * (sp * t_primary + ss * t_second);
    bool fits = false;
    for (double l = -100; l <= 100 && !fits; l += 1e-3) fits = within(base + l * m.null_space, 23);
    CHECK_FALSE(fits);
  }
}

TEST_CASE("saturated on the diagonal: the minimum speed is kept by giving up translation share") {
  const Model m = sand();
  AllocatorConfig cfg;  // yaw priority, omega_min 3 rpm
  const Vec3 tau = m.SB * Vec4(-40, 0, 40, 0);  // the stuck diagonal, beyond saturation
  AllocationResult r;
  allocate(m, cfg, tau, r);
  CHECK(r.min_speed_met);
  CHECK(r.omega_rpm.cwiseAbs().minCoeff() >= 3.0 - 1e-6);
  CHECK(within(r.omega_rpm, 23));
  CHECK(r.scale_secondary < 23.0 / 40.0);
  // Brute force over (share, lambda): no larger share keeps all screws in [3, 23] rpm.
  const Vec4 w = m.SB_pinv * tau;
  bool larger_fits = false;
  for (double s = r.scale_secondary + 0.005; s <= 1.0 && !larger_fits; s += 0.005)
    for (double l = -100; l <= 100 && !larger_fits; l += 1e-2) {
      const Vec4 o = s * w + l * m.null_space;
      larger_fits = within(o, 23) && o.cwiseAbs().minCoeff() >= 3.0;
    }
  CHECK_FALSE(larger_fits);
  // Same direction of force, only less of it.
  CHECK((m.SB * r.omega_rpm).normalized().dot(tau.normalized()) == Approx(1.0));
}

// Where the floor can be met on either side of zero, the side is decided by the smallest |lambda|,
// which a small change of the force flips: a screw reversed for one cycle passes through zero,
// where it blocks in sand. Carried over from the last cycle (`out`), the side holds unless the
// other saves more than sign_hold_rpm.
TEST_CASE("null-space allocator keeps a screw's direction across cycles unless reversing saves more than the hold") {
  const Model m = sand();
  const auto tau = [&](double d_rpm) { return Vec3(m.SB * Vec4(-10, d_rpm, 10, d_rpm)); };  // screws 1, 3 near zero
  for (double hold : {0.0, 2.0}) {
    AllocatorConfig cfg;  // omega_min 3 rpm
    cfg.sign_hold_rpm = hold;
    AllocationResult carried;
    int reversals_carried = 0, reversals_fresh = 0;
    double last_carried = 0, last_fresh = 0;
    for (int k = 0; k < 20; ++k) {
      const double d = k % 2 ? -0.2 : 0.2;  // the force's wobble from cycle to cycle
      allocate(m, cfg, tau(d), carried);
      AllocationResult fresh;
      allocate(m, cfg, tau(d), fresh);
      CHECK(carried.omega_rpm.cwiseAbs().minCoeff() >= 3.0 - 1e-9);
      CHECK((m.SB * carried.omega_rpm - tau(d)).norm() < 1e-9);  // the same force either way
      if (k > 0 && carried.omega_rpm[1] * last_carried < 0) ++reversals_carried;
      if (k > 0 && fresh.omega_rpm[1] * last_fresh < 0) ++reversals_fresh;
      last_carried = carried.omega_rpm[1];
      last_fresh = fresh.omega_rpm[1];
    }
    INFO("sign_hold_rpm " << hold);
    CHECK(reversals_fresh == 19);  // no memory: the side follows the wobble
    CHECK(reversals_carried == (hold > 0 ? 0 : 19));
    if (hold > 0) {
      // Far enough that the other side saves 5 rpm on every screw: it reverses.
      const double before = carried.omega_rpm[1];
      allocate(m, cfg, tau(before > 0 ? -5.0 : 5.0), carried);
      CHECK(carried.omega_rpm[1] * before < 0);
    }
  }
}
