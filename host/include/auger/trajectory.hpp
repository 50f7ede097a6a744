// Reference generation, eq. (18) in the stable critically damped form of docs/model-notes.md:
// eta_d_dd = gamma^2 (eta_p - eta_d) - 2 gamma eta_d_dot, per DOF, from piecewise-constant
// set-points eta_p (waypoints, or a CSV file). Stepped exactly (closed form for a held set-point).
#pragma once

#include <istream>
#include <string>
#include <vector>

#include "auger/model.hpp"

namespace auger {

// From t_s on (relative to the trajectory's start), the set-point is eta_p.
struct Waypoint {
  double t_s = 0;
  Vec3 eta_p = Vec3::Zero();  // x_m, y_m, psi_rad (world)
};

struct ReferenceState {
  Vec3 eta_d = Vec3::Zero();       // heading kept continuous (not wrapped)
  Vec3 eta_d_dot = Vec3::Zero();
  Vec3 eta_d_ddot = Vec3::Zero();
};

// gamma per DOF in 1/s (docs/model-notes.md decision: 0.1 by default).
inline Vec3 default_gamma_per_s() { return Vec3::Constant(0.1); }

// Starts at rest at eta.
void reference_reset(ReferenceState& ref, const Vec3& eta);

// eq. (18), stable form, exactly over dt_s with eta_p held. The heading set-point is taken on
// the turn shorter than pi from the current reference heading.
void reference_step(const Vec3& gamma_per_s, ReferenceState& ref, const Vec3& eta_p, double dt_s);

// Index of the waypoint active at t_s (the last with t <= t_s), or -1 before the first. Starting
// the search at hint (the previous answer) keeps a step O(1).
int active_waypoint(const std::vector<Waypoint>& waypoints, double t_s, int hint = -1);

// Waypoints must have strictly increasing times; throws std::invalid_argument otherwise.
void check_waypoints(const std::vector<Waypoint>& waypoints);

// Reads waypoints from a CSV in the log conventions (docs/log-format.md): `#` lines, a header
// with t_s, x_m, y_m, psi_rad (any order, other columns ignored). Throws LogError, also at the
// row beyond max_rows.
std::vector<Waypoint> load_waypoints_csv(const std::string& path);
std::vector<Waypoint> read_waypoints_csv(std::istream& in, const std::string& name,
                                         std::size_t max_rows = static_cast<std::size_t>(-1));

}  // namespace auger
