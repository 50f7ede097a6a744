// The simulated "true" robot (docs/robot-sim.md): a rigid body in the plane whose screws each
// push at their own contact point, on one terrain, with switchable physics the paper's linear
// model lacks. Deliberately NOT the host model (docs/design.md "Hidden-effect honesty"): per-contact
// drag plus a residual yaw drag instead of a lumped D, the real lever arms instead of the
// empirical yaw row of B, Coriolis terms, smooth (tanh / Stribeck) dry friction, a second-order
// force lag, a 3-D incline. Calibrated so that without extra effects its steady u, v, r equal
// the nominal model's (docs/model-notes.md "Dynamic model").
#pragma once

#include <array>
#include <cmath>
#include <memory>

#include <Eigen/Core>

#include "auger/model.hpp"
#include "field.hpp"

namespace auger::sim {

constexpr double kGravity_mps2 = 9.81;

// Each extra effect: `on` switches it, the rest are its parameters (SI, screw speeds in rpm).
struct DryFriction {  // body-level, smooth Stribeck curve times tanh (not a hard sign)
  bool on = false;
  double coulomb_n = 8.0, stiction_n = 12.0, stribeck_mps = 0.01, eps_mps = 0.0003;
  // per_axis: x and y each get their own curve (levels coulomb_n / stiction_n along x, those
  // times y_ratio along y) instead of one curve on the planar speed |(u, v)|.
  bool per_axis = false;
  double y_ratio = 1.0;
  double coulomb_nm = 1.0, stiction_nm = 1.5, stribeck_radps = 0.03, eps_radps = 0.002;
};
struct Incline {  // the ground is a plane tilted by roll (about world x) then pitch (about world y)
  bool on = false;
  double roll_rad = 0.0, pitch_rad = 0.0;
};
struct TractionLoss {  // screw `screw` keeps only `factor` of its traction from t_on_s on
  bool on = false;
  int screw = 0;
  double factor = 0.3, t_on_s = 0.0;
};
struct TractionSaturation {  // smooth, per screw and axis: f = f_max tanh(f_linear / f_max), or
  bool on = false;           // with sharpness n > 0 f = f_lin / (1 + |f_lin / f_max|^n)^(1/n)
  double long_max_n = 14.0, lat_max_n = 4.0;
  double sharpness = 0.0;    // 0: tanh; larger n bends closer to a hard limit (still smooth)
};
// Smooth saturation of one force component (TractionSaturation's forms).
inline double saturate_force(double f_n, double f_max_n, double sharpness) {
  if (sharpness <= 0) return f_max_n * std::tanh(f_n / f_max_n);
  return f_n / std::pow(1.0 + std::pow(std::fabs(f_n / f_max_n), sharpness), 1.0 / sharpness);
}
struct ForceLag {  // the traction builds up through a second-order filter of the screw speed
  bool on = false;
  double tau_s = 0.15, damping = 0.8;
};
struct DeadBand {  // smooth dead band: omega_eff = omega - omega_dead tanh(omega / omega_dead), or
  bool on = false;  // with corner_rpm > 0 a softplus corner: sign(omega) c ln(1 + e^((|omega| - w0) / c))
  double omega_dead_rpm = 1.5;
  double corner_rpm = 0.0;
};
// Smooth dead band of one screw speed (DeadBand's forms); monotonic in omega.
inline double dead_band_rpm(double omega_rpm, double w0_rpm, double corner_rpm) {
  if (corner_rpm <= 0) return omega_rpm - w0_rpm * std::tanh(omega_rpm / w0_rpm);
  const double z = (std::fabs(omega_rpm) - w0_rpm) / corner_rpm;
  // softplus(z) = ln(1 + e^z), written to stay finite for large z
  const double soft = z > 30 ? z : std::log1p(std::exp(z));
  return std::copysign(corner_rpm * soft, omega_rpm) - std::copysign(corner_rpm * std::log1p(std::exp(-w0_rpm / corner_rpm)), omega_rpm);
}
struct Blocking {  // docs/model-notes.md: |omega| < omega_block: mu m g / 4 dry resistance at the contact
  bool on = false;
  double omega_block_rpm = 1.5, mu = 0.5, eps_mps = 0.002;
};

struct QuadraticDrag {  // per DOF, smooth at rest: -c u sqrt(u^2 + u0^2) (not the hard u|u|)
  bool on = false;
  double u0_mps = 0.005, r0_radps = 0.01;
  double c_x_nspm2 = 0.0, c_y_nspm2 = 0.0;  // N / (m/s)^2
  double c_psi_nmspr2 = 0.0;                // N m / (rad/s)^2, on r |r|
};
struct ResistanceOffset {  // front contacts plough (1 + asym) x their drag, rear (1 - asym) x
  bool on = false;
  double asym = 0.0;  // in (-1, 1); the lateral centre of resistance moves by asym l_x forward
};
struct TerrainChange {  // from about t_s on (tanh blend over width_s) sigma and drag are scaled
  bool on = false;
  double t_s = 0.0, width_s = 0.5;
  double sigma_scale = 1.0, drag_scale = 1.0;
};
struct SoftPatch {  // NOT in the workbench's library: a disc of soft ground (world frame) where a
  bool on = false;  // contact ploughs (1 + extra) x its drag; smooth edge of width edge_m
  double x_m = 0.0, y_m = 0.0, radius_m = 0.5, edge_m = 0.03, extra = 1.0;
};

struct TruthParams {
  double substep_s = 0.0005;  // RK4 step; stable for the tanh friction down to eps ~ 1.5 mm/s
  double r_eff_m = 0.0775;    // load torque = r_eff x traction along the screw's drive direction
  // Base form. The defaults are the physical robot (FIL tests, demo). The batch log generator
  // switches both off so that with no extra effect the truth IS the nominal linear model
  // (docs/robot-sim.md "Base truth of the log generator"): no Coriolis terms, and a yaw inertia
  // scaled by the same factor as the calibrated yaw drag, so the yaw time constant I_z / D_psi
  // is the model's (the real lever arms make the yaw equation that factor times the model's).
  bool coriolis = true;
  bool nominal_yaw_time_constant = false;
  DryFriction friction;
  Incline incline;
  TractionLoss loss;
  TractionSaturation saturation;
  ForceLag lag;
  DeadBand dead_band;
  Blocking blocking;
  QuadraticDrag quad_drag;
  ResistanceOffset offset;
  TerrainChange terrain_change;
  SoftPatch soft_patch;
  // A field (field.hpp): each contact takes the sigma, drag and blocking threshold of the zone
  // under it (a zone's unset blocking_rpm: blocking's threshold if on, else none). Null: the
  // nominal model's terrain everywhere, exactly as without fields.
  std::shared_ptr<const Field> field;
};

// State: pose eta (world), body velocity zeta, and the force-lag filter (value, rate per screw).
struct TruthState {
  Vec3 eta = Vec3::Zero();
  Vec3 zeta = Vec3::Zero();
  Vec4 lag_rpm = Vec4::Zero();
  Vec4 lag_rate_rpmps = Vec4::Zero();
};

class TrueRobot {
 public:
  // nominal: the robot and terrain (model file); the truth is calibrated against it.
  TrueRobot(const Model& nominal, const TruthParams& params);

  // Advance by dt_s with the true screw speeds held (sub-steps of params.substep_s).
  void step(const Vec4& omega_rpm, double dt_s);

  const TruthState& state() const { return s_; }
  void set_state(const TruthState& s) { s_ = s; }
  double t_s() const { return t_s_; }
  TruthParams& params() { return p_; }
  const TruthParams& params() const { return p_; }

  // Load torque on each screw (N m, positive opposes positive rotation; simmod's sign) at the
  // state and speeds of the last step.
  const Vec4& load_torque_nm() const { return load_nm_; }
  // Body acceleration of the last step's end (for the IMU).
  const Vec3& zeta_dot() const { return zeta_dot_; }
  // What an accelerometer at the centre reads at the last step's end, in the body frame (x
  // forward, y left; m/s^2): the acceleration a_x = u' - r v, a_y = v' + r u (eq. (1)) minus
  // gravity's component along the ground (non-zero on an incline; the normal part is the
  // ground's reaction).
  const Eigen::Vector2d& specific_force_mps2() const { return specific_force_mps2_; }
  // Gravity's acceleration along the (tilted) ground in the body frame at heading psi_rad.
  Eigen::Vector2d gravity_along_ground_body(double psi_rad) const;
  // The ground's unit normal in the world frame (e_z on flat ground).
  Eigen::Vector3d ground_normal_world() const;

  // Calibration: per-contact drag coefficients and the residual yaw drag (docs/robot-sim.md).
  double contact_drag_x() const { return cdx_; }
  double contact_drag_y() const { return cdy_; }
  double yaw_drag_residual() const { return d_psi_res_; }
  // Calibrated total yaw drag over the model's D_psi (the lever-arm ratio T_true / T_nom).
  double yaw_scale() const { return yaw_scale_; }
  // Yaw inertia in use (I_z, or I_z yaw_scale() with nominal_yaw_time_constant).
  double yaw_inertia_kgm2() const { return i_z_; }

  // The field's zone under each contact and under the body's centre at state s (all 0 without
  // a field).
  std::array<int, 4> contact_zones(const TruthState& s) const;
  int centre_zone(const TruthState& s) const;

  // Derivative of the full state (exposed for tests); also fills per-screw load torques.
  struct Deriv {
    Vec3 eta_dot, zeta_dot;
    Vec4 lag_dot, lag_ddot;
  };
  Deriv derivative(const TruthState& s, const Vec4& omega_rpm, double t_s, Vec4* load_nm) const;

 private:
  // What a contact needs of the ground under it: the terrain's traction per rpm, its share of the
  // drag, the residual yaw drag (a quarter per contact on a field), the blocking threshold.
  struct Ground {
    double sigma_long = 0, sigma_lat = 0, cdx = 0, cdy = 0, yaw_scale = 1, d_psi_true = 0, d_psi_res = 0;
    double block_rpm = 0;  // 0: no blocking
  };
  Ground calibrate(const Model& m) const;
  Eigen::Vector2d contact_world(const TruthState& s, std::size_t i) const;

  Model m_;
  TruthParams p_;
  Ground base_;                // the nominal model's terrain (no field)
  std::vector<Ground> zones_;  // per zone of p_.field
  TruthState s_;
  double t_s_ = 0;
  double cdx_ = 0, cdy_ = 0, d_psi_res_ = 0, yaw_scale_ = 1, i_z_ = 0;
  std::array<Eigen::Vector2d, 4> pos_;    // contact positions (body)
  std::array<Eigen::Vector2d, 4> drive_;  // unit drive direction (a_i, b_i) of K_i's row
  std::array<double, 4> s_sign_{}, h_sign_{};
  Vec4 load_nm_ = Vec4::Zero();
  Vec3 zeta_dot_ = Vec3::Zero();
  Eigen::Vector2d specific_force_mps2_ = Eigen::Vector2d::Zero();
};

}  // namespace auger::sim
