// Physical effects: named changes to the nominal model, each with its own parameters. An effect
// can change how screw speeds become forces (eq. (7)), add forces on the body (eq. (6)), or
// change what the sensors report. The model file lists the effects in use; the registry creates
// them by id. The workbench (issue 5) adds effects by registering more factories.
#pragma once

#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "auger/model.hpp"

namespace auger {

// An error in a configuration or model file: what() is "file:line:column: message".
class ConfigError : public std::runtime_error {
 public:
  ConfigError(std::string file, int line, int column, const std::string& message);
  const std::string& file() const { return file_; }
  int line() const { return line_; }
  int column() const { return column_; }

 private:
  std::string file_;
  int line_, column_;
};

// What a body-force effect sees over one step of the linear dynamics. Because M and D are
// diagonal and the step is exact with the force held, the body velocity at the step's end is
// affine in the added force: zeta_end = zeta_free + gain .* force. Dry friction uses this to
// stop exactly at zero instead of chattering around it.
struct EffectContext {
  Vec3 eta;           // pose at the step's start (world)
  Vec3 zeta;          // body velocity at the step's start
  Vec4 omega_rpm;     // screw speeds held over the step
  Vec3 tau_drive_n;   // drive force over the step (after drive effects)
  double dt_s = 0;
  Vec3 zeta_free;     // velocity at the step's end with the forces applied so far
  Vec3 gain;          // d zeta_end / d force per DOF
  double t_s = 0;     // time at the step's start (DynamicsData::t_s), for time-dependent effects
};

// Ideal sensor readings of a state; sensor effects change them.
struct SensorValues {
  Vec3 pose;           // external tracking: x_m, y_m, psi_rad
  double imu_psi_rad;  // IMU heading
  double imu_r_radps;  // IMU yaw rate
  double t_s = 0;      // time of the reading (set by the caller), for drifting sensors
  // A reading of augerd's filter, now: not a time of the log a model was fitted on, so a sensor's
  // jump fitted at such a time (imu_heading_bias's t_step_s) is past and its newest value holds.
  bool live = false;
};

class Effect {
 public:
  virtual ~Effect() = default;
  virtual const std::string& id() const = 0;
  // The parameter values in use (name, value), for reports.
  virtual std::vector<std::pair<std::string, double>> params() const = 0;

  // Per-run state (e.g. a lag) lives in the caller's workspace, `state_size()` doubles.
  virtual std::size_t state_size() const { return 0; }
  virtual void reset_state(double* /*state*/) const {}

  // eq. (7): tau_n holds sigma_scale S B omega on entry; change it in place. sigma_scale is the
  // traction of the ground under the robot now relative to the model's S (traction_scale()):
  // an effect that works on S B omega uses it, so that a change of terrain changes the
  // traction before a saturation or a dead band acts on it.
  virtual void drive_force(const Model& /*model*/, const Vec4& /*omega_rpm*/, double /*sigma_scale*/,
                           double /*dt_s*/, Vec3& /*tau_n*/, double* /*state*/) const {}
  // The ground's traction at t_s relative to the model's S (1: as the model says); the product
  // over the effects scales eq. (7) before the drive effects act.
  virtual double traction_scale(double /*t_s*/) const { return 1.0; }
  // eq. (6): body force (body frame) over the coming step, returned in force_n.
  virtual void body_force(const Model& /*model*/, const EffectContext& /*ctx*/, Vec3& force_n,
                          double* /*state*/) const {
    force_n.setZero();
  }
  // What the sensors report for the state (eta, zeta).
  virtual void sensors(const Model& /*model*/, const Vec3& /*eta*/, const Vec3& /*zeta*/,
                       SensorValues& /*values*/) const {}
  // eq. (8): the inertia of the linear dynamics, changed in place (M_diag holds m, m, I_z and
  // model.D_diag is set when make_model calls this).
  virtual void inertia(const Model& /*model*/, Vec3& /*M_diag*/) const {}
  // How much earlier than its t_s a pose row shows the robot (camera latency, two computers'
  // clocks), in s; it changes nothing in the dynamics. Read through pose_delay_s(model).
  virtual double pose_delay_s() const { return 0.0; }
  // Text parameters (name, value) for the model file, e.g. a discovered term's form.
  virtual std::vector<std::pair<std::string, std::string>> text_params() const { return {}; }

  // The force of eq. (6) the controller may feed forward (ControllerConfig::effect_feedforward):
  // the body force at the pose eta and the body velocity zeta, written to force_n; false (the
  // default, force_n untouched) for an effect whose force is not safe to anticipate: dry friction
  // (its sign at rest chatters, and at rest it is whatever holds the body), a force that depends
  // on the screw speeds the allocation is about to choose (blocking), a drive or sensor effect.
  // Parameters read through effect_param (an applied online estimate counts). Must not allocate.
  virtual bool feedforward_force(const Model& /*model*/, const Vec3& /*eta*/, const Vec3& /*zeta*/,
                                 Vec3& /*force_n*/) const {
    return false;
  }

  // Online identification (auger/online_estimator.hpp) of a parameter whose ParamSpec has
  // `online`: the part of eq. (6)'s body force that params()[index] makes is
  // online_shape(value) * online_basis(state), the basis independent of the value (a slope's
  // sin(incline) times gravity turned into the body frame, a drag coefficient times -v |v|), so
  // the estimator's regressor column is the basis's mean over its window times the shape's
  // derivative. Must not allocate (the estimator calls it every cycle).
  virtual Vec3 online_basis(const Model& /*model*/, std::size_t /*index*/, const Vec3& /*eta*/,
                            const Vec3& /*zeta*/) const {
    return Vec3::Zero();
  }
  // The shape g(value) and its derivative dg/dvalue (default: linear, g = value).
  virtual double online_shape(std::size_t /*index*/, double value, double* derivative) const {
    *derivative = 1.0;
    return value;
  }
};

// A parameter a factory accepts; required parameters have no default.
// The fields after `doc` tell the workbench how to fit the parameter (docs/workbench.md,
// "Adding an effect"): its unit, bounds, typical size (start and finite-difference scale),
// whether it is searched over integers (a screw index) and whether it is fitted at all.
struct ParamSpec {
  std::string name;
  double default_value = 0;
  bool required = false;
  std::string doc;
  std::string unit;
  double lower = -1e300, upper = 1e300;
  double typical = 1.0;
  bool integer = false;  // enumerated lower..upper by the search, not fitted by Gauss-Newton
  bool fitted = true;    // false: kept at the default while fitting
  bool log_scale = false;  // positive, fitted in log (spans decades, e.g. a force limit)
  // The physically plausible range for this robot (a 29 kg, 0.6 m robot on soil, screws of at
  // most 23 rpm): a fit outside it, or at a search bound, is flagged by the workbench.
  double physical_lower = -std::numeric_limits<double>::infinity();
  double physical_upper = std::numeric_limits<double>::infinity();
  ParamSpec& physical(double lower_value, double upper_value) {
    physical_lower = lower_value;
    physical_upper = upper_value;
    return *this;
  }
  // A form parameter (a dead band's shift and asymmetry): the workbench starts it at its default
  // and, while it is there, fits its effect's size first with it held (search_lm.cpp).
  bool form = false;
  ParamSpec& form_param() {
    form = true;
    return *this;
  }
  // The index of a parameter that must be nonzero for this one to act (a bias before a jump acts
  // only with a jump time): while that one is 0 this one is not fitted (it has no gradient).
  int acts_with = -1;
  ParamSpec& acting_with(int index) {
    acts_with = index;
    return *this;
  }
  // A model file may mark it `online = true` (augerd estimates it while driving): its effect
  // implements Effect::online_basis / online_shape for it and its physical range is finite.
  bool online = false;
  ParamSpec& estimable_online() {
    online = true;
    return *this;
  }
};

struct EffectParamValue {
  std::string name;
  double value = 0;
  int line = 0, column = 0;
  // `name = { value = 0.05, online = true }` (docs/model.md): augerd estimates it online; where
  // the `online` key stands (for the error when the parameter cannot be estimated online).
  bool online = false;
  int online_line = 0, online_column = 0;
};
struct EffectTextValue {
  std::string name;
  std::string value;
  int line = 0, column = 0;
};

// One `[[effect]]` entry of a model file.
struct EffectConfig {
  std::string id;
  std::vector<EffectParamValue> params;
  std::vector<EffectTextValue> texts;  // text parameters (Entry::text_params), e.g. a term's form
  std::string file;
  int line = 0, column = 0;
  std::string comment;  // written before the [[effect]] (write_model_file); the reader leaves it empty
};

class EffectRegistry {
 public:
  // values are in the order of the specs, defaults filled in.
  using Factory = std::function<std::shared_ptr<const Effect>(const std::vector<double>& values)>;
  struct Entry {
    std::string id;
    std::string doc;
    std::vector<ParamSpec> params;
    Factory make;
    // Plain words for fitted values, e.g. "a constant force of 15 N opposing motion along x".
    std::function<std::string(const std::vector<double>& values)> describe;
    bool needs_imu = false;  // only visible in the IMU heading channel
    // Text parameters (all required), for an effect whose kind is a text (a discovered term's
    // form): made by make_text instead of make.
    std::vector<std::string> text_params{};
    std::function<std::shared_ptr<const Effect>(const std::vector<double>& values,
                                                const std::vector<std::string>& texts)>
        make_text{};
    // Either factory, with the texts in the order of text_params.
    std::shared_ptr<const Effect> build(const std::vector<double>& values, const std::vector<std::string>& texts) const {
      return make_text ? make_text(values, texts) : make(values);
    }
  };

  void add(Entry entry);  // throws std::invalid_argument on a duplicate id
  bool has(const std::string& id) const { return entries_.count(id) != 0; }
  const std::map<std::string, Entry>& entries() const { return entries_; }
  // Throws ConfigError (file, line) on an unknown id, unknown or missing parameter, or a value
  // the factory rejects (std::invalid_argument from it).
  std::shared_ptr<const Effect> create(const EffectConfig& config) const;

  // The effects this library ships.
  static const EffectRegistry& builtin();

 private:
  std::map<std::string, Entry> entries_;
};

// Registers the library's effects into a registry (so a tool can extend a copy).
void register_builtin_effects(EffectRegistry& registry);

// "terrain_slope (incline_x_rad, incline_y_rad), quadratic_drag (...)": the parameters a model
// file may mark online, for error messages and docs.
std::string online_parameter_list(const EffectRegistry& registry);

// ---- the shipped effects ----

// Coulomb dry friction per DOF: a force of at most (force_x_n, force_y_n, torque_psi_nm)
// opposing the motion. smooth_mps 0 is the hard sign form: at rest it holds the body while the
// drive force is below it (stiction equal to the sliding level). smooth_mps > 0 is the level
// times tanh(v / smooth_mps), v the sliding speed (in yaw at the contacts): reached only once
// sliding, so a drive below it creeps instead of sticking (soil sheared slowly resists less).
// Applied implicitly over a step.
class CoulombFriction final : public Effect {
 public:
  explicit CoulombFriction(const Vec3& limit, double smooth_mps = 0.0);
  const std::string& id() const override;
  std::vector<std::pair<std::string, double>> params() const override;
  void body_force(const Model& model, const EffectContext& ctx, Vec3& force_n,
                  double* state) const override;
  const Vec3& limit() const { return limit_; }

 private:
  Vec3 limit_;
  double smooth_mps_;
};

// Dead band: a screw turning slower than its band produces no force. The band is
// omega_dead_rpm (1 + asymmetry) wide turning forward (omega > 0) and omega_dead_rpm
// (1 - asymmetry) backward. Above it the screw pushes as if it turned at
// min(|omega|, (|omega| - band) / shift): shift 1 a dead zone (omega_dead_rpm slower at every
// speed), 0 a gate (full force above the band), in between a ramp of slope 1 / shift that
// joins the nominal line at band / (1 - shift) (docs/workbench.md "`auger effects`").
class ScrewDeadBand final : public Effect {
 public:
  explicit ScrewDeadBand(double omega_dead_rpm, double shift = 0, double asymmetry = 0);
  const std::string& id() const override;
  std::vector<std::pair<std::string, double>> params() const override;
  void drive_force(const Model& model, const Vec4& omega_rpm, double sigma_scale, double dt_s, Vec3& tau_n,
                   double* state) const override;
  // The speed a screw turning at omega_rpm pushes with.
  double effective_rpm(double omega_rpm) const;

 private:
  double omega_dead_rpm_, shift_, asymmetry_;
};

// A constant IMU heading bias: the IMU reports psi + bias_rad.
// The IMU reports psi + bias_rad; with t_step_s > 0, psi + before_rad before t_step_s (log time): a
// heading that jumps once (an IMU re-initialised, a magnetic disturbance).
class ImuHeadingBias final : public Effect {
 public:
  explicit ImuHeadingBias(double bias_rad, double t_step_s = 0, double before_rad = 0);
  const std::string& id() const override;
  std::vector<std::pair<std::string, double>> params() const override;
  void sensors(const Model& model, const Vec3& eta, const Vec3& zeta,
               SensorValues& values) const override;

 private:
  double bias_rad_, t_step_s_, before_rad_;
};

// Ideal sensor readings of (eta, zeta) with the model's sensor effects applied.
void predict_sensors(const Model& model, const Vec3& eta, const Vec3& zeta, SensorValues& values);

}  // namespace auger
