// Drive effects: changes of how the screw speeds become the body force, eq. (7).
#include <algorithm>
#include <cmath>

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
  void drive_force(const Model& model, const Vec4& omega_rpm, double, Vec3& tau_n, double*) const override {
    tau_n -= loss_ * model.SB.col(screw_) * omega_rpm[screw_];  // eq. (7), column of screw i
  }

 private:
  int screw_;
  double loss_;
};

// The traction force saturates per screw: each screw's longitudinal and lateral force of eq. (7)
// (sigma_long B_x,i omega_i, sigma_lat B_y,i omega_i) saturates towards +-force_max,
// f / (1 + |f / force_max|^p)^(1/p), as when the soil under a screw shears before it reaches its
// nominal thrust; the sharpness p runs from gradual (2) to a clip (large p). The yaw share of a
// screw (the lumped row of B) scales with its lateral force.
class TractionSaturation final : public Effect {
 public:
  TractionSaturation(double long_max, double lat_max, double p) : long_max_(long_max), lat_max_(lat_max), p_(p) {}
  const std::string& id() const override {
    static const std::string s = "traction_saturation";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override {
    return {{"force_max_long_n", long_max_}, {"force_max_lat_n", lat_max_}, {"sharpness", p_}};
  }
  void drive_force(const Model& model, const Vec4& omega_rpm, double, Vec3& tau_n, double*) const override {
    for (int i = 0; i < 4; ++i) {
      const Vec3 f = model.SB.col(i) * omega_rpm[i];
      const double fx = f.x() / std::pow(1.0 + std::pow(std::fabs(f.x() / long_max_), p_), 1.0 / p_);
      const double fy = f.y() / std::pow(1.0 + std::pow(std::fabs(f.y() / lat_max_), p_), 1.0 / p_);
      const double share = f.y() != 0 ? fy / f.y() : 1.0;
      tau_n -= f;
      tau_n += Vec3(fx, fy, f.z() * share);
    }
  }

 private:
  double long_max_, lat_max_, p_;
};

// The drive force builds up with a first-order lag of time constant tau_s (exact for a held
// input over a step). State: the lagged force (3) and whether it has been initialised (1):
// a run starts at the steady force of its first screw speeds.
class ForceLag final : public Effect {
 public:
  explicit ForceLag(double tau_s) : tau_s_(tau_s) {}
  const std::string& id() const override {
    static const std::string s = "force_lag";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override { return {{"tau_s", tau_s_}}; }
  std::size_t state_size() const override { return 4; }
  void reset_state(double* state) const override { std::fill(state, state + 4, 0.0); }
  void drive_force(const Model&, const Vec4&, double dt_s, Vec3& tau_n, double* state) const override {
    if (state[3] == 0) {
      for (int k = 0; k < 3; ++k) state[k] = tau_n[k];
      state[3] = 1;
      return;
    }
    const double a = tau_s_ > 0 ? std::exp(-dt_s / tau_s_) : 0.0;
    for (int k = 0; k < 3; ++k) {
      state[k] = a * state[k] + (1.0 - a) * tau_n[k];
      tau_n[k] = state[k];
    }
  }

 private:
  double tau_s_;
};

}  // namespace

void register_drive(EffectRegistry& r) {
  auto non_negative = [](double v, const char* name) {
    if (!(v >= 0) || !std::isfinite(v)) throw std::invalid_argument(std::string(name) + " must be >= 0");
  };
  r.add({"screw_dead_band", "a screw slower than omega_dead_rpm gives no force",
         {{"omega_dead_rpm", 0, true, "dead band half-width", "rpm", 0, 23, 1.0},
          {"shift", 1, false, "1: a dead zone (force of |omega| - omega_dead_rpm), 0: full force above it", "", 0, 1, 1,
           false, false}},
         [non_negative](const std::vector<double>& v) {
           non_negative(v[0], "omega_dead_rpm");
           if (!(v[1] == 0 || v[1] == 1)) throw std::invalid_argument("shift must be 0 or 1");
           return std::make_shared<ScrewDeadBand>(v[0], v[1] == 1);
         },
         [](const std::vector<double>& v) {
           return "a screw turning slower than " + fmt(v[0]) + " rpm pushes with no force: screw dead band";
         }});
  r.add({"screw_traction_loss", "screw `screw` (0 front-right, 1 rear-right, 2 rear-left, 3 front-left) "
                                "transmits only (1 - loss) of its force",
         {{"screw", 0, true, "screw index (MODEL-NOTES table)", "", 0, 3, 1, true},
          {"loss", 0, true, "lost fraction of its force", "", 0, 1, 0.2}},
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
         {{"force_max_long_n", 1e6, false, "per-screw longitudinal limit", "N", 0.05, 1e6, 8, false, true, true},
          {"force_max_lat_n", 1e6, false, "per-screw lateral limit", "N", 0.05, 1e6, 2.5, false, true, true},
          {"sharpness", 4, false, "p of f / (1 + |f / f_max|^p)^(1/p): 2 gradual, 20 a clip", "", 1, 30, 4, false, true, true}},
         [](const std::vector<double>& v) {
           if (!(v[0] > 0 && v[1] > 0)) throw std::invalid_argument("force limits must be > 0");
           if (!(v[2] >= 1 && v[2] <= 100)) throw std::invalid_argument("sharpness must be in [1, 100]");
           return std::make_shared<TractionSaturation>(v[0], v[1], v[2]);
         },
         [](const std::vector<double>& v) {
           return "each screw's thrust saturates at " + fmt(v[0]) + " N along and " + fmt(v[1]) +
                  " N across the robot: saturation of the traction force";
         }});
  r.add({"force_lag", "the drive force follows S B omega with a first-order lag tau_s",
         {{"tau_s", 0, true, "time constant", "s", 0, 3, 0.1}},
         [non_negative](const std::vector<double>& v) {
           non_negative(v[0], "tau_s");
           return std::make_shared<ForceLag>(v[0]);
         },
         [](const std::vector<double>& v) {
           return "the screws' force builds up with a time constant of " + fmt(v[0]) + " s: lag of force build-up";
         }});
}

}  // namespace effects
}  // namespace auger
