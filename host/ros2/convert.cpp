#include "convert.hpp"

#include <cmath>

namespace auger::ros2 {

double stamp_to_unix_s(int32_t sec, uint32_t nanosec) { return double(sec) + 1e-9 * double(nanosec); }

void unix_s_to_stamp(double t_s, int32_t& sec, uint32_t& nanosec) {
  double whole = std::floor(t_s);
  long long ns = std::llround((t_s - whole) * 1e9);
  if (ns >= 1000000000LL) ns -= 1000000000LL, whole += 1;
  sec = int32_t(whole);
  nanosec = uint32_t(ns);
}

bool yaw_from_quaternion(double x, double y, double z, double w, double& yaw_rad, std::string& why) {
  const double n = std::sqrt(x * x + y * y + z * z + w * w);
  if (!std::isfinite(n)) {
    why = "orientation is not finite";
    return false;
  }
  if (std::fabs(n - 1.0) > 0.1) {
    why = "orientation is not a unit quaternion (norm " + std::to_string(n) + ")";
    return false;
  }
  x /= n, y /= n, z /= n, w /= n;
  yaw_rad = std::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
  return true;
}

void quaternion_from_yaw(double yaw_rad, double q[4]) {
  q[0] = 0;
  q[1] = 0;
  q[2] = std::sin(0.5 * yaw_rad);
  q[3] = std::cos(0.5 * yaw_rad);
}

void odometry_covariance(const double cov[36], double pose_cov[36], double twist_cov[36]) {
  // State index -> index in the message's 6-vector: x -> x, y -> y, psi -> rot Z (5); the same
  // for u, v, r in the twist.
  static const int to_msg[3] = {0, 1, 5};
  for (int i = 0; i < 36; ++i) pose_cov[i] = twist_cov[i] = 0;
  for (int k : {2, 3, 4}) pose_cov[k * 6 + k] = twist_cov[k * 6 + k] = kNotEstimatedVariance;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      pose_cov[to_msg[i] * 6 + to_msg[j]] = cov[i * 6 + j];
      twist_cov[to_msg[i] * 6 + to_msg[j]] = cov[(i + 3) * 6 + (j + 3)];
    }
}

}  // namespace auger::ros2
