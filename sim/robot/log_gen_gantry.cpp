// The gantry's log of the batch log generator (log_gen.hpp): one screw module on the
// identification rail (eqs. (11)-(14)) driven by ideal screws in runs along the rail, with the
// hidden effect, the nominal rail alongside for the effect's size, written as a gantry log
// (docs/log-format.md "Gantry log").
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

#include "auger/log.hpp"
#include "log_gen_internal.hpp"

namespace auger::sim {

using namespace loggen;

namespace {

constexpr double kRail_m = 0.5;  // the paper's rail

// eqs. (11)-(14): m x'' = -D u + sigma B omega, B_x = [-1, -1], B_y = [-1, 1]; then the effect.
GantryTruthParams gantry_truth(const TerrainParams& terrain, double mass_kg, bool lateral, const EffectSpec& e) {
  GantryTruthParams gp;
  gp.mass_kg = mass_kg;
  gp.sigma = lateral ? terrain.sigma_lat : terrain.sigma_long;
  gp.drag = lateral ? terrain.D_y : terrain.D_x;
  gp.b = lateral ? std::array<double, 2>{-1.0, 1.0} : std::array<double, 2>{-1.0, -1.0};
  apply_gantry_effect(e, lateral, kRail_m, gp);
  return gp;
}

// The screw command: runs along the rail, reversing at its ends: single-dof at 5, 10, 20 rpm
// (jittered), manual at random speeds 3-22 rpm; 1-2 s standing between runs. Draws from rng.
class RailRuns {
 public:
  RailRuns(const LogGenConfig& cfg, std::mt19937_64& rng) : cfg_(cfg), rng_(rng), speed_(run_speed(0)) {}
  // The speed (rpm, signed) at t with the carriage at x_m.
  double at(double t, double x_m) {
    if (t >= rest_until_) {
      const bool at_end = (dir_ > 0 && x_m >= kRail_m - 0.05) || (dir_ < 0 && x_m <= 0.05);
      if (at_end) {
        dir_ = -dir_;
        speed_ = run_speed(++run_no_);
        rest_until_ = t + 1.0 + u01_(rng_);
      }
    }
    return t < rest_until_ ? 0.0 : dir_ * speed_;
  }

 private:
  double run_speed(int n) {
    if (cfg_.trajectory == Trajectory::single_dof) {
      const double speeds[] = {5.0, 10.0, 20.0};
      return speeds[n % 3] * (0.9 + 0.2 * u01_(rng_));
    }
    return 3.0 + 19.0 * u01_(rng_);
  }

  const LogGenConfig& cfg_;
  std::mt19937_64& rng_;
  std::uniform_real_distribution<double> u01_{0.0, 1.0};
  double dir_ = 1.0, speed_, rest_until_ = 0.0;
  int run_no_ = 0;
};

// The nominal rail alongside for the effect's size: the same screw speeds, no effect, reset to
// the truth every size_segment_s; exact first-order steps of m u' = -D u + sigma_nominal B omega.
struct NominalRail {
  double sigma, drag, mass_kg;
  std::array<double, 2> b;
  double x_m, u_mps = 0, next_reset_s = 0;

  void step(const Vec4& mean_rpm, double h_s) {
    const double u_ss = sigma * (b[0] * mean_rpm[0] + b[1] * mean_rpm[1]) / drag;
    const double a0 = std::exp(-drag / mass_kg * h_s);
    const double u_new = u_ss + a0 * (u_mps - u_ss);
    x_m += u_ss * h_s + (u_mps - u_ss) * (1 - a0) * mass_kg / drag;
    u_mps = u_new;
  }
};

std::string mass_text(double mass_kg) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", mass_kg);
  return buf;
}

}  // namespace

LogGenResult generate_gantry_log(const TerrainParams& terrain, double mass_kg, const LogGenConfig& cfg,
                                 std::ostream& out) {
  const std::vector<EffectSpec> effects = active_effects(cfg);
  if (effects.size() > 1) throw std::invalid_argument("a gantry log takes one hidden effect");
  const EffectSpec e = effects.empty() ? EffectSpec{} : effects.front();
  if (!info_of(e.id).gantry) throw std::invalid_argument("effect " + e.id + " applies to robot logs only");
  if (!(cfg.seconds > 0)) throw std::invalid_argument("--seconds must be > 0");
  if (!(mass_kg > 0)) throw std::invalid_argument("gantry mass must be > 0");
  const bool lateral = cfg.gantry == GantryAxis::lateral;
  const auto n_ticks = static_cast<std::size_t>(std::lround(cfg.seconds / kTick_s)) + 1;

  const GantryTruthParams gp = gantry_truth(terrain, mass_kg, lateral, e);
  const std::array<double, 2>& b = gp.b;
  const bool patch = gp.soft_patch.on;
  TrueGantry gantry(gp);
  const double patch_c = gp.soft_patch.centre_m, patch_r = gp.soft_patch.half_length_m;

  std::mt19937_64 rng(cfg.seed * 7919 + 29);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::mt19937_64 noise_rng(cfg.seed * 2654435761ULL + 13);
  std::normal_distribution<double> n01(0.0, 1.0);
  GantryLogWriter log(out, {{"format", kGantryLogFormat},
                            {"axis", lateral ? "lateral" : "longitudinal"},
                            {"terrain", cfg.terrain},
                            {"mass_kg", mass_text(mass_kg)}});
  LogGenResult res;
  res.truth.reserve(n_ticks);
  GantryState& s = gantry.state();
  s.x_m = 0.05;
  RailRuns runs(cfg, rng);
  double sq = 0;
  std::array<double, 2> rev{u01(rng), u01(rng)}, rev_prev = rev;
  Vec4 omega = Vec4::Zero(), target = Vec4::Zero();
  double force_window_n = 0.0;
  NominalRail base{lateral ? terrain.sigma_lat : terrain.sigma_long, lateral ? terrain.D_y : terrain.D_x, mass_kg, b,
                   s.x_m};
  for (std::size_t k = 0; k < n_ticks; ++k) {
    const double t = static_cast<double>(k) * kTick_s;
    const double w_cmd = runs.at(t, s.x_m);
    // + x needs sigma b . omega > 0: omega_i = w b_i (|b_i| = 1).
    target = Vec4(w_cmd * b[0], w_cmd * b[1], 0, 0);
    GantrySample g;
    g.t_s = t;
    for (int i = 0; i < 2; ++i)
      g.omega_rpm[static_cast<std::size_t>(i)] =
          k == 0 ? 0.0 : encoder_rpm(rev_prev[static_cast<std::size_t>(i)], rev[static_cast<std::size_t>(i)], cfg.counts_per_rev);
    rev_prev = rev;
    // The force sensor's reading: the traction averaged over the same 10 ms window as the
    // encoder speed (its anti-aliasing filter), so both columns describe the same interval.
    g.force_n = (k == 0 ? 0.0 : force_window_n / 10.0) + cfg.gantry_force_noise_n * n01(noise_rng);
    force_window_n = 0.0;
    g.position_m = s.x_m + cfg.gantry_position_noise_m * n01(noise_rng);
    log.write(g);
    bool acting = e.id != "none";
    if (patch) acting = std::fabs(s.x_m - patch_c) < patch_r;
    res.truth.push_back({t, Vec3(s.x_m, 0, 0), Vec3(s.u_mps, 0, 0), acting});
    if (t >= base.next_reset_s - 1e-9) {
      base.x_m = s.x_m;
      base.u_mps = s.u_mps;
      base.next_reset_s += cfg.size_segment_s;
    }
    sq += (s.x_m - base.x_m) * (s.x_m - base.x_m);
    if (k + 1 == n_ticks) break;
    for (int j = 0; j < 10; ++j) {
      const Vec4 mean_rpm = ideal_screw_step(omega, target, cfg.ideal_tau_s, kCouple_s);
      for (int h = 0; h < 2; ++h) gantry.step(mean_rpm, kCouple_s / 2);
      force_window_n += gantry.traction_n(mean_rpm);
      for (int i = 0; i < 2; ++i) rev[static_cast<std::size_t>(i)] += mean_rpm[i] * (kCouple_s / 60.0);
      base.step(mean_rpm, kCouple_s);
    }
  }
  res.effect_rms = Vec3(std::sqrt(sq / static_cast<double>(n_ticks)), 0, 0);
  if (patch) {
    char note[120];
    std::snprintf(note, sizeof note, "soft_patch on the rail from %.3f to %.3f m", patch_c - patch_r, patch_c + patch_r);
    res.notes.push_back(note);
  }
  return res;
}

}  // namespace auger::sim
