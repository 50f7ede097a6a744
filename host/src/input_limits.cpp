// The bounds table and its checks (input_limits.hpp).
#include "auger/input_limits.hpp"

#include <algorithm>
#include <cstdio>

namespace auger {
namespace {

std::string number_text(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

// The first failing check's message, or "".
std::string first(std::initializer_list<std::string> messages) {
  for (const auto& m : messages)
    if (!m.empty()) return m;
  return "";
}

}  // namespace

std::string quote_input(const std::string& s, std::size_t max_bytes) {
  std::string q = "'";
  const std::size_t n = std::min(s.size(), max_bytes);
  for (std::size_t i = 0; i < n; ++i) {
    const auto ch = static_cast<unsigned char>(s[i]);
    if (ch < 0x20 || ch == 0x7f) {
      char b[8];
      std::snprintf(b, sizeof b, "\\x%02x", ch);
      q += b;
    } else {
      q += static_cast<char>(ch);
    }
  }
  q += "'";
  if (s.size() > max_bytes) q += "... (" + std::to_string(s.size()) + " bytes)";
  return q;
}

std::string check_bound(const char* field, double v, const InputBound& b) {
  if (within(v, b)) return "";
  return std::string(field) + " = " + number_text(v) + " " + b.unit + " is outside " + number_text(b.lo) + ".." +
         number_text(b.hi) + " " + b.unit + " (" + b.why + ")";
}

std::string check_pose(double x_m, double y_m, double psi_rad, double sx_m, double sy_m, double spsi_rad) {
  using namespace limits;
  return first({check_bound("x_m", x_m, kPosition), check_bound("y_m", y_m, kPosition),
                check_bound("psi_rad", psi_rad, kHeading), check_bound("sx_m", sx_m, kPositionSd),
                check_bound("sy_m", sy_m, kPositionSd), check_bound("spsi_rad", spsi_rad, kHeadingSd)});
}

std::string check_imu(double psi_rad, double r_radps) {
  return first({check_bound("psi_rad", psi_rad, limits::kHeading), check_bound("r_radps", r_radps, limits::kYawRate)});
}

std::string check_goal(double x_m, double y_m, double psi_rad) {
  using namespace limits;
  return first({check_bound("x_m", x_m, kPosition), check_bound("y_m", y_m, kPosition),
                check_bound("psi_rad", psi_rad, kHeading)});
}

std::string check_velocity(double u_mps, double v_mps, double r_radps) {
  using namespace limits;
  return first({check_bound("u_mps", u_mps, kBodySpeed), check_bound("v_mps", v_mps, kBodySpeed),
                check_bound("r_radps", r_radps, kBodyYawRate)});
}

std::string check_screw_speed(double omega_rpm) { return check_bound("omega_rpm", omega_rpm, limits::kScrewSpeed); }

std::string check_waypoint(std::size_t index, double t_s, double x_m, double y_m, double psi_rad) {
  const std::string e = first({check_bound("t_s", t_s, limits::kWaypointTime), check_goal(x_m, y_m, psi_rad)});
  return e.empty() ? e : "waypoint " + std::to_string(index) + ": " + e;
}

bool estimate_ok(const Vec3& eta, const Vec3& zeta) {
  using namespace limits;
  return within(eta[0], kEstimatePosition) && within(eta[1], kEstimatePosition) && within(eta[2], kHeading) &&
         within(zeta[0], kEstimateSpeed) && within(zeta[1], kEstimateSpeed) && within(zeta[2], kEstimateYawRate);
}

std::string check_estimate(const Vec3& eta, const Vec3& zeta) {
  using namespace limits;
  return first({check_bound("estimated x_m", eta[0], kEstimatePosition),
                check_bound("estimated y_m", eta[1], kEstimatePosition),
                check_bound("estimated psi_rad", eta[2], kHeading),
                check_bound("estimated u_mps", zeta[0], kEstimateSpeed),
                check_bound("estimated v_mps", zeta[1], kEstimateSpeed),
                check_bound("estimated r_radps", zeta[2], kEstimateYawRate)});
}

}  // namespace auger
