// Conversions between ROS 2 message conventions and augerd's quantities (REP-103: x forward,
// y left, z up, yaw counter-clockwise; docs/ros2.md). Pure functions, no DDS.
#pragma once

#include <cstdint>
#include <string>

namespace auger::ros2 {

// builtin_interfaces/Time <-> seconds since the Unix epoch (ROS time is the system clock).
double stamp_to_unix_s(int32_t sec, uint32_t nanosec);
void unix_s_to_stamp(double t_s, int32_t& sec, uint32_t& nanosec);

// The heading (rotation about z) of an orientation, for a robot on the ground: yaw of the
// z-y-x Euler angles. A quaternion whose norm is not within 10 % of 1 (all zeros: a message
// never filled in) is refused: false, and why.
bool yaw_from_quaternion(double x, double y, double z, double w, double& yaw_rad, std::string& why);
// Rotation about z by yaw: x, y, z, w.
void quaternion_from_yaw(double yaw_rad, double q[4]);

// Variance given for what a planar estimate does not estimate (z, roll, pitch and their rates):
// large, so that a 3-D filter fusing the Odometry does not take them as known.
constexpr double kNotEstimatedVariance = 1e6;
// The estimator's 6x6 covariance over [x, y, psi, u, v, r] (row-major) to nav_msgs/Odometry's
// two 6x6 blocks over (x, y, z, rot X, rot Y, rot Z) for the pose and (vx, vy, vz, wx, wy, wz)
// for the twist (the cross block between pose and velocity has no place in the message).
void odometry_covariance(const double cov[36], double pose_cov[36], double twist_cov[36]);

}  // namespace auger::ros2
