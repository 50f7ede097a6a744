// Model construction: eqs. (1)-(4), (7)-(10) from the per-screw table of docs/model-notes.md.
#include "auger/model.hpp"

#include <stdexcept>

#include <Eigen/LU>

#include "auger/effect.hpp"

namespace auger {

double wrap_angle(double a) {
  if (a > -kPi && a <= kPi) return a;  // remainder's answer, without its cost (every simulated step)
  a = std::remainder(a, 2.0 * kPi);    // in [-pi, pi]
  if (a <= -kPi) a += 2.0 * kPi;     // -pi belongs to +pi: the interval is (-pi, pi]
  return a;
}

std::array<ScrewMount, 4> screw_table(const RobotParams& p) {
  // Positions and signs of docs/model-notes.md; the signs are the only "typed-in" data.
  return {{{"front-right", +p.l_x_m, -p.l_y_m, -1.0, +1.0},
           {"rear-right", -p.l_x_m, -p.l_y_m, +1.0, -1.0},
           {"rear-left", -p.l_x_m, +p.l_y_m, +1.0, +1.0},
           {"front-left", +p.l_x_m, +p.l_y_m, -1.0, -1.0}}};
}

double kappa_m(const RobotParams& p) { return p.l_x_m + p.l_y_m / std::tan(p.phi_rad); }  // eq. (2)

Mat43 inverse_kinematics_matrix(const RobotParams& p, const std::array<ScrewMount, 4>& screws) {
  Mat43 K;
  for (int i = 0; i < 4; ++i) {
    const ScrewMount& s = screws[static_cast<std::size_t>(i)];
    const double a = s.mount_sign * s.helix_sign / std::tan(p.phi_rad);
    const double b = s.mount_sign;
    // Rigid body: the screw sees (u - r y_i, v + r x_i), so the r coefficient follows from a, b.
    K.row(i) << a, b, -a * s.y_m + b * s.x_m;  // eq. (4)
  }
  return K;
}

Mat34 forward_kinematics_matrix(const Mat43& K_i) {
  return (K_i.transpose() * K_i).inverse() * K_i.transpose();  // eq. (2), left inverse
}

Mat34 allocation_matrix(const RobotParams& p, const std::array<ScrewMount, 4>& screws) {
  Mat34 B;
  for (int i = 0; i < 4; ++i) {
    const ScrewMount& s = screws[static_cast<std::size_t>(i)];
    // The force of positive omega points where its no-slip motion points (signs of K_i);
    // the yaw row is the paper's empirical lumped coefficient, not a lever arm.
    B.col(i) << s.mount_sign * s.helix_sign, s.mount_sign, -p.l_x_m * std::sin(p.alpha_rad);  // eq. (10)
  }
  return B;
}

Model make_model(const RobotParams& robot, const TerrainParams& terrain,
                 std::vector<std::shared_ptr<const Effect>> effects) {
  auto positive = [](double v, const char* what) {
    if (!(v > 0) || !std::isfinite(v)) throw std::invalid_argument(std::string(what) + " must be > 0");
  };
  positive(robot.r_s_m, "r_s_m");
  positive(robot.l_x_m, "l_x_m");
  positive(robot.l_y_m, "l_y_m");
  positive(robot.m_kg, "m_kg");
  positive(robot.I_z_kgm2, "I_z_kgm2");
  positive(robot.omega_max_rpm, "omega_max_rpm");
  if (!(robot.phi_rad > 0 && robot.phi_rad < kPi / 2)) throw std::invalid_argument("phi must be in (0, 90) deg");
  positive(terrain.sigma_long, "sigma_long");
  positive(terrain.sigma_lat, "sigma_lat");
  if (!(terrain.D_x >= 0 && terrain.D_y >= 0 && terrain.D_psi >= 0))
    throw std::invalid_argument("terrain '" + terrain.name + "' needs D_x, D_y, D_psi >= 0");

  Model m;
  m.robot = robot;
  m.terrain = terrain;
  m.screws = screw_table(robot);
  m.kappa_m = kappa_m(robot);
  m.K_i = inverse_kinematics_matrix(robot, m.screws);
  m.K_f = forward_kinematics_matrix(m.K_i);
  m.B = allocation_matrix(robot, m.screws);
  apply_terrain(m);
  m.null_space = Vec4(-1, 1, -1, 1) * 0.5;
  m.M_diag << robot.m_kg, robot.m_kg, robot.I_z_kgm2;
  m.effects = std::move(effects);
  for (const auto& e : m.effects) {
    m.effect_state_offset.push_back(m.effect_state_size);
    m.effect_state_size += e->state_size();
    e->inertia(m, m.M_diag);
  }
  positive(m.M_diag[0], "the effective mass");
  positive(m.M_diag[2], "the effective yaw inertia");
  return m;
}

void apply_terrain(Model& m) {
  const TerrainParams& t = m.terrain;
  m.sigma << t.sigma_long, t.sigma_lat, t.sigma_lat;  // eq. (7)
  m.SB = m.sigma.asDiagonal() * m.B;
  // Full row rank 3: (S B)^+ = (S B)^T (S B (S B)^T)^-1, eq. (22).
  m.SB_pinv = m.SB.transpose() * (m.SB * m.SB.transpose()).inverse();
  m.D_diag << t.D_x, t.D_y, t.D_psi;  // eq. (6)
}

double yaw_lumping(const Model& m) {
  double moment = 0.0;
  for (std::size_t i = 0; i < 4; ++i) {
    const ScrewMount& s = m.screws[i];
    // Screw i's force per rpm in the body frame is column i of S B's x and y rows.
    moment += s.x_m * m.SB(1, static_cast<Eigen::Index>(i)) - s.y_m * m.SB(0, static_cast<Eigen::Index>(i));
  }
  const double lumped = m.SB.row(2).sum();
  return std::fabs(moment) > 0 ? lumped / moment : 1.0;
}

Mat3 rotation_J(double psi) {
  const double c = std::cos(psi), s = std::sin(psi);
  Mat3 J;
  J << c, -s, 0, s, c, 0, 0, 0, 1;  // eq. (9)
  return J;
}

Vec3 kinematic_body_velocity(const Model& model, const Vec4& omega_rpm) {
  return model.robot.r_s_m * model.K_f * (omega_rpm * kRpmToRadps);  // eq. (1), omega in rad/s
}

Vec4 kinematic_screw_speeds_rpm(const Model& model, const Vec3& zeta) {
  return (model.K_i * zeta / model.robot.r_s_m) / kRpmToRadps;  // eq. (3)
}

double pose_delay_s(const Model& model) {
  double delay_s = 0.0;
  for (const auto& e : model.effects) delay_s += e->pose_delay_s();
  return delay_s;
}

}  // namespace auger
