// The robot model of docs/model-notes.md: per-screw table, kinematics eqs. (1)-(4), dynamic model
// matrices eqs. (5)-(10). A Model is built once (from a model file or parameters) and then only
// read (const) by the estimation, control and allocation steps.
#pragma once

#include <array>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace auger {

using Vec3 = Eigen::Vector3d;
using Vec4 = Eigen::Vector4d;
using Mat3 = Eigen::Matrix3d;
using Mat34 = Eigen::Matrix<double, 3, 4>;
using Mat43 = Eigen::Matrix<double, 4, 3>;

constexpr double kPi = 3.14159265358979323846;
constexpr double kRpmToRadps = 2.0 * kPi / 60.0;
inline double deg_to_rad(double deg) { return deg * kPi / 180.0; }

// Wraps an angle to (-pi, pi] (docs/model-notes.md decision for heading errors).
double wrap_angle(double angle_rad);

class Effect;

// Geometry and mass (docs/model-notes.md "Geometry and mass"; Table 3).
struct RobotParams {
  double r_s_m = 0.0775;
  double phi_rad = kPi / 6.0;          // helix angle
  double l_x_m = 0.15;
  double l_y_m = 0.30;
  double alpha_rad = 26.5 * kPi / 180;  // lever-arm angle of B, eq. (10)
  double m_kg = 29.0;
  double I_z_kgm2 = 3.72;
  double omega_max_rpm = 23.0;  // motor rating at 12 V
};

// One terrain's parameter set (Tables 2-3). sigma in N per rpm (omega_unit = rpm), D_x, D_y in
// N/(m/s), D_psi in N m/(rad/s). D_psi is NaN for the gantry sets, which have no yaw.
struct TerrainParams {
  std::string name;
  double sigma_long = 0, sigma_lat = 0;
  double D_x = 0, D_y = 0, D_psi = std::nan("");
};

// Row of the per-screw table of docs/model-notes.md. mount_sign is the sign of the lateral rolling
// (front and rear modules are mounted mirrored), helix_sign the handedness of the helix; together
// they give the row of K_i and the column of B.
struct ScrewMount {
  const char* name;
  double x_m, y_m;
  double mount_sign;
  double helix_sign;
};

// The table: 0 front-right, 1 rear-right, 2 rear-left, 3 front-left (REP-103, y left).
std::array<ScrewMount, 4> screw_table(const RobotParams& robot);

// kappa = l_x + l_y / tan(phi), eq. (2).
double kappa_m(const RobotParams& robot);

// K_i of eq. (4) built from the table: row i = [s h / tan(phi), s, -a_i y_i + b_i x_i]
// (the contact velocity of screw i is (u - r y_i, v + r x_i)).
Mat43 inverse_kinematics_matrix(const RobotParams& robot, const std::array<ScrewMount, 4>& screws);
// K_f of eq. (2): the left inverse (K_i^T K_i)^-1 K_i^T.
Mat34 forward_kinematics_matrix(const Mat43& K_i);
// B of eq. (10) from the table: x row s h, y row s, yaw row -l_x sin(alpha) (empirical lump).
Mat34 allocation_matrix(const RobotParams& robot, const std::array<ScrewMount, 4>& screws);

// An effect's parameter the model uses in place of the effect's own value: augerd's online
// estimate with `[online] apply` (online_estimator.hpp set_effect_parameters). The effects are
// immutable and shared; the estimate lives in the model that uses it, in fixed room (the 100 Hz
// loop allocates nothing). Unused entries have effect == nullptr.
struct EffectOverride {
  const Effect* effect = nullptr;
  std::size_t index = 0;  // into the effect's params()
  double value = 0;
};
constexpr int kMaxEffectOverrides = 3;

struct Model {
  RobotParams robot;
  TerrainParams terrain;
  std::array<ScrewMount, 4> screws;
  double kappa_m = 0;
  Mat43 K_i;       // eq. (4)
  Mat34 K_f;       // eq. (2)
  Mat34 B;         // eq. (10)
  Vec3 sigma;      // diagonal of S = diag(sigma_long, sigma_lat, sigma_lat), eq. (7)
  Mat34 SB;        // tau = S B omega_rpm
  Mat43 SB_pinv;   // (S B)^+, eq. (22)
  Vec4 null_space; // unit vector along [-1, 1, -1, 1]: S B n = 0
  Vec3 M_diag;     // eq. (8)
  Vec3 D_diag;     // D = diag(D_x, D_y, D_psi), eq. (6)
  std::vector<std::shared_ptr<const Effect>> effects;  // in the order of the model file
  std::vector<std::size_t> effect_state_offset;          // into a workspace's effect state
  std::size_t effect_state_size = 0;
  std::array<EffectOverride, kMaxEffectOverrides> effect_overrides{};  // none: the effects' own values
};

// The value of an effect's parameter `index` in this model: an override's, else `own` (the
// effect's). Effects whose parameters may be online read them through this in body_force.
inline double effect_param(const Model& model, const Effect* effect, std::size_t index, double own) {
  for (const EffectOverride& o : model.effect_overrides)
    if (o.effect == effect && o.index == index) return o.value;
  return own;
}

// S, S B, (S B)^+ and D (eqs. (6), (7), (22)) from model.terrain; no heap allocation (the online
// estimator's parameters reach the controller through it, online_estimator.hpp).
void apply_terrain(Model& model);

// Builds every matrix from the parameters; throws std::invalid_argument on non-physical values.
Model make_model(const RobotParams& robot, const TerrainParams& terrain,
                 std::vector<std::shared_ptr<const Effect>> effects = {});

// How much earlier than their t_s the model's pose rows show the robot, in s: the sum of its
// effects' pose_delay_s() (effect pose_time_offset). The workbench shifts the screw speeds
// against the poses by it, the controller's EKF takes each pose as of that much earlier.
double pose_delay_s(const Model& model);

// eq. (9): body to world.
Mat3 rotation_J(double psi_rad);

// eq. (1): no-slip body velocity [u, v, r] from screw speeds (converted rpm -> rad/s here).
Vec3 kinematic_body_velocity(const Model& model, const Vec4& omega_rpm);
// eq. (3): screw speeds in rpm for a body velocity, no slip.
Vec4 kinematic_screw_speeds_rpm(const Model& model, const Vec3& zeta);

// The yaw row of eq. (10)'s B is an empirical lump (-l_x sin(alpha) per screw), not the lever
// arm of the screw forces: the model's yaw equation is the real one scaled down. This is that
// scale, the model's yaw torque over the real moment of the same screw forces at their contact
// points, for the pure-yaw pattern omega = [1 1 1 1] (about 1/17 with the paper's values). An
// effect that applies a force at a contact point turns its real moment into the model's yaw
// units with it.
double yaw_lumping(const Model& model);

}  // namespace auger
