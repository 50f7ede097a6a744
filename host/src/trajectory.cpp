// Reference generation, eq. (18) (stable form).
#include "auger/trajectory.hpp"

#include <cmath>
#include <fstream>
#include <stdexcept>

#include "auger/log.hpp"

namespace auger {

void reference_reset(ReferenceState& ref, const Vec3& eta) {
  ref.eta_d = eta;
  ref.eta_d_dot.setZero();
  ref.eta_d_ddot.setZero();
}

void reference_step(const Vec3& gamma, ReferenceState& ref, const Vec3& eta_p_in, double dt) {
  Vec3 eta_p = eta_p_in;
  eta_p.z() = ref.eta_d.z() + wrap_angle(eta_p_in.z() - ref.eta_d.z());
  for (int k = 0; k < 3; ++k) {
    const double g = gamma[k];
    const double e0 = ref.eta_d[k] - eta_p[k];
    const double ed0 = ref.eta_d_dot[k];
    // Critically damped: e(t) = (e0 + (ed0 + g e0) t) exp(-g t), the exact solution of
    // e_dd = -g^2 e - 2 g e_d (eq. (18), stable form) for a held set-point.
    const double c = ed0 + g * e0;
    const double ex = std::exp(-g * dt);
    const double e = (e0 + c * dt) * ex;
    const double ed = (ed0 - g * c * dt) * ex;
    ref.eta_d[k] = eta_p[k] + e;
    ref.eta_d_dot[k] = ed;
    ref.eta_d_ddot[k] = -g * g * e - 2.0 * g * ed;  // eq. (18)
  }
}

int active_waypoint(const std::vector<Waypoint>& w, double t_s, int hint) {
  int i = hint < 0 ? -1 : hint;
  if (i >= static_cast<int>(w.size()) || (i >= 0 && w[static_cast<std::size_t>(i)].t_s > t_s)) i = -1;
  while (i + 1 < static_cast<int>(w.size()) && w[static_cast<std::size_t>(i + 1)].t_s <= t_s) ++i;
  return i;
}

void check_waypoints(const std::vector<Waypoint>& w) {
  for (std::size_t i = 0; i < w.size(); ++i) {
    if (!w[i].eta_p.allFinite() || !std::isfinite(w[i].t_s))
      throw std::invalid_argument("waypoint " + std::to_string(i) + " is not finite");
    if (i && !(w[i].t_s > w[i - 1].t_s))
      throw std::invalid_argument("waypoint times must increase strictly (waypoint " + std::to_string(i) + ")");
  }
}

std::vector<Waypoint> read_waypoints_csv(std::istream& in, const std::string& name, std::size_t max_rows) {
  CsvLogReader csv(in, name);
  csv.require_columns({"t_s", "x_m", "y_m", "psi_rad"});
  const int cols[3] = {csv.column_index("x_m"), csv.column_index("y_m"), csv.column_index("psi_rad")};
  std::vector<Waypoint> w;
  while (csv.next()) {
    if (w.size() >= max_rows)
      throw LogError(name, csv.line(), 1, "more than " + std::to_string(max_rows) + " waypoints");
    Waypoint p;
    p.t_s = csv.t_s();
    for (int k = 0; k < 3; ++k) {
      p.eta_p[k] = csv.value(cols[k]);
      if (!measured(p.eta_p[k])) csv.fail_at_field(cols[k], "waypoint needs a number, got '" + csv.field_text(cols[k]) + "'");
    }
    w.push_back(p);
  }
  return w;
}

std::vector<Waypoint> load_waypoints_csv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw LogError(path, 0, 0, "cannot open waypoint file");
  return read_waypoints_csv(in, path);
}

}  // namespace auger
