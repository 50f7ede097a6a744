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

namespace {
// The length of the well-formed UTF-8 sequence starting at s[i] within n bytes (RFC 3629: no
// overlong forms, no surrogates, at most U+10FFFF); 0 when there is none.
std::size_t utf8_sequence(const std::string& s, std::size_t i, std::size_t n) {
  const auto b = [&](std::size_t k) { return static_cast<unsigned char>(s[i + k]); };
  const unsigned char c = b(0);
  std::size_t len = 0;
  unsigned char lo = 0x80, hi = 0xbf;  // the second byte's range
  if (c >= 0xc2 && c <= 0xdf) len = 2;
  else if (c >= 0xe0 && c <= 0xef) len = 3, lo = c == 0xe0 ? 0xa0 : 0x80, hi = c == 0xed ? 0x9f : 0xbf;
  else if (c >= 0xf0 && c <= 0xf4) len = 4, lo = c == 0xf0 ? 0x90 : 0x80, hi = c == 0xf4 ? 0x8f : 0xbf;
  else return 0;
  if (i + len > n || b(1) < lo || b(1) > hi) return 0;
  for (std::size_t k = 2; k < len; ++k)
    if (b(k) < 0x80 || b(k) > 0xbf) return 0;
  return len;
}
}  // namespace

std::string quote_input(const std::string& s, std::size_t max_bytes) {
  // Printable: control bytes and bytes that are not UTF-8 text (a terminal or a log reader
  // would misread them) become \xNN.
  std::string q = "'";
  const std::size_t n = std::min(s.size(), max_bytes);
  for (std::size_t i = 0; i < n;) {
    const auto ch = static_cast<unsigned char>(s[i]);
    const std::size_t len = ch < 0x80 ? (ch < 0x20 || ch == 0x7f ? 0 : 1) : utf8_sequence(s, i, n);
    if (len == 0) {
      char b[8];
      std::snprintf(b, sizeof b, "\\x%02x", ch);
      q += b;
      ++i;
    } else {
      q.append(s, i, len);
      i += len;
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

std::string check_imu_acceleration(double ax_mps2, double ay_mps2) {
  return first({check_bound("ax_mps2", ax_mps2, limits::kAcceleration), check_bound("ay_mps2", ay_mps2, limits::kAcceleration)});
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
