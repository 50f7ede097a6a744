// The physical bounds of every value that enters the controller from outside: sensor messages
// (camera pose, IMU), operator commands (goal, body velocity, one screw's speed), waypoint files
// and the logs the workbench reads; and the bounds an estimate must stay within. One table, so
// that augerd's sockets, any other input path (a DDS bridge) and the tools judge a value the same
// way; docs/daemon.md "Limits and abuse" lists it. Each check returns "" when the values may be
// used, else one line naming the field, its value and the bound (no trailing newline).
#pragma once

#include <cstddef>
#include <string>

#include "auger/model.hpp"

namespace auger {

struct InputBound {
  const char* quantity;  // what the bound is about, e.g. "position"
  const char* unit;      // "m", "rad", ...
  double lo, hi;         // inclusive
  const char* why;       // where the numbers come from (docs/daemon.md quotes it)
};

namespace limits {
// Positions: UTM northings reach 1e7 m, so a camera or RTK fix in a projected frame fits; the
// EKF's squares (1e14) stay far from overflow.
inline constexpr InputBound kPosition{"position", "m", -1e7, 1e7,
                                      "UTM northings reach 1e7 m; beyond that it is not a place on Earth"};
// Headings: wrapped angles, or an IMU's unwrapped yaw after 159 turns.
inline constexpr InputBound kHeading{"heading", "rad", -1000, 1000,
                                     "an unwrapped IMU yaw after 159 turns; wrap_angle keeps full precision there"};
// Standard deviations of a camera pose: below a micrometre the EKF's gain becomes singular in
// floating point, above 100 m (10 rad) the measurement carries no information.
inline constexpr InputBound kPositionSd{"position standard deviation", "m", 1e-6, 100,
                                        "1 um .. 100 m: smaller makes the EKF gain singular, larger says nothing"};
inline constexpr InputBound kHeadingSd{"heading standard deviation", "rad", 1e-6, 10,
                                       "1 urad .. 10 rad: a heading sd above pi says nothing"};
// Yaw rate: a MEMS gyro's largest full scale, 2000 deg/s.
inline constexpr InputBound kYawRate{"yaw rate", "rad/s", -35, 35, "a MEMS gyro's 2000 deg/s full scale"};
// Linear acceleration (an accelerometer's specific force): a MEMS accelerometer's largest full
// scale, 16 g.
inline constexpr InputBound kAcceleration{"acceleration", "m/s^2", -157, 157, "a MEMS accelerometer's 16 g full scale"};
// Commanded body velocity: far above anything the screws reach (about 0.2 m/s); augerd scales
// the screw speeds down to omega_max_rpm in any case, this only keeps the products finite.
inline constexpr InputBound kBodySpeed{"body speed", "m/s", -10, 10,
                                       "50x the robot's top speed; larger is a typing error"};
inline constexpr InputBound kBodyYawRate{"body yaw rate", "rad/s", -10, 10,
                                         "50x the robot's top turn rate; larger is a typing error"};
// Screw speeds: the wire's range (int16 in 0.01 rpm, shared/protocol.h).
inline constexpr InputBound kScrewSpeed{"screw speed", "rpm", -327.67, 327.67,
                                        "the setpoint frame's range: int16 in 0.01 rpm"};
// Waypoint times, relative to the start of the motion: one day.
inline constexpr InputBound kWaypointTime{"waypoint time", "s", 0, 86400, "one day of motion"};
// Gantry traction force: 100 times what a 16 kg module can push.
inline constexpr InputBound kForce{"force", "N", -1e5, 1e5, "100x what the gantry's module can push"};
// Gantry logs' `mass_kg` (module plus load; 16 kg in the paper).
inline constexpr InputBound kGantryMass{"mass", "kg", 0.1, 1000, "a screw module with its load on the rail"};
// Log times: t_s may be a Unix time (1.7e9 s); consecutive samples at least a microsecond apart.
inline constexpr InputBound kLogTime{"log time", "s", -1e10, 1e10, "Unix times fit; beyond that is no clock"};
inline constexpr double kMinSampleStepS = 1e-6;

// Waypoint files (augerd `follow`): read off the loop, refused beyond these.
inline constexpr std::size_t kMaxWaypoints = 100000;          // 2.8 h at 10 Hz
inline constexpr std::size_t kMaxWaypointFileBytes = 8u << 20;  // 8 MiB (80 bytes a row)

// The estimate (Controller): outside these the state is absurd and latches a fault.
inline constexpr InputBound kEstimatePosition = kPosition;
inline constexpr InputBound kEstimateSpeed{"estimated speed", "m/s", -10, 10,
                                           "50x the robot's top speed: the estimate has diverged"};
inline constexpr InputBound kEstimateYawRate{"estimated yaw rate", "rad/s", -35, 35,
                                             "the gyro's full scale: the estimate has diverged"};
}  // namespace limits

// Input for an error message: quoted, control bytes and bytes that are not UTF-8 text as \xNN,
// cut after max_bytes with the full length named (a 10 MB field, a NUL byte or a stray byte
// must not come back raw). Used by every reader and by augerd's answers.
std::string quote_input(const std::string& text, std::size_t max_bytes = 60);

// v is finite and within b (no allocation: for the 100 Hz path).
inline bool within(double v, const InputBound& b) { return v >= b.lo && v <= b.hi; }  // false for NaN

// "" if v is finite and within b, else "<field> = <v> <unit> is outside lo..hi <unit> (<why>)".
std::string check_bound(const char* field, double v, const InputBound& b);

// A camera pose with its standard deviations (sensors socket `pose`, a DDS PoseWithCovariance).
std::string check_pose(double x_m, double y_m, double psi_rad, double sx_m, double sy_m, double spsi_rad);
// An IMU heading and yaw rate (sensors socket `imu`, a DDS Imu).
std::string check_imu(double psi_rad, double r_radps);
// An IMU's body-frame specific force (ax forward, ay left).
std::string check_imu_acceleration(double ax_mps2, double ay_mps2);
// A `goto` goal.
std::string check_goal(double x_m, double y_m, double psi_rad);
// A `vel` body velocity (a DDS Twist).
std::string check_velocity(double u_mps, double v_mps, double r_radps);
// A `spin` screw speed.
std::string check_screw_speed(double omega_rpm);
// One waypoint (index for the message).
std::string check_waypoint(std::size_t index, double t_s, double x_m, double y_m, double psi_rad);
// The controller's estimate: pose and body velocities finite and within the estimate bounds.
bool estimate_ok(const Vec3& eta, const Vec3& zeta);  // the same without the message
std::string check_estimate(const Vec3& eta, const Vec3& zeta);

}  // namespace auger
