// Friction effects: hard-sign dry friction (Coulomb, and stick-slip with a higher breakaway
// level) and quadratic drag, all as body forces of eq. (6) applied implicitly over a step
// (EffectContext: zeta_end = zeta_free + gain .* force), so they stop at zero, never chatter.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "effects.hpp"

namespace auger {
namespace effects {

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

namespace {

const char* kDofWords[3] = {"along x", "along y", "in yaw"};

void check_non_negative(double v, const char* name) {
  if (!(v >= 0) || !std::isfinite(v)) throw std::invalid_argument(std::string(name) + " must be >= 0");
}

// The three levels of a dry friction (force_x_n, force_y_n, torque_psi_nm).
void check_levels(const std::vector<double>& v) {
  check_non_negative(v[0], "force_x_n");
  check_non_negative(v[1], "force_y_n");
  check_non_negative(v[2], "torque_psi_nm");
}

std::string dry_words(const std::vector<double>& v, const std::string& what) {
  std::string s;
  for (int k = 0; k < 3; ++k) {
    if (!(v[static_cast<std::size_t>(k)] > 0)) continue;
    if (!s.empty()) s += ", ";
    s += "a constant " + std::string(k == 2 ? "torque of " : "force of ") + fmt(v[static_cast<std::size_t>(k)]) +
         (k == 2 ? " N m" : " N") + " opposing motion " + kDofWords[k];
  }
  return (s.empty() ? std::string("no force") : s) + ": " + what;
}

// Stick-slip (Stribeck): the friction level is the sliding level times
// 1 + (breakaway_ratio - 1) exp(-|v| / stribeck_mps), so the body needs breakaway_ratio times the
// sliding force to start and the resistance falls as it speeds up. The level is taken at the
// step's start velocity, the force applied implicitly as for Coulomb friction (it stops at zero).
// stribeck_mps is a sliding speed at the contacts: in yaw the screws' contacts slide at
// r hypot(l_x, l_y) (eq. (1)'s mounts), so the yaw decay rate is stribeck_mps / hypot(l_x, l_y),
// not the same number read as rad/s (which would make the yaw breakaway 3x too short-lived).
class StickSlipFriction final : public Effect {
 public:
  StickSlipFriction(const Vec3& kinetic, double breakaway, double stribeck_mps)
      : kinetic_(kinetic), breakaway_(breakaway), v_s_(stribeck_mps) {}
  const std::string& id() const override {
    static const std::string s = "stick_slip_friction";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override {
    return {{"force_x_n", kinetic_.x()}, {"force_y_n", kinetic_.y()}, {"torque_psi_nm", kinetic_.z()},
            {"breakaway_ratio", breakaway_}, {"stribeck_mps", v_s_}};
  }
  void body_force(const Model& m, const EffectContext& ctx, Vec3& force_n, double*) const override {
    for (int k = 0; k < 3; ++k) {
      const double stop = -ctx.zeta_free[k] / ctx.gain[k];
      const double slide_mps = std::fabs(ctx.zeta[k]) * contact_speed_per_unit(m, k);
      const double level = kinetic_[k] * (1.0 + (breakaway_ - 1.0) * std::exp(-slide_mps / v_s_));
      force_n[k] = std::clamp(stop, -level, level);
    }
  }

 private:
  Vec3 kinetic_;
  double breakaway_, v_s_;
};

// Quadratic drag per DOF, -c_k v_k m_k with m_k = (1 - isotropy) |v_k| + isotropy |V| along x and y
// (V = (u, v): the speed over ground) and m = |r| in yaw. isotropy 0 is a resistance per axis,
// -c v |v|; 1 is one that opposes the planar velocity as a whole, -c |V| V, as soil pushed aside
// by a body moving through it resists (on a diagonal it is sqrt(2) times the per-axis form's).
// Solved implicitly at the step's end velocity with |V| taken at the step's start: with
// v = v_free + g f, g c (1 - a) v^2 + (1 + g c a S) v - v_free = 0 for v of v_free's sign.
class QuadraticDrag final : public Effect {
 public:
  QuadraticDrag(const Vec3& c, double isotropy) : c_(c), isotropy_(isotropy) {}
  const std::string& id() const override {
    static const std::string s = "quadratic_drag";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override {
    return {{"c_x_nspm2", c_.x()}, {"c_y_nspm2", c_.y()}, {"c_psi_nmspr2", c_.z()}, {"isotropy", isotropy_}};
  }
  void body_force(const Model& model, const EffectContext& ctx, Vec3& force_n, double*) const override {
    const double speed_mps = std::hypot(ctx.zeta.x(), ctx.zeta.y());
    for (int k = 0; k < 3; ++k) {
      // The coefficient as the model holds it (augerd's applied online estimate, else the file's).
      const double c = effect_param(model, this, static_cast<std::size_t>(k), c_[k]);
      const double a = share(k);
      const double vf = ctx.zeta_free[k], gc = ctx.gain[k] * c;
      if (gc <= 0 || vf == 0) {
        force_n[k] = 0;
        continue;
      }
      // The root of the quadratic in its cancellation-free form (exact also where (1 - a) is 0).
      const double lin = 1.0 + gc * a * speed_mps, quad = gc * (1 - a);
      const double v = 2.0 * vf / (lin + std::sqrt(lin * lin + 4.0 * quad * std::fabs(vf)));
      force_n[k] = (v - vf) / ctx.gain[k];
    }
  }
  // Online: c_k times -v_k m_k at the state (the explicit form; the step's implicit solution above
  // differs from it by the velocity change within one step).
  Vec3 online_basis(const Model&, std::size_t index, const Vec3&, const Vec3& zeta) const override {
    Vec3 b = Vec3::Zero();
    b[static_cast<int>(index)] = -zeta[static_cast<int>(index)] * magnitude(zeta, static_cast<int>(index));
    return b;
  }
  // The same explicit form, with the coefficients the model holds: smooth through zero (no sign
  // switch), so it can be anticipated.
  bool feedforward_force(const Model& model, const Vec3&, const Vec3& zeta, Vec3& force_n) const override {
    for (int k = 0; k < 3; ++k)
      force_n[k] = -effect_param(model, this, static_cast<std::size_t>(k), c_[k]) * zeta[k] * magnitude(zeta, k);
    return true;
  }

 private:
  // The share of DOF k's resistance that grows with the speed over ground (none in yaw).
  double share(int k) const { return k < 2 ? isotropy_ : 0.0; }
  double magnitude(const Vec3& zeta, int k) const {
    const double a = share(k);
    return a > 0 ? (1 - a) * std::fabs(zeta[k]) + a * std::hypot(zeta.x(), zeta.y()) : std::fabs(zeta[k]);
  }
  Vec3 c_;
  double isotropy_;
};

}  // namespace

void register_friction(EffectRegistry& r) {
  // smooth_mps's physical range: granular soil reaches its sliding resistance within a slip of a
  // centimetre or two per second; beyond that a tanh is the paper's linear D (eq. (6)) in another
  // name (a level over a speed).
  r.add({"coulomb_friction", "dry friction per DOF, hard sign form (stiction = sliding level), or tanh(v / smooth_mps)",
         {ParamSpec{"force_x_n", 0, false, "longitudinal level", "N", 0, 500, 10}.physical(0, 60),
          ParamSpec{"force_y_n", 0, false, "lateral level", "N", 0, 500, 10}.physical(0, 30),
          ParamSpec{"torque_psi_nm", 0, false, "yaw level", "N m", 0, 50, 0.5}.physical(0, 1.5),
          ParamSpec{"smooth_mps", 0, false,
                    "sliding speed over which the level is reached, level tanh(v / smooth_mps) (in yaw at the "
                    "contacts, r hypot(l_x, l_y)); 0: hard sign, sticking below the level",
                    "m/s", 0, 0.03, 0.005}
              .physical(0, 0.02)
              .form_param()},
         [](const std::vector<double>& v) {
           check_levels(v);
           check_non_negative(v[3], "smooth_mps");
           return std::make_shared<CoulombFriction>(Vec3(v[0], v[1], v[2]), v[3]);
         },
         [](const std::vector<double>& v) {
           return dry_words(v, v[3] > 0 ? "dry (Coulomb) friction, reached over a sliding speed of " +
                                              fmt(v[3] * 1000) + " mm/s (tanh)"
                                        : "dry (Coulomb) friction");
         }});
  r.add({"stick_slip_friction",
         "dry friction per DOF with a Stribeck breakaway: breakaway_ratio times the sliding level at rest",
         {ParamSpec{"force_x_n", 0, false, "sliding level, longitudinal", "N", 0, 500, 10}.physical(0, 60),
          ParamSpec{"force_y_n", 0, false, "sliding level, lateral", "N", 0, 500, 10}.physical(0, 30),
          ParamSpec{"torque_psi_nm", 0, false, "sliding level, yaw", "N m", 0, 50, 0.5}.physical(0, 1.5),
          ParamSpec{"breakaway_ratio", 1.5, false, "breakaway (static) / sliding level", "", 1, 5, 1.3}.physical(1, 5),
          ParamSpec{"stribeck_mps", 0.005, false, "sliding speed over which the breakaway excess decays (m/s; in yaw at the contacts, r hypot(l_x, l_y))", "m/s",
           1e-4, 0.2, 0.005, false, true, true}.physical(1e-4, 0.05)},
         [](const std::vector<double>& v) {
           check_levels(v);
           if (!(v[3] >= 1) || !std::isfinite(v[3])) throw std::invalid_argument("breakaway_ratio must be >= 1");
           if (!(v[4] > 0) || !std::isfinite(v[4])) throw std::invalid_argument("stribeck_mps must be > 0");
           return std::make_shared<StickSlipFriction>(Vec3(v[0], v[1], v[2]), v[3], v[4]);
         },
         [](const std::vector<double>& v) {
           return dry_words(v, "stick-slip friction, breaking away at " + fmt(v[3]) + " times that, decaying over " +
                                   fmt(v[4] * 1000) + " mm/s");
         }});
  // Physical ranges: about twice the largest linear drag of the paper's terrains (eq. (6)'s D) at
  // the robot's cruising speeds, 0.1 m/s and 0.15 rad/s (soil pushed aside faster than it flows
  // back can dominate near top speed; at 5000 N/(m/s)^2, once the bound, drags of 1.2-1.5 times
  // the linear one at 0.1 m/s were fitted at the bound and flagged).
  r.add({"quadratic_drag", "a resistance -c v |v| per DOF, or along x and y with the speed over ground (isotropy), on top of the linear D of eq. (6)",
         {ParamSpec{"c_x_nspm2", 0, false, "longitudinal coefficient", "N/(m/s)^2", 0, 1e5, 500}.physical(0, 12000).estimable_online(),
          ParamSpec{"c_y_nspm2", 0, false, "lateral coefficient", "N/(m/s)^2", 0, 1e5, 500}.physical(0, 12000).estimable_online(),
          ParamSpec{"c_psi_nmspr2", 0, false, "yaw coefficient", "N m/(rad/s)^2", 0, 1e4, 10}.physical(0, 150).estimable_online(),
          ParamSpec{"isotropy", 0, false,
                    "what the x and y resistance grows with: 0 each axis's own speed (-c v |v|), 1 the speed over ground "
                    "(-c v |V|)",
                    "", 0, 1, 1}
              .physical(0, 1)
              .form_param()},
         [](const std::vector<double>& v) {
           check_non_negative(v[0], "c_x_nspm2");
           check_non_negative(v[1], "c_y_nspm2");
           check_non_negative(v[2], "c_psi_nmspr2");
           if (!(v[3] >= 0 && v[3] <= 1)) throw std::invalid_argument("isotropy must be in [0, 1]");
           return std::make_shared<QuadraticDrag>(Vec3(v[0], v[1], v[2]), v[3]);
         },
         [](const std::vector<double>& v) {
           std::string s = "quadratic drag: a resistance growing with the square of the speed (" + fmt(v[0]) +
                           " N at 1 m/s along x, " + fmt(v[1]) + " N at 1 m/s along y, " + fmt(v[2]) +
                           " N m at 1 rad/s in yaw)";
           if (v[3] >= 0.995) s += ", along x and y with the speed over ground";
           else if (v[3] > 0.005) s += ", along x and y " + fmt(v[3] * 100) + " % with the speed over ground";
           return s;
         }});
}

}  // namespace effects
}  // namespace auger
