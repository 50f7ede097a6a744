// The true robot: see true_robot.hpp and docs/robot-sim.md.
#include "true_robot.hpp"

#include <cmath>
#include <stdexcept>

namespace auger::sim {

namespace {
// Smooth unit "sign" of a 2-D velocity: tanh(|c| / eps) c / |c|, 0 at rest. The tanh keeps the
// dry forces continuous so the fixed-step RK4 needs no event handling; eps sets how fast a
// force below the breakaway level still creeps (about eps atanh(F / F_max)).
Eigen::Vector2d smooth_direction(const Eigen::Vector2d& c, double eps) {
  const double n = c.norm();
  if (n < 1e-12) return Eigen::Vector2d::Zero();
  return c * (std::tanh(n / eps) / n);
}
}  // namespace

TrueRobot::TrueRobot(const Model& nominal, const TruthParams& params) : m_(nominal), p_(params) {
  if (!(p_.substep_s > 0)) throw std::invalid_argument("TrueRobot: substep_s must be > 0");
  const double tan_phi = std::tan(m_.robot.phi_rad);
  for (int i = 0; i < 4; ++i) {
    const ScrewMount& sc = m_.screws[static_cast<std::size_t>(i)];
    pos_[static_cast<std::size_t>(i)] = Eigen::Vector2d(sc.x_m, sc.y_m);
    s_sign_[static_cast<std::size_t>(i)] = sc.mount_sign;
    h_sign_[static_cast<std::size_t>(i)] = sc.helix_sign;
    // (a_i, b_i) of K_i's row (eq. (4)): the contact velocity direction one screw drives.
    drive_[static_cast<std::size_t>(i)] =
        Eigen::Vector2d(sc.mount_sign * sc.helix_sign / tan_phi, sc.mount_sign).normalized();
  }
  base_ = calibrate(m_);
  base_.block_rpm = p_.blocking.on ? p_.blocking.omega_block_rpm : 0.0;
  cdx_ = base_.cdx;
  cdy_ = base_.cdy;
  yaw_scale_ = base_.yaw_scale;
  d_psi_res_ = base_.d_psi_res;
  i_z_ = m_.robot.I_z_kgm2 * (p_.nominal_yaw_time_constant ? yaw_scale_ : 1.0);
  if (p_.field && p_.nominal_yaw_time_constant)
    throw std::invalid_argument("TrueRobot: a field needs the physical yaw inertia (nominal_yaw_time_constant off)");
  // The stiffest ground sets the stability bound below.
  double d_xy_max = m_.D_diag[0] + m_.D_diag[1], d_psi_max = base_.d_psi_true;
  bool any_blocking = p_.blocking.on;
  if (p_.field) {
    for (const FieldZone& z : p_.field->zones) {
      Ground g = calibrate(make_model(m_.robot, z.terrain));
      g.block_rpm = z.blocking_rpm.value_or(base_.block_rpm);
      any_blocking = any_blocking || g.block_rpm > 0;
      d_xy_max = std::max(d_xy_max, z.terrain.D_x + z.terrain.D_y);
      d_psi_max = std::max(d_psi_max, g.d_psi_true);
      zones_.push_back(g);
    }
  }
  if (p_.offset.on && !(std::fabs(p_.offset.asym) < 1.0))
    throw std::invalid_argument("TrueRobot: resistance offset asym must lie in (-1, 1)");
  // RK4 is stable for a real eigenvalue -lambda while lambda h < 2.78. The tanh forms are
  // stiffest at rest: slope F_max / eps. Translation: friction plus four blocked contacts.
  const double m = m_.robot.m_kg, g_n = m * kGravity_mps2;
  double lambda = d_xy_max / m;
  if (p_.friction.on) lambda += p_.friction.stiction_n / p_.friction.eps_mps / m;
  if (any_blocking) lambda += p_.blocking.mu * g_n / p_.blocking.eps_mps / m;
  // The soft patch and a terrain change scale the drag; the front contacts of the offset too.
  double drag_gain = 1.0;
  if (p_.soft_patch.on) drag_gain *= 1.0 + std::max(0.0, p_.soft_patch.extra);
  if (p_.terrain_change.on) drag_gain *= std::max(1.0, p_.terrain_change.drag_scale);
  if (p_.offset.on) drag_gain *= 1.0 + std::fabs(p_.offset.asym);
  lambda *= drag_gain;
  double lambda_z = drag_gain * d_psi_max / i_z_;
  if (p_.friction.on) lambda_z += p_.friction.stiction_nm / p_.friction.eps_radps / i_z_;
  if (any_blocking)
    lambda_z += p_.blocking.mu * g_n / p_.blocking.eps_mps * 0.25 * (pos_[0].squaredNorm()) * 4 / i_z_;
  if (std::max(lambda, lambda_z) * p_.substep_s > 2.5)
    throw std::invalid_argument("TrueRobot: substep_s too long for the smoothing eps of the dry forces");
}

TrueRobot::Ground TrueRobot::calibrate(const Model& m) const {
  Ground g;
  g.sigma_long = m.terrain.sigma_long;
  g.sigma_lat = m.terrain.sigma_lat;
  // Drag: each contact ploughs through the ground and resists its own velocity with a quarter
  // of D_x, D_y (so translation keeps eq. (6)'s D_x, D_y exactly).
  g.cdx = m.D_diag[0] / 4.0;
  g.cdy = m.D_diag[1] / 4.0;
  // Yaw: the truth's screw forces act at their real lever arms, about 17x the empirical yaw row
  // of B (docs/model-notes.md). For the same steady r, D_psi is scaled by the same ratio:
  // r_ss = T_true / D_true = T_nom / D_psi  =>  D_true = D_psi T_true / T_nom, with T per rpm of
  // the pure-yaw pattern omega = [1 1 1 1] (it gives no net force in either model).
  double torque_true = 0.0;
  for (std::size_t i = 0; i < 4; ++i) {
    const double fx = m.terrain.sigma_long * s_sign_[i] * h_sign_[i];
    const double fy = m.terrain.sigma_lat * s_sign_[i];
    torque_true += pos_[i].x() * fy - pos_[i].y() * fx;
  }
  const double torque_nom = m.SB.row(2).sum();
  if (!(std::fabs(torque_nom) > 0) || !std::isfinite(m.D_diag[2]))
    throw std::invalid_argument("TrueRobot: the terrain needs D_psi and a yaw row of B");
  g.yaw_scale = torque_true / torque_nom;
  g.d_psi_true = m.D_diag[2] * g.yaw_scale;
  double contact_yaw = 0.0;
  for (const auto& r : pos_) contact_yaw += g.cdx * r.y() * r.y() + g.cdy * r.x() * r.x();
  g.d_psi_res = g.d_psi_true - contact_yaw;
  if (g.d_psi_res < 0)
    throw std::invalid_argument("TrueRobot: the contact drag alone exceeds the calibrated yaw drag on " + m.terrain.name);
  return g;
}

Eigen::Vector2d TrueRobot::contact_world(const TruthState& s, std::size_t i) const {
  const double cpsi = std::cos(s.eta[2]), spsi = std::sin(s.eta[2]);
  const Eigen::Vector2d& p = pos_[i];
  return Eigen::Vector2d(s.eta[0] + cpsi * p.x() - spsi * p.y(), s.eta[1] + spsi * p.x() + cpsi * p.y());
}

std::array<int, 4> TrueRobot::contact_zones(const TruthState& s) const {
  std::array<int, 4> z{};
  if (!p_.field) return z;
  for (std::size_t i = 0; i < 4; ++i) {
    const Eigen::Vector2d w = contact_world(s, i);
    z[i] = p_.field->zone_at(w.x(), w.y());
  }
  return z;
}

int TrueRobot::centre_zone(const TruthState& s) const {
  return p_.field ? p_.field->zone_at(s.eta[0], s.eta[1]) : 0;
}

TrueRobot::Deriv TrueRobot::derivative(const TruthState& s, const Vec4& omega_rpm, double t_s,
                                       Vec4* load_nm) const {
  const double u = s.zeta[0], v = s.zeta[1], r = s.zeta[2];
  const double m = m_.robot.m_kg;

  // Normal load: the weight's component normal to the (possibly tilted) ground.
  const Eigen::Vector3d n_world = ground_normal_world();
  const double normal_n = m * kGravity_mps2 * n_world.z();

  Deriv d;
  // Speed that makes traction: smooth dead band, then the second-order lag.
  Vec4 w_in = omega_rpm;
  if (p_.dead_band.on) {
    const double w0 = p_.dead_band.omega_dead_rpm;
    for (int i = 0; i < 4; ++i) w_in[i] = dead_band_rpm(omega_rpm[i], w0, p_.dead_band.corner_rpm);
  }
  Vec4 w_tr = w_in;
  if (p_.lag.on) {
    const double tau = p_.lag.tau_s;
    w_tr = s.lag_rpm;
    d.lag_dot = s.lag_rate_rpmps;
    // tau^2 y'' + 2 zeta tau y' + y = omega: a second-order (not first-order) build-up.
    d.lag_ddot = (w_in - s.lag_rpm - 2.0 * p_.lag.damping * tau * s.lag_rate_rpmps) / (tau * tau);
  } else {
    d.lag_dot.setZero();
    d.lag_ddot.setZero();
  }

  // Terrain change: the blend b goes 0 -> 1 around t_s (a smooth switch, not a step).
  double sigma_gain = 1.0, drag_gain = 1.0;
  if (p_.terrain_change.on) {
    const TerrainChange& tc = p_.terrain_change;
    const double b = 0.5 * (1.0 + std::tanh((t_s - tc.t_s) / std::max(tc.width_s, 1e-6)));
    sigma_gain = 1.0 + b * (tc.sigma_scale - 1.0);
    drag_gain = 1.0 + b * (tc.drag_scale - 1.0);
  }
  const double cpsi = std::cos(s.eta[2]), spsi = std::sin(s.eta[2]);

  // The ground under each contact (a field's zone, else the nominal terrain). The residual yaw
  // drag is the body's: on a field each contact carries a quarter of its zone's.
  std::array<const Ground*, 4> ground{&base_, &base_, &base_, &base_};
  double d_psi_res = d_psi_res_;
  if (p_.field) {
    for (std::size_t i = 0; i < 4; ++i) {
      const Eigen::Vector2d w = contact_world(s, i);
      ground[i] = &zones_[static_cast<std::size_t>(p_.field->zone_at(w.x(), w.y()))];
    }
    const bool same = ground[1] == ground[0] && ground[2] == ground[0] && ground[3] == ground[0];
    d_psi_res = same ? ground[0]->d_psi_res
                     : 0.25 * (ground[0]->d_psi_res + ground[1]->d_psi_res + ground[2]->d_psi_res + ground[3]->d_psi_res);
  }
  Eigen::Vector2d f_body = Eigen::Vector2d::Zero();
  double m_z = -drag_gain * d_psi_res * r;
  for (std::size_t i = 0; i < 4; ++i) {
    const Eigen::Vector2d& p = pos_[i];
    // Traction of screw i from its speed (N per rpm, eq. (7) distributed per screw).
    const Ground& gr = *ground[i];
    double f_long = sigma_gain * gr.sigma_long * w_tr[static_cast<int>(i)];
    double f_lat = sigma_gain * gr.sigma_lat * w_tr[static_cast<int>(i)];
    if (p_.saturation.on) {
      f_long = saturate_force(f_long, p_.saturation.long_max_n, p_.saturation.sharpness);
      f_lat = saturate_force(f_lat, p_.saturation.lat_max_n, p_.saturation.sharpness);
    }
    if (p_.loss.on && static_cast<int>(i) == p_.loss.screw && t_s >= p_.loss.t_on_s) {
      f_long *= p_.loss.factor;
      f_lat *= p_.loss.factor;
    }
    Eigen::Vector2d f_tr(f_long * s_sign_[i] * h_sign_[i], f_lat * s_sign_[i]);
    // Contact point velocity (u - r y_i, v + r x_i) (docs/model-notes.md "Frames").
    const Eigen::Vector2d c(u - r * p.y(), v + r * p.x());
    Eigen::Vector2d f_block = Eigen::Vector2d::Zero();
    if (gr.block_rpm > 0 && std::fabs(omega_rpm[static_cast<int>(i)]) < gr.block_rpm)
      f_block = -(p_.blocking.mu * normal_n / 4.0) * smooth_direction(c, p_.blocking.eps_mps);
    // Contact drag; the resistance offset makes the front pair plough more than the rear (so a
    // sideways velocity gives a yaw moment a D_y l_x v, and r a lateral force), the soft patch
    // adds drag to a contact inside its disc.
    double k_drag = drag_gain;
    if (p_.soft_patch.on) {
      const SoftPatch& sp = p_.soft_patch;
      const double xw = s.eta[0] + cpsi * p.x() - spsi * p.y() - sp.x_m;
      const double yw = s.eta[1] + spsi * p.x() + cpsi * p.y() - sp.y_m;
      const double inside = 0.5 * (1.0 - std::tanh((std::hypot(xw, yw) - sp.radius_m) / sp.edge_m));
      k_drag *= 1.0 + sp.extra * inside;
    }
    const Eigen::Vector2d f_plain(-k_drag * gr.cdx * c.x(), -k_drag * gr.cdy * c.y());
    Eigen::Vector2d f_drag = f_plain;
    if (p_.offset.on) {
      const double asym = p.x() > 0 ? p_.offset.asym : -p_.offset.asym;
      const Eigen::Vector2d f_asym = asym * f_plain;
      // Its moment is the real one, like every contact force's: in the model's lumped yaw row it
      // is 1/yaw_scale of that (the library's resistance_offset scales it so), and the centre of
      // resistance sits at asym l_x for the model too.
      f_drag += f_asym;
    }
    const Eigen::Vector2d f = f_tr + f_block + f_drag;
    f_body += f;
    m_z += p.x() * f.y() - p.y() * f.x();
    // The ground pushes the robot with f_tr + f_block; the helix feels the reaction along the
    // screw's drive direction, at the effective radius (positive opposes positive rotation).
    if (load_nm) (*load_nm)[static_cast<int>(i)] = p_.r_eff_m * drive_[i].dot(f_tr + f_block);
  }

  if (p_.incline.on) f_body += m * gravity_along_ground_body(s.eta[2]);
  if (p_.friction.on) {
    const DryFriction& fr = p_.friction;
    const double load = normal_n / (m * kGravity_mps2);  // friction scales with the normal load
    auto stribeck = [&](double speed, double scale) {
      return scale * (fr.coulomb_n + (fr.stiction_n - fr.coulomb_n) * std::exp(-(speed / fr.stribeck_mps) * (speed / fr.stribeck_mps)));
    };
    if (fr.per_axis) {
      f_body.x() -= load * stribeck(u, 1.0) * std::tanh(u / fr.eps_mps);
      f_body.y() -= load * stribeck(v, fr.y_ratio) * std::tanh(v / fr.eps_mps);
    } else {
      const Eigen::Vector2d w(u, v);
      f_body -= load * stribeck(w.norm(), 1.0) * smooth_direction(w, fr.eps_mps);
    }
    const double level_z = fr.coulomb_nm + (fr.stiction_nm - fr.coulomb_nm) *
                                               std::exp(-(r / fr.stribeck_radps) * (r / fr.stribeck_radps));
    m_z -= load * level_z * std::tanh(r / fr.eps_radps);
  }

  if (p_.quad_drag.on) {
    // Quadratic ploughing, smooth through zero (u sqrt(u^2 + u0^2)) so RK4 sees no kink.
    const QuadraticDrag& q = p_.quad_drag;
    f_body.x() -= q.c_x_nspm2 * u * std::sqrt(u * u + q.u0_mps * q.u0_mps);
    f_body.y() -= q.c_y_nspm2 * v * std::sqrt(v * v + q.u0_mps * q.u0_mps);
    m_z -= q.c_psi_nmspr2 * r * std::sqrt(r * r + q.r0_radps * q.r0_radps);
  }

  // Rigid body in the plane, body frame: m (u' - r v) = F_x, m (v' + r u) = F_y, I r' = M_z
  // (Coriolis terms optional, see TruthParams::coriolis).
  const double cor = p_.coriolis ? 1.0 : 0.0;
  d.zeta_dot = Vec3(f_body.x() / m + cor * r * v, f_body.y() / m - cor * r * u, m_z / i_z_);
  // eq. (5): eta' = J(psi) zeta.
  d.eta_dot = Vec3(cpsi * u - spsi * v, spsi * u + cpsi * v, r);
  return d;
}

Eigen::Vector3d TrueRobot::ground_normal_world() const {
  if (!p_.incline.on) return Eigen::Vector3d(0, 0, 1);
  const double cr = std::cos(p_.incline.roll_rad), sr = std::sin(p_.incline.roll_rad);
  const double cp = std::cos(p_.incline.pitch_rad), sp = std::sin(p_.incline.pitch_rad);
  return Eigen::Vector3d(sp * cr, -sr, cp * cr);  // R_y(pitch) R_x(roll) e_z
}

Eigen::Vector2d TrueRobot::gravity_along_ground_body(double psi_rad) const {
  if (!p_.incline.on) return Eigen::Vector2d::Zero();
  const Eigen::Vector3d n_world = ground_normal_world();
  // Gravity minus its normal part, in the world frame, then into the body frame (J^T).
  const Eigen::Vector3d g_world(0, 0, -kGravity_mps2);
  const Eigen::Vector3d g_t = g_world - g_world.dot(n_world) * n_world;
  const double c = std::cos(psi_rad), s = std::sin(psi_rad);
  return Eigen::Vector2d(c * g_t.x() + s * g_t.y(), -s * g_t.x() + c * g_t.y());
}

void TrueRobot::step(const Vec4& omega_rpm, double dt_s) {
  if (!(dt_s > 0)) return;
  const int n = std::max(1, static_cast<int>(std::ceil(dt_s / p_.substep_s - 1e-9)));
  const double h = dt_s / n;
  auto add = [](const TruthState& s, const Deriv& d, double k) {
    TruthState o = s;
    o.eta += k * d.eta_dot;
    o.zeta += k * d.zeta_dot;
    o.lag_rpm += k * d.lag_dot;
    o.lag_rate_rpmps += k * d.lag_ddot;
    return o;
  };
  for (int k = 0; k < n; ++k) {
    // Classical RK4 with the screw speeds held over the sub-step.
    const Deriv k1 = derivative(s_, omega_rpm, t_s_, nullptr);
    const Deriv k2 = derivative(add(s_, k1, h / 2), omega_rpm, t_s_ + h / 2, nullptr);
    const Deriv k3 = derivative(add(s_, k2, h / 2), omega_rpm, t_s_ + h / 2, nullptr);
    const Deriv k4 = derivative(add(s_, k3, h), omega_rpm, t_s_ + h, nullptr);
    s_.eta += h / 6 * (k1.eta_dot + 2 * k2.eta_dot + 2 * k3.eta_dot + k4.eta_dot);
    s_.zeta += h / 6 * (k1.zeta_dot + 2 * k2.zeta_dot + 2 * k3.zeta_dot + k4.zeta_dot);
    s_.lag_rpm += h / 6 * (k1.lag_dot + 2 * k2.lag_dot + 2 * k3.lag_dot + k4.lag_dot);
    s_.lag_rate_rpmps += h / 6 * (k1.lag_ddot + 2 * k2.lag_ddot + 2 * k3.lag_ddot + k4.lag_ddot);
    t_s_ += h;
  }
  const Deriv end = derivative(s_, omega_rpm, t_s_, &load_nm_);
  zeta_dot_ = end.zeta_dot;
  // The body-frame acceleration of the centre by kinematics, whatever TruthParams::coriolis says
  // (d/dt of J(psi) zeta = J (zeta' + (-r v, r u)), eq. (5)), minus gravity's pull along the
  // ground: what an accelerometer there reads in the plane.
  const double u = s_.zeta[0], v = s_.zeta[1], r = s_.zeta[2];
  specific_force_mps2_ = Eigen::Vector2d(zeta_dot_[0] - r * v, zeta_dot_[1] + r * u) - gravity_along_ground_body(s_.eta[2]);
}

}  // namespace auger::sim
