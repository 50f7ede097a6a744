// The fitted effects' own curves for `auger report` (report_effect.hpp): what the model before and
// after the fit do, each evaluated through the same dynamics functions the simulation uses.
#include "report_effect.hpp"

#include <algorithm>
#include <cmath>

#include "auger/dynamics.hpp"

namespace auger::wb {
namespace {

const char* const kDofName[3] = {"x", "y", "yaw"};
const char* const kSpeedName[3] = {"body speed u (m/s)", "body speed v (m/s)", "yaw rate r (rad/s)"};
const char* const kForceUnit[3] = {"N", "N", "N m"};

double percentile_abs(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  for (double& x : v) x = std::fabs(x);
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

std::vector<double> grid(double lo, double hi, int n) {
  std::vector<double> g;
  for (int i = 0; i < n; ++i) g.push_back(lo + (hi - lo) * i / (n - 1));
  return g;
}

bool differs(const std::vector<double>& a, const std::vector<double>& b) {
  double scale = 0, diff = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    scale = std::max(scale, std::fabs(a[i]));
    diff = std::max(diff, std::fabs(a[i] - b[i]));
  }
  return diff > 1e-3 * scale + 1e-9;
}

// Resistance of eq. (6) plus the effects' body forces at body speed v along dof, screws still.
std::vector<double> resistance(const Model& m, int dof, const std::vector<double>& v, double t_s) {
  DynamicsData data(m);
  std::vector<double> f;
  for (double s : v) {
    data.reset(m);
    data.tau_drive_n.setZero();
    Vec3 zeta = Vec3::Zero();
    zeta[dof] = s;
    effect_body_force(m, data, t_s, Vec3::Zero(), zeta, Vec4::Zero(), 1e-3);
    f.push_back(-m.D_diag[dof] * s + data.tau_effect_n[dof]);
  }
  return f;
}

// Steady body speed along dof for constant screw speeds s * pattern (8 s from rest).
std::vector<double> steady_speed(const Model& m, int dof, const Vec4& pattern, const std::vector<double>& s, double t_s) {
  DynamicsData data(m);
  std::vector<double> out;
  for (double k : s) {
    data.reset(m);
    data.t_s = t_s;
    Vec3 eta = Vec3::Zero(), zeta = Vec3::Zero();
    const Vec4 omega = k * pattern;
    for (int i = 0; i < 800; ++i) dynamics_step(m, data, eta, zeta, omega, 0.01);
    out.push_back(zeta[dof]);
  }
  return out;
}

// Drive force along dof after a step of the screw speeds to omega at t = 0 (eq. (7) with the drive effects).
std::vector<double> drive_step(const Model& m, int dof, const Vec4& omega, const std::vector<double>& t) {
  DynamicsData data(m);
  data.reset(m);
  std::vector<double> out;
  Vec3 tau = Vec3::Zero();
  for (double ts : t) {
    drive_force(m, data, ts < 0 ? Vec4::Zero() : omega, 0.01, tau);
    out.push_back(tau[dof]);
  }
  return out;
}

bool has_state(const Model& m) {
  for (const auto& e : m.effects)
    if (e->state_size() > 0) return true;
  return false;
}

}  // namespace

std::vector<Chart> effect_curves(const Model& before, const Model& after, const Dataset& d) {
  std::vector<Chart> charts;
  if (d.size() == 0) return charts;
  std::vector<int> dofs;
  if (d.gantry) dofs.push_back(d.axis == "longitudinal" ? 0 : 1);
  else dofs = {0, 1, 2};
  const double t_first = d.t_s.front(), t_last = d.t_s.back();

  // The log's range of speeds: the screws' and the steady body speeds they give (99th percentile).
  std::vector<double> omega_abs;
  std::array<std::vector<double>, 3> v_ss;
  std::array<bool, 4> used{};
  for (std::size_t k = 0; k < d.size(); ++k) {
    const Vec4& w = d.omega_rpm[k];
    omega_abs.push_back(w.cwiseAbs().maxCoeff());
    for (int i = 0; i < 4; ++i) used[static_cast<std::size_t>(i)] = used[static_cast<std::size_t>(i)] || w[i] != 0;
    const Vec3 v = steady_velocity(before, w);
    for (int dof : dofs) v_ss[static_cast<std::size_t>(dof)].push_back(v[dof]);
  }
  const double omega_max = percentile_abs(omega_abs, 0.99);

  for (int dof : dofs) {
    const double vmax = 1.1 * percentile_abs(v_ss[static_cast<std::size_t>(dof)], 0.99);
    if (!(vmax > 1e-6)) continue;
    const std::vector<double> v = grid(-vmax, vmax, 161);
    const auto f0 = resistance(before, dof, v, t_last);
    const auto f_end = resistance(after, dof, v, t_last), f_start = resistance(after, dof, v, t_first);
    if (!differs(f0, f_end) && !differs(f0, f_start)) continue;
    Chart c;
    c.title = std::string("Force against speed, ") + kDofName[dof] + ": the resistance of eq. (6) and the effects' forces";
    c.xlabel = kSpeedName[dof];
    c.ylabel = std::string("force (") + kForceUnit[dof] + ")";
    c.x = v;
    c.series.push_back({"before", f0, "dashed", "#888888"});
    if (differs(f_start, f_end)) {
      c.series.push_back({"after, at the log's start", f_start, "line", "#9467bd"});
      c.series.push_back({"after, at the log's end", f_end, "line", "#2ca02c"});
    } else {
      c.series.push_back({"after (fitted)", f_end, "line", "#2ca02c"});
    }
    charts.push_back(std::move(c));
  }

  if (omega_max > 0) {
    for (int dof : dofs) {
      // The screws that push along dof: the sign pattern of S B's row (eq. (7)), screws the log drives.
      Vec4 pattern = Vec4::Zero();
      for (int i = 0; i < 4; ++i)
        if (used[static_cast<std::size_t>(i)]) pattern[i] = before.SB(dof, i);
      if (pattern.cwiseAbs().maxCoeff() <= 0) continue;
      pattern /= pattern.cwiseAbs().maxCoeff();
      const std::vector<double> s = grid(-omega_max, omega_max, 49);
      const auto v0 = steady_speed(before, dof, pattern, s, t_last), v1 = steady_speed(after, dof, pattern, s, t_last);
      if (!differs(v0, v1)) continue;
      Chart c;
      c.title = std::string("Steady ") + (dof == 2 ? "yaw rate" : "speed") + " against screw speed, " + kDofName[dof] +
                ": every screw that pushes along " + kDofName[dof] + " at the speed shown";
      c.xlabel = "screw speed (rpm)";
      c.ylabel = kSpeedName[dof];
      c.x = s;
      c.series.push_back({"before", v0, "dashed", "#888888"});
      c.series.push_back({"after (fitted)", v1, "line", "#2ca02c"});
      charts.push_back(std::move(c));
    }
  }

  if (has_state(after) && omega_max > 0) {
    const int dof = dofs.front();
    Vec4 omega = Vec4::Zero();
    for (int i = 0; i < 4; ++i)
      if (used[static_cast<std::size_t>(i)]) omega[i] = before.SB(dof, i) >= 0 ? 0.5 * omega_max : -0.5 * omega_max;
    std::vector<double> t;
    for (int i = -20; i <= 150; ++i) t.push_back(0.01 * i);
    Chart c;
    c.title = std::string("Drive force after a step of the screw speeds to ") + std::to_string(static_cast<int>(0.5 * omega_max + 0.5)) +
              " rpm at t = 0, along " + kDofName[dof] + " (eq. (7) with the drive effects)";
    c.xlabel = "time after the step (s)";
    c.ylabel = std::string("drive force (") + kForceUnit[dof] + ")";
    c.x = t;
    c.series.push_back({"before", drive_step(before, dof, omega, t), "dashed", "#888888"});
    c.series.push_back({"after (fitted)", drive_step(after, dof, omega, t), "line", "#2ca02c"});
    charts.push_back(std::move(c));
  }

  if (!d.gantry && d.active[kImuPsi]) {
    std::vector<double> t = grid(t_first, t_last, 301), b(t.size()), a(t.size());
    auto offset = [](const Model& m, double ts) {
      SensorValues s{Vec3::Zero(), 0.0, 0.0, ts};
      for (const auto& e : m.effects) e->sensors(m, Vec3::Zero(), Vec3::Zero(), s);
      return s.imu_psi_rad;
    };
    for (std::size_t i = 0; i < t.size(); ++i) b[i] = offset(before, t[i]), a[i] = offset(after, t[i]);
    if (differs(b, a)) {
      Chart c;
      c.title = "IMU heading minus the true heading over the log (the sensor effects)";
      c.xlabel = "t (s)";
      c.ylabel = "IMU heading offset (rad)";
      c.x = t;
      c.series.push_back({"before", b, "dashed", "#888888"});
      c.series.push_back({"after (fitted)", a, "line", "#2ca02c"});
      charts.push_back(std::move(c));
    }
  }
  return charts;
}

}  // namespace auger::wb
