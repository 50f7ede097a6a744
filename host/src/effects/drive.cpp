// Drive effects: changes of how the screw speeds become the body force, eq. (7).
#include <algorithm>
#include <cmath>
#include <limits>

#include "effects.hpp"

namespace auger {
namespace effects {
namespace {

// One screw transmits only (1 - loss) of its nominal force (a slipping or lifted screw).
class ScrewTractionLoss final : public Effect {
 public:
  ScrewTractionLoss(int screw, double loss) : screw_(screw), loss_(loss) {}
  const std::string& id() const override {
    static const std::string s = "screw_traction_loss";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override {
    return {{"screw", static_cast<double>(screw_)}, {"loss", loss_}};
  }
  void drive_force(const Model& model, const Vec4& omega_rpm, double sigma_scale, double, Vec3& tau_n,
                   double*) const override {
    tau_n -= loss_ * sigma_scale * model.SB.col(screw_) * omega_rpm[screw_];  // eq. (7), column of screw i
  }

 private:
  int screw_;
  double loss_;
};

// The traction force saturates per screw: each screw's longitudinal and lateral force of eq. (7)
// (sigma_long B_x,i omega_i, sigma_lat B_y,i omega_i) saturates towards +-force_max,
// f / (1 + |f / force_max|^p)^(1/p), as when the soil under a screw shears before it reaches its
// nominal thrust; the sharpness p runs from gradual (2) to a clip (large p). The yaw share of a
// screw (the lumped row of B) scales with its lateral force. Where the soil under the whole
// footprint shears as one (a soft layer under a firm crust), the limit is the robot's, on the total
// force per axis, four times a screw's: the form parameter pooling blends what each screw's
// saturation sees, its own force (0) or the footprint's mean (1), and at 1 the total along each
// axis is 4 f_max sat(mean / f_max); its yaw against the lateral limit at the screws' lever arm.
// The form parameter ellipse couples the axes: at 0 each saturates against its own limit, at 1
// all against the norm of their loads (the friction ellipse of a soil whose shear strength bounds
// the shear stress vector).
class TractionSaturation final : public Effect {
 public:
  TractionSaturation(double long_max, double lat_max, double p, double pooling, double ellipse)
      : long_max_(long_max), lat_max_(lat_max), p_(p), pooling_(pooling), ellipse_(ellipse) {}
  const std::string& id() const override {
    static const std::string s = "traction_saturation";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override {
    return {{"force_max_long_n", long_max_},
            {"force_max_lat_n", lat_max_},
            {"sharpness", p_},
            {"pooling", pooling_},
            {"ellipse", ellipse_}};
  }
  // State: each screw's and axis's last load, sharpness and share, so that the sub-steps of one
  // step, which see the same screw speeds, do not compute the same powers again.
  std::size_t state_size() const override { return 3 * kSlots; }
  void reset_state(double* state) const override {
    std::fill(state, state + state_size(), std::numeric_limits<double>::quiet_NaN());
  }
  void drive_force(const Model& model, const Vec4& omega_rpm, double sigma_scale, double, Vec3& tau_n,
                   double* state) const override {
    Vec3 f[4];
    Vec3 mean = Vec3::Zero();
    for (int i = 0; i < 4; ++i) {
      f[i] = sigma_scale * model.SB.col(i) * omega_rpm[i];
      mean += 0.25 * f[i];
    }
    for (int i = 0; i < 4; ++i) {
      const Vec3 g = (1 - pooling_) * f[i] + pooling_ * mean;
      // The yaw torque in lateral force at this screw's lever arm (B's yaw over its lateral row).
      const double lever_m = model.SB(1, i) != 0 ? std::fabs(model.SB(2, i) / model.SB(1, i)) : 0.0;
      // Each axis's load as a share of its limit.
      const Vec3 a(g.x() / long_max_, g.y() / lat_max_, (lever_m > 0 ? g.z() / lever_m : g.y()) / lat_max_);
      Vec3 n = a.cwiseAbs();
      if (ellipse_ > 0) {
        // The soil's strength is shared by the axes (Mohr-Coulomb: a limit on the shear stress
        // vector, not on each component): each axis sees the ellipse's norm, the others weighted by
        // ellipse. One screw's yaw is its lateral force again, so y and yaw count each other only
        // as far as the forces are pooled.
        const Vec3 q = a.cwiseAbs2();
        n = Vec3(q.x() + ellipse_ * (q.y() + pooling_ * q.z()), q.y() + ellipse_ * (q.x() + pooling_ * q.z()),
                 q.z() + ellipse_ * (q.x() + pooling_ * q.y()))
                .cwiseSqrt();
      }
      double* slot = state + 9 * i;
      tau_n += Vec3(f[i].x() * (share(n.x(), slot) - 1), f[i].y() * (share(n.y(), slot + 3) - 1),
                    f[i].z() * (share(n.z(), slot + 6) - 1));
    }
  }

 private:
  // What is left of a force at n times its limit f_max, saturated towards +-f_max:
  // 1 / (1 + n^p)^(1/p). (Far below the limit 1 + n^p is 1 to the bit: the second pow is skipped.)
  double share(double n) const {
    const double s = 1.0 + std::pow(n, p_);
    return s == 1.0 ? 1.0 : 1.0 / std::pow(s, 1.0 / p_);
  }
  // share(n) again where the slot {load, sharpness, share} last saw this load and sharpness: the
  // same number to the bit, whatever model last used the workspace.
  double share(double n, double* slot) const {
    if (slot[0] == n && slot[1] == p_) return slot[2];
    slot[0] = n;
    slot[1] = p_;
    slot[2] = share(n);
    return slot[2];
  }
  static constexpr int kSlots = 12;  // 4 screws x 3 axes
  double long_max_, lat_max_, p_, pooling_, ellipse_;
};

// The drive force builds up after a dead time delay_s with a first-order lag of time constant
// tau_s: the first-order-plus-dead-time form, because a build-up with more than one stage (the
// soil has to shear before the screw's thread bites) looks like a delay followed by its slowest
// stage; one lag alone leaves the early part of every speed change wrong.
// The input S B omega is piecewise constant over the steps it is given for; the lag sees its
// mean over the step delayed by delay_s (exact for any step length; delay_s 0 is the plain lag),
// then follows it exactly as for a held input. State: [0] initialised, [1] time, [2] the newest
// stored step, [3..5] the lagged force, [6..7] the last step's length and the lag's decay over it,
// then a ring of kSlots steps (start time, force (3)).
// A run starts at the steady force of its first screw speeds, and before the first step the
// input is taken to have been that force.
class ForceLag final : public Effect {
 public:
  static constexpr int kSlots = 128;  // covers delay_s up to its bound (0.2 s) for steps >= 1.6 ms
  ForceLag(double tau_s, double delay_s, double release_ratio)
      : tau_s_(tau_s), delay_s_(delay_s), release_ratio_(release_ratio) {}
  const std::string& id() const override {
    static const std::string s = "force_lag";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override {
    return {{"tau_s", tau_s_}, {"delay_s", delay_s_}, {"release_ratio", release_ratio_}};
  }
  std::size_t state_size() const override { return kHeader + 4 * kSlots; }
  void reset_state(double* state) const override { std::fill(state, state + state_size(), 0.0); }
  void drive_force(const Model&, const Vec4&, double, double dt_s, Vec3& tau_n, double* state) const override {
    double* ring = state + kHeader;
    if (state[0] == 0) {
      state[0] = 1;
      state[1] = 0;
      state[2] = 0;
      for (int k = 0; k < 3; ++k) state[3 + k] = tau_n[k];
      for (int j = 0; j < kSlots; ++j) {
        ring[4 * j] = -1e300;  // "since ever"
        for (int k = 0; k < 3; ++k) ring[4 * j + 1 + k] = tau_n[k];
      }
    }
    const double now_s = state[1];
    const Vec3 input = delay_s_ > 0 && dt_s > 0 ? delayed_mean(state, ring, tau_n, now_s, dt_s) : tau_n;
    // Store this step's input, then advance the lag over it.
    const int head = (static_cast<int>(state[2]) + 1) % kSlots;
    state[2] = head;
    ring[4 * head] = now_s;
    for (int k = 0; k < 3; ++k) ring[4 * head + 1 + k] = tau_n[k];
    state[1] = now_s + dt_s;
    // The lag's decay over the step, computed again only when the step's length changes (a
    // state of zeros has seen none).
    if (!(dt_s > 0 && dt_s == state[6])) {
      state[6] = dt_s;
      state[7] = tau_s_ > 0 ? std::exp(-dt_s / tau_s_) : 0.0;
      state[8] = tau_s_ * release_ratio_ > 0 ? std::exp(-dt_s / (tau_s_ * release_ratio_)) : 0.0;
    }
    for (int k = 0; k < 3; ++k) {
      // Building up (the input's magnitude above the force's) with tau_s, falling back with
      // release_ratio tau_s: soil compresses under the flights slowly and may let go at once.
      const double a = std::fabs(input[k]) > std::fabs(state[3 + k]) ? state[7] : state[8];
      state[3 + k] = a * state[3 + k] + (1.0 - a) * input[k];
      tau_n[k] = state[3 + k];
    }
  }

 private:
  // [started, now_s, ring head, 3 lagged forces, the last step's length, its decays building up
  // and falling back]
  static constexpr int kHeader = 9;

  // Mean of the input over [now - delay, now + dt - delay): stored steps, newest first, and the
  // current step (which starts at now) when the delay is shorter than the step.
  Vec3 delayed_mean(const double* state, const double* ring, const Vec3& current, double now_s, double dt_s) const {
    const double a = now_s - delay_s_, b = a + dt_s;
    Vec3 sum = Vec3::Zero();
    if (b > now_s) sum += (b - std::max(a, now_s)) * current;
    double end_s = now_s;  // end of the step looked at
    int j = static_cast<int>(state[2]);
    for (int n = 0; n < kSlots && end_s > a; ++n) {
      const double* slot = ring + 4 * j;
      // The oldest slot stands for all time before it (the ring is full or the run just began).
      const double start_s = n == kSlots - 1 ? -1e300 : slot[0];
      const double lo = std::max(a, start_s), hi = std::min(b, end_s);
      if (hi > lo) sum += (hi - lo) * Vec3(slot[1], slot[2], slot[3]);
      end_s = start_s;
      j = (j + kSlots - 1) % kSlots;
    }
    return sum / dt_s;
  }

  double tau_s_, delay_s_, release_ratio_;
};

// "a screw turning slower than 2 rpm forward and 1 rpm backward pushes with no force; above it its
// force ramps back to the nominal at 4 rpm forward and 2 rpm backward: screw dead band"
std::string describe_dead_band(double omega_dead_rpm, double shift, double asymmetry) {
  const double fwd = omega_dead_rpm * (1 + asymmetry), back = omega_dead_rpm * (1 - asymmetry);
  const bool sym = std::fabs(asymmetry) < 0.02;  // within 4 %: one width
  auto both = [&](double f, double b) { return sym ? fmt(f) + " rpm" : fmt(f) + " rpm forward and " + fmt(b) + " rpm backward"; };
  std::string s = "a screw turning slower than " + both(fwd, back) + " pushes with no force";
  if (shift >= 0.995) s += " (above, as if it turned that much slower)";
  else if (shift <= 0.005) s += " (above, with its full speed)";
  else s += "; above, its force ramps back to the nominal at " + both(fwd / (1 - shift), back / (1 - shift));
  return s + ": screw dead band";
}

}  // namespace

void register_drive(EffectRegistry& r) {
  auto non_negative = [](double v, const char* name) {
    if (!(v >= 0) || !std::isfinite(v)) throw std::invalid_argument(std::string(name) + " must be >= 0");
  };
  // The band's form (docs/workbench.md "`auger effects`"): its width forward and backward, and
  // whether the force above it jumps back (a gate), ramps back to the nominal line, or stays
  // shifted (a dead zone), all fitted: a dead zone fitted to a band that ramps back ends at several
  // times the noise floor (the independent generator's ramp-join and asymmetric dead bands).
  r.add({"screw_dead_band", "a screw slower than its band (omega_dead_rpm (1 +- asymmetry) forward / backward) gives no force",
         {ParamSpec{"omega_dead_rpm", 0, true, "dead band half-width (the mean of forward and backward)", "rpm", 0, 23, 1.0}.physical(0.1, 6),
          ParamSpec{"shift", 1, false,
                    "above the band the screw pushes with min(|omega|, (|omega| - band) / shift): 1 a dead zone, 0 a gate, "
                    "between a ramp joining the nominal line at band / (1 - shift)",
                    "", 0, 1, 1}.physical(0, 1).form_param(),
          ParamSpec{"asymmetry", 0, false, "the band is omega_dead_rpm (1 + asymmetry) turning forward (omega > 0), "
                    "omega_dead_rpm (1 - asymmetry) backward", "", -1, 1, 0.3}.physical(-1, 1).form_param()},
         [non_negative](const std::vector<double>& v) {
           non_negative(v[0], "omega_dead_rpm");
           if (!(v[1] >= 0 && v[1] <= 1)) throw std::invalid_argument("shift must be in [0, 1]");
           if (!(v[2] >= -1 && v[2] <= 1)) throw std::invalid_argument("asymmetry must be in [-1, 1]");
           return std::make_shared<ScrewDeadBand>(v[0], v[1], v[2]);
         },
         [](const std::vector<double>& v) { return describe_dead_band(v[0], v[1], v[2]); }});
  r.add({"screw_traction_loss", "screw `screw` (0 front-right, 1 rear-right, 2 rear-left, 3 front-left) "
                                "transmits only (1 - loss) of its force",
         {ParamSpec{"screw", 0, true, "screw index (docs/model-notes.md table)", "", 0, 3, 1, true}.physical(0, 3),
          ParamSpec{"loss", 0, true, "lost fraction of its force", "", 0, 1, 0.2}.physical(0.05, 1)},
         [](const std::vector<double>& v) {
           if (!(v[0] == 0 || v[0] == 1 || v[0] == 2 || v[0] == 3))
             throw std::invalid_argument("screw must be 0, 1, 2 or 3");
           if (!(v[1] >= 0 && v[1] <= 1)) throw std::invalid_argument("loss must be in [0, 1]");
           return std::make_shared<ScrewTractionLoss>(static_cast<int>(v[0]), v[1]);
         },
         [](const std::vector<double>& v) {
           static const char* names[4] = {"front-right", "rear-right", "rear-left", "front-left"};
           const int i = std::clamp(static_cast<int>(v[0]), 0, 3);
           return "screw " + std::to_string(i) + " (" + names[i] + ") transmits only " + fmt(100 * (1 - v[1])) +
                  " % of its force: loss of traction of one screw";
         }});
  r.add({"traction_saturation", "each screw's longitudinal / lateral force saturates smoothly towards +-force_max",
         {ParamSpec{"force_max_long_n", 1e6, false, "per-screw longitudinal limit", "N", 0.05, 1e6, 8, false, true, true}.physical(2, 100),
          ParamSpec{"force_max_lat_n", 1e6, false, "per-screw lateral limit", "N", 0.05, 1e6, 2.5, false, true, true}.physical(0.5, 50),
          ParamSpec{"sharpness", 4, false, "p of f / (1 + |f / f_max|^p)^(1/p): 2 gradual, 20 a clip", "", 1, 30, 4, false, true, true}.physical(1, 30),
          ParamSpec{"pooling", 0, false, "what saturates: 0 each screw's own force, 1 the footprint's total (4 f_max)", "", 0, 1, 1}
              .physical(0, 1)
              .form_param(),
          ParamSpec{"ellipse", 0, false,
                    "how the axes share the soil's strength: 0 each its own limit, 1 one limit on the force's norm", "",
                    0, 1, 1}
              .physical(0, 1)
              .form_param()},
         [](const std::vector<double>& v) {
           if (!(v[0] > 0 && v[1] > 0)) throw std::invalid_argument("force limits must be > 0");
           if (!(v[2] >= 1 && v[2] <= 100)) throw std::invalid_argument("sharpness must be in [1, 100]");
           if (!(v[3] >= 0 && v[3] <= 1)) throw std::invalid_argument("pooling must be in [0, 1]");
           if (!(v[4] >= 0 && v[4] <= 1)) throw std::invalid_argument("ellipse must be in [0, 1]");
           return std::make_shared<TractionSaturation>(v[0], v[1], v[2], v[3], v[4]);
         },
         [](const std::vector<double>& v) {
           const std::string shared =
               v[4] > 0 ? ", the axes sharing one limit (friction ellipse " + fmt(v[4]) + ")" : std::string();
           if (v[3] >= 0.5)
             return "the robot's total thrust saturates at " + fmt(4 * v[0]) + " N along and " + fmt(4 * v[1]) +
                    " N across (four screws' " + fmt(v[0]) + " and " + fmt(v[1]) + " N; pooling " + fmt(v[3]) + ")" +
                    shared + ": saturation of the traction force under the whole footprint";
           return "each screw's thrust saturates at " + fmt(v[0]) + " N along and " + fmt(v[1]) + " N across the robot" +
                  (v[3] > 0 ? " (pooling " + fmt(v[3]) + ")" : std::string()) + shared +
                  ": saturation of the traction force";
         }});
  r.add({"force_lag", "the drive force follows S B omega after a dead time delay_s with a first-order lag tau_s",
         {ParamSpec{"tau_s", 0, true, "time constant", "s", 0, 3, 0.1}.physical(0.005, 1.0),
          ParamSpec{"delay_s", 0, false, "dead time before the force starts to build up", "s", 0, 0.2, 0.03}.physical(0, 0.2),
          // A form parameter: 1 is the same lag both ways.
          ParamSpec{"release_ratio", 1, false,
                    "the lag's time constant while the force falls back, as a multiple of tau_s (below 1: soil "
                    "that lets go faster than it compresses)",
                    "", 0.05, 4, 0.3}
              .physical(0.1, 2)
              .form_param()},
         [non_negative](const std::vector<double>& v) {
           non_negative(v[0], "tau_s");
           if (!(v[1] >= 0 && v[1] <= 0.2)) throw std::invalid_argument("delay_s must be in [0, 0.2]");
           if (!(v[2] > 0) || !std::isfinite(v[2])) throw std::invalid_argument("release_ratio must be > 0");
           return std::make_shared<ForceLag>(v[0], v[1], v[2]);
         },
         [](const std::vector<double>& v) {
           const bool same = std::fabs(v[2] - 1) < 0.02;
           return "the screws' force builds up with a time constant of " + fmt(v[0]) + " s" +
                  (same ? std::string() : " and falls back with " + fmt(v[0] * v[2]) + " s") +
                  (v[1] > 0 ? " after a dead time of " + fmt(v[1]) + " s" : std::string()) +
                  ": lag of force build-up";
         }});
}

}  // namespace effects
}  // namespace auger
