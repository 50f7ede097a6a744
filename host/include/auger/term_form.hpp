// A discovered term (docs/workbench.md "Discovered terms"): a generalized force that no library
// effect has, proposed by `auger explain` from the residuals and loaded from a model file as the
// effect `term` (dof, form, coefficient). The form is a product of at most two factors, each a
// function of one input of a fixed vocabulary, so that a term reads as physics: "the rear-left
// screw pushes 0.3 of its speed less when it turns backwards" is `screw_2: neg(omega_rpm)`.
#pragma once

#include <string>
#include <vector>

#include "auger/model.hpp"

namespace auger {

// Where the term acts: a body force along x or y (N), a yaw torque in the model's lumped units
// (N m, eq. (10)), or a change of one screw's (or every screw's) effective speed in rpm that
// eq. (7) turns into force through its column of S B, or (`drag`) a change of the ground's
// linear drag D zeta of eq. (6) on every axis alike, as a fraction: the force -c form D zeta (a
// ground that grows harder to move through over the log, or in one part of the field).
enum class TermDof { kX, kY, kYaw, kDrag, kScrew0, kScrew1, kScrew2, kScrew3, kScrews };

// The inputs a factor may take (the vocabulary; names as the log's columns):
// omega_rpm_0..3, omega_rpm (a screw dof's own screw), u_mps, v_mps, r_radps (body velocity),
// psi_rad, x_m, y_m (pose), t_s (log time), and 1.
enum class TermInput { kOmega0, kOmega1, kOmega2, kOmega3, kOmegaOwn, kU, kV, kR, kPsi, kX, kY, kT, kOne };
// The functions of one input: the input itself, sign, abs, pos (max(a, 0): a screw's forward
// part), neg (min(a, 0): its backward part), sqs (a |a|, odd), sq (a^2, even), sin, cos, sin2
// (sin 2a), cos2 (cos 2a).
enum class TermFn { kId, kSign, kAbs, kPos, kNeg, kSqs, kSq, kSin, kCos, kSin2, kCos2 };

struct TermFactor {
  TermFn fn = TermFn::kId;
  TermInput input = TermInput::kOne;
};

// What a term's factors see at one step.
struct TermInputs {
  Vec3 eta = Vec3::Zero();   // x_m, y_m, psi_rad
  Vec3 zeta = Vec3::Zero();  // u_mps, v_mps, r_radps
  Vec4 omega_rpm = Vec4::Zero();
  double t_s = 0;
};

class TermForm {
 public:
  // Parses dof ("x", "y", "yaw", "drag", "screw_0".."screw_3", "screws") and form ("neg(omega_rpm)",
  // "u_mps*r_radps", "sin(psi_rad)", "1", ...); throws std::invalid_argument naming what is wrong.
  TermForm(const std::string& dof, const std::string& form);
  TermDof dof() const { return dof_; }
  const std::vector<TermFactor>& factors() const { return factors_; }
  const std::string& dof_text() const { return dof_text_; }
  const std::string& form_text() const { return form_text_; }  // canonical spelling
  // The form's value for screw i (a screw dof) or for the body (i < 0).
  double value(const TermInputs& in, int screw = -1) const;
  // The body force (x, y, yaw) of the term with this coefficient, eqs. (6)-(7).
  Vec3 force(const Model& model, const TermInputs& in, double coefficient) const;
  // The inputs it reads, in the vocabulary (omega_rpm of a screw dof named per screw).
  std::vector<std::string> input_names() const;
  // Units: of the form, of the dof, and of the coefficient (dof unit / form unit; "-" if they
  // cancel), e.g. "N/(m/s)^2".
  std::string form_unit() const;
  std::string dof_unit() const;
  std::string coefficient_unit() const;
  // Plain words: "a yaw torque of -0.41 N m per rad/s ..." (for model file comments and reports).
  std::string describe(double coefficient) const;

 private:
  TermDof dof_;
  std::vector<TermFactor> factors_;
  std::string dof_text_, form_text_;
};

}  // namespace auger
