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
  si_.setZero();
  Pi_.setZero();
  ins_on_ = false;
  acc_age_s_ = 0;
  last_acc_.setZero();
  pose_var_.setZero();
  have_pose_ = false;
  zeta_ = Vec3::Constant(NAN);
}

void KinematicVelocity::start_inertial() {
  si_ << sx_(0), sx_(1), sy_(0), sy_(1), 0, 0, 0, 0, 0, 0;
  Pi_.setZero();
  Pi_.block<2, 2>(0, 0) = Px_.block<2, 2>(0, 0);
  Pi_.block<2, 2>(2, 2) = Py_.block<2, 2>(0, 0);
  Pi_(4, 4) = Pi_(5, 5) = cfg_.acc_bias_sd_mps2 * cfg_.acc_bias_sd_mps2;
  if (coloured()) Pi_(6, 6) = pose_var_.x(), Pi_(7, 7) = pose_var_.y();  // stationary
  Pi_(8, 8) = Pi_(9, 9) = cfg_.acc_gravity_sd_mps2 * cfg_.acc_gravity_sd_mps2;
  ins_on_ = true;
}

void KinematicVelocity::step_inertial(const SensorInput& sensors, bool pose_ok, double dt) {
  // The world acceleration R(psi) (f - b) + g (eq. (1)'s rotation), held over the cycle: the
  // accelerometer reads the acceleration less gravity's part along the ground, g, which on a
  // plane is constant in the world frame, while the bias b is constant in the body's: a turn
  // tells them apart (a slope read as bias would follow a turn only at the bias's walk).
  const double c = std::cos(sp_(0)), sn = std::sin(sp_(0));
  const double fx = last_acc_.x() - si_(4), fy = last_acc_.y() - si_(5);
  const double ax = c * fx - sn * fy + si_(8), ay = sn * fx + c * fy + si_(9), h2 = 0.5 * dt * dt;
  si_(0) += si_(1) * dt + h2 * ax;
  si_(1) += ax * dt;
  si_(2) += si_(3) * dt + h2 * ay;
  si_(3) += ay * dt;
  MatNk F = MatNk::Identity();
  F(0, 1) = F(2, 3) = dt;
  F(0, 8) = F(2, 9) = h2, F(1, 8) = F(3, 9) = dt;
  // d(R (f - b)) / db = -R
  F(0, 4) = -h2 * c, F(0, 5) = h2 * sn, F(1, 4) = -dt * c, F(1, 5) = dt * sn;
  F(2, 4) = -h2 * sn, F(2, 5) = -h2 * c, F(3, 4) = -dt * sn, F(3, 5) = -dt * c;
  // The accelerometer's white noise integrated exactly into velocity and position per axis
  // (isotropic, so the rotation leaves it), and the bias's random walk.
  const double qa = cfg_.acc_noise_mps2_per_sqrt_hz * cfg_.acc_noise_mps2_per_sqrt_hz;
  const double qb = cfg_.acc_bias_walk_mps2_per_sqrt_s * cfg_.acc_bias_walk_mps2_per_sqrt_s;
  MatNk Q = MatNk::Zero();
  for (int i : {0, 2}) {
    Q(i, i) = qa * dt * dt * dt / 3;
    Q(i, i + 1) = Q(i + 1, i) = qa * h2;
    Q(i + 1, i + 1) = qa * dt;
  }
  Q(4, 4) = Q(5, 5) = qb * dt;
  Q(8, 8) = Q(9, 9) = cfg_.acc_gravity_walk_mps2_per_sqrt_s * cfg_.acc_gravity_walk_mps2_per_sqrt_s * dt;
  if (coloured()) {
    // The camera's error decays as exp(-dt / tau) and is renewed to keep its variance (its
    // exact discretisation, as sim/robot/sensors.cpp draws it).
    const double a = std::exp(-dt / cfg_.pose_noise_corr_s);
    F(6, 6) = F(7, 7) = a;
    si_.segment<2>(6) *= a;
    Q(6, 6) = (1 - a * a) * pose_var_.x();
    Q(7, 7) = (1 - a * a) * pose_var_.y();
  }
  Pi_ = F * Pi_ * F.transpose() + Q;
  if (!pose_ok) return;
  // Scalar position updates z = p + c + w, H = e_0 + e_6 (x) and e_2 + e_7 (y): with coloured
  // noise w is a hundredth of the variance (keeps S away from 0), else all of it and c stays 0.
  auto update = [this](int i, int j, double z, double var) {
    const double r = coloured() ? 0.01 * var : var;
    const double S = Pi_(i, i) + 2 * Pi_(i, j) + Pi_(j, j) + r;
    const VecNk K = (Pi_.col(i) + Pi_.col(j)) / S;
    si_ += K * (z - si_(i) - si_(j));
    Pi_ -= K * (Pi_.row(i) + Pi_.row(j));
  };
  update(0, 6, sensors.pose.x(), sensors.pose_cov(0, 0));
  update(2, 7, sensors.pose.y(), sensors.pose_cov(1, 1));
  // Hours at 100 Hz: keep the covariance symmetric against rounding (fixed size: no allocation).
  Pi_ = (0.5 * (Pi_ + Pi_.transpose())).eval();
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
  const bool pose_ok = sensors.has_pose && std::isfinite(sensors.pose.x()) && std::isfinite(sensors.pose.y());
  if (pose_ok) {
    pose_var_ = Eigen::Vector2d(sensors.pose_cov(0, 0), sensors.pose_cov(1, 1));
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
  // The accelerometer's filter runs beside the constant-acceleration one (which it starts from and
  // falls back to); a sample missing for up to kAccHoldS is bridged with the last one.
  constexpr double kAccHoldS = 0.05;
  const bool acc = cfg_.use_accelerometer && sensors.has_imu_acc && std::isfinite(sensors.imu_ax_mps2) &&
                   std::isfinite(sensors.imu_ay_mps2);
  if (acc) last_acc_ = Eigen::Vector2d(sensors.imu_ax_mps2, sensors.imu_ay_mps2);
  acc_age_s_ = acc ? 0 : acc_age_s_ + dt_s;
  if (ins_on_ && acc_age_s_ > kAccHoldS + 1e-9) ins_on_ = false;
  if (ins_on_)
    step_inertial(sensors, pose_ok, dt_s);
  else if (acc && have_pose_)
    start_inertial();
  // eq. (1) turned back: body = R(psi)^T world.
  const double c = std::cos(sp_(0)), s = std::sin(sp_(0));
  if (ins_on_ && have_pose_ && pose_age_s_ <= cfg_.max_pose_age_acc_s + 1e-9) {
    zeta_ << c * si_(1) + s * si_(3), -s * si_(1) + c * si_(3), sp_(1);
  } else if (have_pose_ && pose_age_s_ <= cfg_.max_pose_age_s + 1e-9) {
    zeta_ << c * sx_(1) + s * sy_(1), -s * sx_(1) + c * sy_(1), sp_(1);
  } else {
    zeta_.setConstant(NAN);
  }
  return zeta_;
}

Vec3 KinematicVelocity::body_velocity_sd() const {
  const double v = ins_on_ ? std::sqrt(std::max(Pi_(1, 1), Pi_(3, 3))) : std::sqrt(std::max(Px_(1, 1), Py_(1, 1)));
  return Vec3(v, v, std::sqrt(Pp_(1, 1)));
}

}  // namespace auger
