// Terrain effects: a slope (gravity in the world frame), an offset centre of resistance, and a
// change of terrain at some time. Body forces of eq. (6).
#include <algorithm>
#include <cmath>

#include "effects.hpp"

namespace auger {
namespace effects {
namespace {

constexpr double kG = 9.81;

// A plane inclined by incline_x_rad along world x and incline_y_rad along world y (rising
// towards +x, +y): gravity pulls -m g sin(incline) along each world axis, rotated into the body
// frame with J(psi)^T (eq. (9)), so the force depends on the heading.
class TerrainSlope final : public Effect {
 public:
  TerrainSlope(double ix, double iy) : ix_(ix), iy_(iy) {}
  const std::string& id() const override {
    static const std::string s = "terrain_slope";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override {
    return {{"incline_x_rad", ix_}, {"incline_y_rad", iy_}};
  }
  void body_force(const Model& model, const EffectContext& ctx, Vec3& force_n, double*) const override {
    feedforward_force(model, ctx.eta, ctx.zeta, force_n);
  }
  // Gravity depends on the heading alone: the safest force to feed forward (no velocity in it).
  bool feedforward_force(const Model& model, const Vec3& eta, const Vec3&, Vec3& force_n) const override {
    // The inclines as the model holds them (augerd's applied online estimate, else the file's).
    const double ix = effect_param(model, this, 0, ix_), iy = effect_param(model, this, 1, iy_);
    const double fx = -model.robot.m_kg * kG * std::sin(ix), fy = -model.robot.m_kg * kG * std::sin(iy);
    const double c = std::cos(eta.z()), s = std::sin(eta.z());
    force_n << c * fx + s * fy, -s * fx + c * fy, 0.0;  // J(psi)^T f_world
    return true;
  }
  // Online: the force is sin(incline) times the full weight along the world axis, turned into the
  // body frame; the shape sin is exact at every incline (no small-angle approximation).
  Vec3 online_basis(const Model& model, std::size_t index, const Vec3& eta, const Vec3&) const override {
    const double w = -model.robot.m_kg * kG, c = std::cos(eta.z()), s = std::sin(eta.z());
    return index == 0 ? Vec3(c * w, -s * w, 0.0) : Vec3(s * w, c * w, 0.0);
  }
  double online_shape(std::size_t, double value, double* derivative) const override {
    *derivative = std::cos(value);
    return std::sin(value);
  }

 private:
  double ix_, iy_;
};

// The resistance -D zeta of eq. (6) acts at (offset_x_m, offset_y_m) from the centre instead of
// at it: sideways resistance then turns the robot, torque = x_c (-D_y v) - y_c (-D_x u), in the
// lumped yaw units.
class ResistanceOffset final : public Effect {
 public:
  ResistanceOffset(double ox, double oy) : ox_(ox), oy_(oy) {}
  const std::string& id() const override {
    static const std::string s = "resistance_offset";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override {
    return {{"offset_x_m", ox_}, {"offset_y_m", oy_}};
  }
  void body_force(const Model& model, const EffectContext& ctx, Vec3& force_n, double*) const override {
    // The resistance point moves with (u - r y_c, v + r x_c) (rigid body); the difference to the
    // centre's resistance is the extra force, and its moment about the centre the extra torque.
    const double u = ctx.zeta_free.x(), v = ctx.zeta_free.y(), r = ctx.zeta_free.z();
    // The moment is a real one: it enters eq. (8)'s lumped yaw row scaled as the screws' moments
    // are (yaw_lumping, about 1/17). Unscaled, fitted offsets came out 13-17 times too small.
    const double fx = -model.D_diag.x() * (u - r * oy_), fy = -model.D_diag.y() * (v + r * ox_);
    force_n << fx + model.D_diag.x() * u, fy + model.D_diag.y() * v, yaw_lumping(model) * (ox_ * fy - oy_ * fx);
  }

 private:
  double ox_, oy_;
};

// From t_change_s on, the terrain's traction is sigma_factor times and its resistance
// drag_factor times the model's (eqs. (6)-(7)): S of eq. (7) scaled by sigma_factor before the
// drive effects act (a screw's force limit or dead band is the screw's, not the ground's), and
// the extra damping (drag_factor - 1) D, implicit over the step.
class TerrainChange final : public Effect {
 public:
  TerrainChange(double t, double ks, double kd) : t_(t), ks_(ks), kd_(kd) {}
  const std::string& id() const override {
    static const std::string s = "terrain_change";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override {
    return {{"t_change_s", t_}, {"sigma_factor", ks_}, {"drag_factor", kd_}};
  }
  double traction_scale(double t_s) const override { return t_s < t_ ? 1.0 : ks_; }
  void body_force(const Model& model, const EffectContext& ctx, Vec3& force_n, double*) const override {
    if (ctx.t_s < t_) {
      force_n.setZero();
      return;
    }
    for (int k = 0; k < 3; ++k) {
      const double d_extra = (kd_ - 1.0) * model.D_diag[k];
      // f = -d_extra v_end, v_end = v_free + g f  =>  f = -d_extra v_free / (1 + d_extra g)
      force_n[k] = -d_extra * ctx.zeta_free[k] / (1.0 + d_extra * ctx.gain[k]);
    }
  }

 private:
  double t_, ks_, kd_;
};

}  // namespace

void register_terrain(EffectRegistry& r) {
  r.add({"terrain_slope", "a plane inclined along world x and y: gravity in the world frame",
         {ParamSpec{"incline_x_rad", 0, false, "rise towards world +x", "rad", -0.6, 0.6, 0.02}.physical(-0.35, 0.35).estimable_online(),
          ParamSpec{"incline_y_rad", 0, false, "rise towards world +y", "rad", -0.6, 0.6, 0.02}.physical(-0.35, 0.35).estimable_online()},
         [](const std::vector<double>& v) {
           if (!(std::fabs(v[0]) < 1.5 && std::fabs(v[1]) < 1.5)) throw std::invalid_argument("inclines must be in (-1.5, 1.5) rad");
           return std::make_shared<TerrainSlope>(v[0], v[1]);
         },
         [](const std::vector<double>& v) {
           const double deg = std::atan(std::hypot(std::tan(v[0]), std::tan(v[1]))) * 180.0 / kPi;
           const double dir = std::atan2(-std::tan(v[1]), -std::tan(v[0])) * 180.0 / kPi;
           return "a slope of " + fmt(deg) + " deg, downhill towards " + fmt(dir) +
                  " deg in the world frame (gravity pulls " + fmt(29.0 * kG * std::sin(deg * kPi / 180)) +
                  " N on the 29 kg robot): terrain slope";
         }});
  r.add({"resistance_offset", "the resistance -D zeta acts at (offset_x_m, offset_y_m) from the centre",
         {ParamSpec{"offset_x_m", 0, false, "ahead of the centre", "m", -1, 1, 0.05}.physical(-0.2, 0.2),
          ParamSpec{"offset_y_m", 0, false, "left of the centre", "m", -1, 1, 0.05}.physical(-0.35, 0.35)},
         [](const std::vector<double>& v) {
           if (!(std::isfinite(v[0]) && std::isfinite(v[1]))) throw std::invalid_argument("offsets must be finite");
           return std::make_shared<ResistanceOffset>(v[0], v[1]);
         },
         [](const std::vector<double>& v) {
           return "the centre of resistance sits " + fmt(v[0]) + " m ahead of and " + fmt(v[1]) +
                  " m left of the centre, so sideways motion turns the robot: offset of the centre of resistance";
         }});
  r.add({"terrain_change", "from t_change_s on, traction times sigma_factor and resistance times drag_factor",
         {ParamSpec{"t_change_s", 0, true, "time of the change (log time)", "s", 0, 1e9, 10, false, false}.physical(0, 1e9),
          ParamSpec{"sigma_factor", 1, false, "traction after / before", "", 0.05, 20, 0.2}.physical(0.2, 5),
          ParamSpec{"drag_factor", 1, false, "resistance after / before", "", 0.05, 20, 0.2}.physical(0.2, 5)},
         [](const std::vector<double>& v) {
           if (!(v[1] > 0 && v[2] > 0)) throw std::invalid_argument("factors must be > 0");
           return std::make_shared<TerrainChange>(v[0], v[1], v[2]);
         },
         [](const std::vector<double>& v) {
           return "at t = " + fmt(v[0]) + " s the terrain changes: traction " + fmt(v[1]) + " times,"
                  " resistance " + fmt(v[2]) + " times the model's: change of terrain";
         }});
}

}  // namespace effects
}  // namespace auger
