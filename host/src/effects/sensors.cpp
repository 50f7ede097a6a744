// Sensor effects: what the IMU and the pose tracking report, not how the robot moves.
#include <cmath>

#include "effects.hpp"

namespace auger {
namespace effects {
namespace {

// The IMU heading drifts: it reports psi + bias_rad + drift_radps * t_s (gyro bias integrated). A
// gyro warming up settles: its bias rate decays as exp(-settle_per_s t_s), and the heading error
// ends at drift_radps / settle_per_s (an IMU heading bias that settles from bias_rad to there has
// the same form). settle_per_s = 0 is the linear drift, the limit of the settling form.
class ImuHeadingDrift final : public Effect {
 public:
  ImuHeadingDrift(double bias, double drift, double settle_per_s) : bias_(bias), drift_(drift), settle_(settle_per_s) {}
  const std::string& id() const override {
    static const std::string s = "imu_heading_drift";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override {
    return {{"bias_rad", bias_}, {"drift_radps", drift_}, {"settle_per_s", settle_}};
  }
  void sensors(const Model&, const Vec3&, const Vec3&, SensorValues& v) const override {
    // (1 - exp(-k t)) / k, and t itself at k = 0 (expm1: no cancellation at small k t).
    const double elapsed_s = settle_ > 0 ? -std::expm1(-settle_ * v.t_s) / settle_ : v.t_s;
    v.imu_psi_rad = wrap_angle(v.imu_psi_rad + bias_ + drift_ * elapsed_s);
    v.imu_r_radps += settle_ > 0 ? drift_ * std::exp(-settle_ * v.t_s) : drift_;
  }

 private:
  double bias_, drift_, settle_;
};

// The pose rows are late: a row at t shows the robot at t - offset_s (camera latency, clocks
// of two computers). It changes nothing in the dynamics; pose_delay_s(model) reports it to the
// workbench (wb::SimOptions::pose_delay_s) and the controller's EKF (Controller, PoseHistory).
class PoseTimeOffset final : public Effect {
 public:
  explicit PoseTimeOffset(double offset_s) : offset_s_(offset_s) {}
  const std::string& id() const override {
    static const std::string s = "pose_time_offset";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override { return {{"offset_s", offset_s_}}; }
  double pose_delay_s() const override { return offset_s_; }

 private:
  double offset_s_;
};

}  // namespace

void register_sensors(EffectRegistry& r) {
  EffectRegistry::Entry bias{
      "imu_heading_bias",
      "the IMU reports psi + bias_rad; with t_step_s > 0, psi + before_rad before t_step_s (a heading that jumps "
      "once: an IMU re-initialised, a magnetic disturbance)",
      {ParamSpec{"bias_rad", 0, true, "heading bias (from t_step_s on)", "rad", -3.2, 3.2, 0.02}.physical(-3.15, 3.15),
       // The jump's time is not fitted by the search's gradient steps: the workbench places it from
       // camera minus IMU heading, which needs no model (search_candidate.cpp, imu_step_start).
       ParamSpec{"t_step_s", 0, false, "time of a jump of the bias (log time; 0: none, a constant bias)", "s", 0, 1e9,
                 10, false, false}
           .physical(0, 1e9)
           .form_param(),
       ParamSpec{"before_rad", 0, false, "heading bias before t_step_s", "rad", -3.2, 3.2, 0.02}
           .physical(-3.15, 3.15)
           .form_param()
           .acting_with(1)},
      [](const std::vector<double>& v) {
        if (!std::isfinite(v[0]) || !std::isfinite(v[2])) throw std::invalid_argument("bias_rad and before_rad must be finite");
        if (!(v[1] >= 0) || !std::isfinite(v[1])) throw std::invalid_argument("t_step_s must be >= 0");
        return std::make_shared<ImuHeadingBias>(v[0], v[1], v[2]);
      },
      [](const std::vector<double>& v) {
        const std::string now = fmt(v[0]) + " rad (" + fmt(v[0] * 180 / kPi) + " deg)";
        if (!(v[1] > 0)) return "the IMU heading is off by a constant " + now + ": IMU heading bias";
        return "the IMU heading is off by " + fmt(v[2]) + " rad until t = " + fmt(v[1]) + " s, then by " + now +
               ": IMU heading bias that jumps once (re-initialised, a magnetic disturbance)";
      },
      true};
  r.add(std::move(bias));
  EffectRegistry::Entry drift{
      "imu_heading_drift",
      "the IMU reports psi + bias_rad + drift_radps t_s; with settle_per_s > 0 the drift rate decays as "
      "exp(-settle_per_s t_s) (a gyro warming up, a bias settling)",
      {ParamSpec{"bias_rad", 0, false, "heading bias at t = 0", "rad", -3.2, 3.2, 0.02}.physical(-3.15, 3.15),
       ParamSpec{"drift_radps", 0, false, "heading drift rate at t = 0", "rad/s", -0.1, 0.1, 2e-4}.physical(-0.01, 0.01),
       ParamSpec{"settle_per_s", 0, false, "decay rate of the drift (0: linear; 1 / the settling time)", "1/s", 0, 1, 0.02}
           .physical(0, 0.2)
           .form_param()},
      [](const std::vector<double>& v) {
        if (!std::isfinite(v[0]) || !std::isfinite(v[1]))
          throw std::invalid_argument("bias_rad and drift_radps must be finite");
        if (!(v[2] >= 0) || !std::isfinite(v[2])) throw std::invalid_argument("settle_per_s must be >= 0");
        return std::make_shared<ImuHeadingDrift>(v[0], v[1], v[2]);
      },
      [](const std::vector<double>& v) {
        const std::string rate = fmt(v[1] * 180 / kPi * 60) + " deg per minute";
        if (!(v[2] > 0))
          return "the IMU heading drifts by " + rate + " (offset " + fmt(v[0]) + " rad at t = 0): IMU heading drift";
        return "the IMU heading drifts by " + rate + " at t = 0, settling over " + fmt(1 / v[2]) + " s to " +
               fmt(v[0] + v[1] / v[2]) + " rad off (" + fmt(v[0]) + " rad at t = 0): IMU heading drift, settling";
      },
      true};
  r.add(std::move(drift));
  r.add({"pose_time_offset", "pose rows show the robot offset_s earlier than their t_s (latency)",
         {ParamSpec{"offset_s", 0, true, "pose latency relative to the screw speeds", "s", -1, 1, 0.05}.physical(-1, 1)},
         [](const std::vector<double>& v) {
           if (!(std::fabs(v[0]) <= 5)) throw std::invalid_argument("offset_s must be within +-5 s");
           return std::make_shared<PoseTimeOffset>(v[0]);
         },
         [](const std::vector<double>& v) {
           return "the poses are " + fmt(v[0] * 1000) + " ms late against the screw speeds: time offset between pose and screw speeds";
         }});
}

}  // namespace effects
}  // namespace auger
