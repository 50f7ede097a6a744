// Dynamic model, eqs. (5)-(7): eta_dot = J(psi) zeta, M zeta_dot = -D zeta + tau, tau = S B omega
// (omega in rpm), plus the model's effects. The linear part is stepped exactly (zero-order hold
// per DOF: M and D are diagonal), because m / D_x = 0.05 s is shorter than a few 10 ms samples;
// the pose is integrated with RK4 sub-steps using that exact velocity.
#pragma once

#include <limits>
#include <vector>

#include "auger/effect.hpp"
#include "auger/model.hpp"

namespace auger {

// Exact step of one DOF m v_dot = -d v + f with f held over dt (d may be 0).
// Returns the end velocity; *gain (if given) receives d v_end / d f.
double first_order_step(double m, double d, double v, double f, double dt_s, double* gain = nullptr);
// Displacement over that step (exact integral of v).
double first_order_displacement(double m, double d, double v, double f, double dt_s);

// The exponentials of those steps for one step length: a simulation takes the same length step
// after step, and the exponentials were a tenth of a workbench fit's time. decay(m, d, dt) is
// first_order_step's exp(-d dt / m) per DOF, to the bit (NaN where d <= 0: no decay).
struct StepDecay {
  double dt_s = std::numeric_limits<double>::quiet_NaN();
  Vec3 m = Vec3::Zero(), d = Vec3::Zero();
  Vec3 e = Vec3::Zero();  // exp(-d dt / m)
  double e_psi_displacement = 0;  // first_order_displacement's exp(-dt / (m / d)) in yaw
  void update(const Vec3& m_diag, const Vec3& d_diag, double dt);
};
// first_order_step with its exponential given (StepDecay::e).
double first_order_step(double m, double d, double v, double f, double dt_s, double e, double* gain);

// Preallocated workspace of the dynamics step.
struct DynamicsData {
  explicit DynamicsData(const Model& model);
  void reset(const Model& model);  // resets the effects' state
  std::vector<double> effect_state;
  double t_s = 0;  // time of the next step's start; dynamics_step advances it (time-dependent effects)
  EffectContext ctx;
  Vec3 tau_drive_n = Vec3::Zero();   // last sub-step's drive force (after drive effects)
  Vec3 tau_effect_n = Vec3::Zero();  // last sub-step's effect body forces
  StepDecay step, half_step;         // dynamics_step's sub-step and its half
};

// eq. (7) with the drive effects: the body force of the screw speeds over a step starting at t_s
// (NaN: data.t_s), with the ground's traction there (Effect::traction_scale).
void drive_force(const Model& model, DynamicsData& data, const Vec4& omega_rpm, double dt_s, Vec3& tau_n,
                 double t_s = std::numeric_limits<double>::quiet_NaN());

// eq. (6)'s added body forces: the model's effects for the state (eta, zeta) over a step of dt_s
// starting at t_s, with omega_rpm and data.tau_drive_n held; the sum lands in data.tau_effect_n.
void effect_body_force(const Model& model, DynamicsData& data, double t_s, const Vec3& eta, const Vec3& zeta,
                       const Vec4& omega_rpm, double dt_s);

// The part of eq. (6)'s added forces the controller feeds forward (Effect::feedforward_force):
// the sum over the model's effects at pose eta and body velocity zeta, in force_n. Returns the
// first effect whose force is not finite (force_n then undefined), nullptr when all are. No
// heap allocation.
const Effect* effect_feedforward_force(const Model& model, const Vec3& eta, const Vec3& zeta, Vec3& force_n);

// One step of eqs. (5)-(7) over dt_s with omega_rpm held, in n_sub equal sub-steps (effects
// re-evaluated per sub-step). eta (world) and zeta (body) are updated in place.
void dynamics_step(const Model& model, DynamicsData& data, Vec3& eta, Vec3& zeta,
                   const Vec4& omega_rpm, double dt_s, int n_sub = 4);

// Steady body velocity of the nominal model for constant screw speeds: D^-1 S B omega.
Vec3 steady_velocity(const Model& model, const Vec4& omega_rpm);

}  // namespace auger
