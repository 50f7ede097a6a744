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

// The traction force saturates: each body-force component of eq. (7) is limited (hard clamp),
// as when the soil shears before the screws reach their nominal thrust.
class TractionSaturation final : public Effect {
 public:
  explicit TractionSaturation(const Vec3& limit) : limit_(limit) {}
  const std::string& id() const override {
    static const std::string s = "traction_saturation";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override {
    return {{"force_max_x_n", limit_.x()}, {"force_max_y_n", limit_.y()}, {"torque_max_psi_nm", limit_.z()}};
  }
  void drive_force(const Model&, const Vec4&, double, Vec3& tau_n, double*) const override {
    for (int k = 0; k < 3; ++k) tau_n[k] = std::clamp(tau_n[k], -limit_[k], limit_[k]);
  }

 private:
  Vec3 limit_;
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
         {{"omega_dead_rpm", 0, true, "dead band half-width", "rpm", 0, 23, 1.0}},
         [non_negative](const std::vector<double>& v) {
           non_negative(v[0], "omega_dead_rpm");
           return std::make_shared<ScrewDeadBand>(v[0]);
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
  r.add({"traction_saturation", "each component of the drive force S B omega is limited to +-force_max",
         {{"force_max_x_n", 1e6, false, "longitudinal limit", "N", 0.1, 1e6, 20, false, true, true},
          {"force_max_y_n", 1e6, false, "lateral limit", "N", 0.1, 1e6, 10, false, true, true},
          {"torque_max_psi_nm", 1e6, false, "yaw limit", "N m", 0.01, 1e6, 0.5, false, true, true}},
         [](const std::vector<double>& v) {
           for (int k = 0; k < 3; ++k)
             if (!(v[static_cast<std::size_t>(k)] > 0)) throw std::invalid_argument("force limits must be > 0");
           return std::make_shared<TractionSaturation>(Vec3(v[0], v[1], v[2]));
         },
         [](const std::vector<double>& v) {
           std::string s = "the screws' thrust saturates at";
           const char* what[3] = {" N along x", " N along y", " N m in yaw"};
           bool any = false;
           for (int k = 0; k < 3; ++k)
             if (v[static_cast<std::size_t>(k)] < 1e5) {
               s += std::string(any ? "," : "") + " " + fmt(v[static_cast<std::size_t>(k)]) + what[k];
               any = true;
             }
           return (any ? s : std::string("no limit reached")) + ": saturation of the traction force";
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
