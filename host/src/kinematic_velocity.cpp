// The terrain-free velocity of kinematic_velocity.hpp.
#include "auger/kinematic_velocity.hpp"

#include <algorithm>
#include <cmath>

namespace auger {

namespace {
constexpr double kUnknown = 1e6;  // prior variance where nothing is known
// The heading innovation on the circle.
double wrap(double a) { return std::remainder(a, 2.0 * M_PI); }
}  // namespace

KinematicVelocity::KinematicVelocity(const KinematicVelocityConfig& config) : cfg_(config) { reset(Vec3::Zero()); }

void KinematicVelocity::reset(const Vec3& eta) {
  sx_ << eta.x(), 0, 0;
  sy_ << eta.y(), 0, 0;
  Px_ = Mat3k::Identity() * kUnknown;
  Py_ = Px_;
  sp_ << eta.z(), 0;
  Pp_ = Eigen::Matrix2d::Identity() * kUnknown;
  have_pose_ = false;
  zeta_ = Vec3::Constant(NAN);
}

void KinematicVelocity::predict_axis(Vec3k& s, Mat3k& P, double dt) const {
  Mat3k F;
  F << 1, dt, 0.5 * dt * dt, 0, 1, dt, 0, 0, 1;
  // White jerk of spectral density q, integrated exactly over dt.
  const double q = cfg_.jerk_sd * cfg_.jerk_sd, d2 = dt * dt, d3 = d2 * dt, d4 = d3 * dt, d5 = d4 * dt;
  Mat3k Q;
  Q << d5 / 20, d4 / 8, d3 / 6, d4 / 8, d3 / 3, d2 / 2, d3 / 6, d2 / 2, dt;
  s = F * s;
  P = F * P * F.transpose() + q * Q;
}

const Vec3& KinematicVelocity::step(const SensorInput& sensors, double dt_s) {
  predict_axis(sx_, Px_, dt_s);
  predict_axis(sy_, Py_, dt_s);
  Eigen::Matrix2d F;
  F << 1, dt_s, 0, 1;
  Eigen::Matrix2d Q;
  const double qa = cfg_.yaw_accel_sd * cfg_.yaw_accel_sd;
  Q << dt_s * dt_s * dt_s / 3, dt_s * dt_s / 2, dt_s * dt_s / 2, dt_s;
  sp_ = F * sp_;
  Pp_ = F * Pp_ * F.transpose() + qa * Q;
  if (sensors.has_pose && std::isfinite(sensors.pose.x()) && std::isfinite(sensors.pose.y())) {
    // Scalar position updates: H = [1 0 0].
    auto update = [](Vec3k& s, Mat3k& P, double z, double r) {
      const double S = P(0, 0) + r;
      const Vec3k K = P.col(0) / S;
      s += K * (z - s(0));
      P -= K * P.row(0);
    };
    update(sx_, Px_, sensors.pose.x(), sensors.pose_cov(0, 0));
    update(sy_, Py_, sensors.pose.y(), sensors.pose_cov(1, 1));
    have_pose_ = true;
    pose_age_s_ = 0;
  } else {
    pose_age_s_ += dt_s;
  }
  // Heading measurements (H = [1 0], on the circle) and the rate (H = [0 1]).
  auto heading = [this](double z, double r) {
    const double S = Pp_(0, 0) + r;
    const Eigen::Vector2d K = Pp_.col(0) / S;
    sp_ += K * wrap(z - sp_(0));
    Pp_ -= K * Pp_.row(0);
  };
  if (sensors.has_pose && std::isfinite(sensors.pose.z())) heading(sensors.pose.z(), sensors.pose_cov(2, 2));
  if (sensors.has_imu_psi && std::isfinite(sensors.imu_psi_rad)) heading(sensors.imu_psi_rad, cfg_.imu_psi_sd * cfg_.imu_psi_sd);
  if (sensors.has_imu_r && std::isfinite(sensors.imu_r_radps)) {
    const double S = Pp_(1, 1) + cfg_.imu_r_sd * cfg_.imu_r_sd;
    const Eigen::Vector2d K = Pp_.col(1) / S;
    sp_ += K * (sensors.imu_r_radps - sp_(1));
    Pp_ -= K * Pp_.row(1);
  }
  if (have_pose_ && pose_age_s_ <= cfg_.max_pose_age_s + 1e-9) {
    // eq. (1) turned back: body = R(psi)^T world.
    const double c = std::cos(sp_(0)), s = std::sin(sp_(0));
    zeta_ << c * sx_(1) + s * sy_(1), -s * sx_(1) + c * sy_(1), sp_(1);
  } else {
    zeta_.setConstant(NAN);
  }
  return zeta_;
}

Vec3 KinematicVelocity::body_velocity_sd() const {
  const double v = std::sqrt(std::max(Px_(1, 1), Py_(1, 1)));
  return Vec3(v, v, std::sqrt(Pp_(1, 1)));
}

}  // namespace auger
