// The fitted effects' own curves for `auger report` (report_effect.hpp): what the model before and
// after the fit do, each evaluated through the same dynamics functions the simulation uses.
#include "report_effect.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

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

// The model without one effect (its own chart draws it; state sizes follow from the copy's effects).
Model without(const Model& m, const std::string& id) {
  Model c = m;
  c.effects.erase(std::remove_if(c.effects.begin(), c.effects.end(), [&](const auto& e) { return e->id() == id; }),
                  c.effects.end());
  return c;
}

bool has_effect(const Model& m, const std::string& id) {
  for (const auto& e : m.effects)
    if (e->id() == id) return true;
  return false;
}

// Steady drive force of screw i alone at each speed of s, along dof and signed so that the screw's
// forward turning pushes forward (eq. (7) with the drive effects, 3 s after the step: a lag settled).
std::vector<double> screw_force(const Model& m, int i, int dof, const std::vector<double>& s, double t_s) {
  DynamicsData data(m);
  const double sign = m.SB(dof, i) >= 0 ? 1.0 : -1.0;
  std::vector<double> out;
  for (double w : s) {
    data.reset(m);
    Vec4 omega = Vec4::Zero();
    omega[i] = w;
    Vec3 tau = Vec3::Zero();
    for (int k = 0; k < 300; ++k) drive_force(m, data, omega, 0.01, tau, t_s);
    out.push_back(sign * tau[dof]);
  }
  return out;
}

// The effects' body force against a motion along x of 0.2 m/s (enough that a blocked screw's dry
// resistance, not the stopping of the motion, bounds it) with screw i at each speed of s and the
// others turning at `others` rpm: a screw's blocking against its own speed.
std::vector<double> blocking_force(const Model& m, int i, const std::vector<double>& s, double others, double t_s) {
  DynamicsData data(m);
  std::vector<double> out;
  for (double w : s) {
    data.reset(m);
    data.tau_drive_n.setZero();
    Vec4 omega = Vec4::Constant(others);
    omega[i] = w;
    effect_body_force(m, data, t_s, Vec3::Zero(), Vec3(0.2, 0, 0), omega, 0.01);
    out.push_back(-data.tau_effect_n[0]);
  }
  return out;
}

// "screw 2", "screws 0, 1, 3"
std::string screws_text(const std::vector<int>& screws) {
  std::string s = screws.size() == 1 ? "screw" : "screws";
  for (std::size_t k = 0; k < screws.size(); ++k) s += (k ? ", " : " ") + std::to_string(screws[k]);
  return s;
}

// Each screw's drive force against its own speed, before and after: screws with one curve share a
// line, and a screw the fit left as it was is not drawn again (a one-screw traction loss is one
// line beside the others').
void per_screw_chart(const Model& before, const Model& after, int dof, double omega_max, double t_s,
                     const std::array<bool, 4>& used, std::vector<Chart>& charts) {
  const std::vector<double> s = grid(-omega_max, omega_max, 97);
  std::vector<std::vector<double>> b(4), a(4);
  bool any = false;
  for (int i = 0; i < 4; ++i) {
    if (!used[static_cast<std::size_t>(i)]) continue;
    b[i] = screw_force(before, i, dof, s, t_s);
    a[i] = screw_force(after, i, dof, s, t_s);
    any = any || differs(b[i], a[i]);
  }
  if (!any) return;
  Chart c;
  c.title = std::string("Drive force of each screw against its own speed, along ") + kDofName[dof] +
            " (eq. (7) with the drive effects, the screw alone, steady)";
  c.xlabel = "screw speed (rpm)";
  c.ylabel = std::string("drive force (") + kForceUnit[dof] + ")";
  c.x = s;
  // Groups of screws with the same curve.
  auto add_groups = [&](const std::vector<std::vector<double>>& curves, const char* what, const char* style,
                        const char* color, bool only_changed) {
    std::array<bool, 4> done{};
    for (int i = 0; i < 4; ++i) {
      if (curves[i].empty() || done[static_cast<std::size_t>(i)]) continue;
      if (only_changed && !differs(b[i], a[i])) continue;
      std::vector<int> same;
      for (int j = i; j < 4; ++j)
        if (!curves[j].empty() && !done[static_cast<std::size_t>(j)] && !differs(curves[i], curves[j]) &&
            (!only_changed || differs(b[j], a[j])))
          same.push_back(j), done[static_cast<std::size_t>(j)] = true;
      c.series.push_back({std::string(what) + ", " + screws_text(same), curves[i], style, color});
    }
  };
  add_groups(b, "before", "dashed", "#888888", false);
  add_groups(a, "after", "line", "#2ca02c", true);
  // Distinct colours when several after-lines are drawn (one per group of screws).
  static const char* const kScrewColour[] = {"#2ca02c", "#d62728", "#9467bd", "#17becf"};
  int n = 0;
  for (auto& sr : c.series)
    if (sr.style == "line") sr.color = kScrewColour[n++ % 4];
  charts.push_back(std::move(c));
}

// A chart of one curve before (dashed) and after the fit.
Chart before_after(std::string title, std::string xlabel, std::string ylabel, std::vector<double> x,
                   std::vector<double> before, std::vector<double> after) {
  Chart c;
  c.title = std::move(title);
  c.xlabel = std::move(xlabel);
  c.ylabel = std::move(ylabel);
  c.x = std::move(x);
  c.series.push_back({"before", std::move(before), "dashed", "#888888"});
  c.series.push_back({"after (fitted)", std::move(after), "line", "#2ca02c"});
  return c;
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

  // A blocked screw's resistance depends on its own speed, not the body's: it has its own chart
  // below, and with the screws still (as here) it would read as a dry friction of all four.
  const bool blocking = has_effect(before, "screw_blocking") || has_effect(after, "screw_blocking");
  const Model before_r = without(before, "screw_blocking"), after_r = without(after, "screw_blocking");
  for (int dof : dofs) {
    const double vmax = 1.1 * percentile_abs(v_ss[static_cast<std::size_t>(dof)], 0.99);
    if (!(vmax > 1e-6)) continue;
    const std::vector<double> v = grid(-vmax, vmax, 161);
    const auto f0 = resistance(before_r, dof, v, t_last);
    const auto f_end = resistance(after_r, dof, v, t_last), f_start = resistance(after_r, dof, v, t_first);
    if (!differs(f0, f_end) && !differs(f0, f_start)) continue;
    Chart c;
    c.title = std::string("Force against speed, ") + kDofName[dof] + ": the resistance of eq. (6) and the effects' forces" +
              (blocking ? " (screw blocking: its own chart)" : "");
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
      charts.push_back(before_after(std::string("Steady ") + (dof == 2 ? "yaw rate" : "speed") + " against screw speed, " +
                                        kDofName[dof] + ": every screw that pushes along " + kDofName[dof] +
                                        " at the speed shown",
                                    "screw speed (rpm)", kSpeedName[dof], s, v0, v1));
    }
  }

  if (omega_max > 0) per_screw_chart(before, after, dofs.front(), omega_max, t_last, used, charts);

  if (blocking && !d.gantry) {
    // Screw 0 near standstill, the others turning well above any blocking speed.
    double w_block = 1.5;
    for (const auto& e : after.effects)
      if (e->id() == "screw_blocking")
        for (const auto& [name, value] : e->params())
          if (name == "omega_block_rpm") w_block = value;
    const std::vector<double> s = grid(-4 * w_block, 4 * w_block, 161);
    const double others = std::max(10 * w_block, omega_max);
    const auto b = blocking_force(before, 0, s, others, t_last), a = blocking_force(after, 0, s, others, t_last);
    if (differs(b, a))
      charts.push_back(before_after("Screw blocking: the resistance to a motion along x (0.2 m/s) against one screw's "
                                    "speed, the others turning at " + std::to_string(static_cast<int>(others + 0.5)) +
                                        " rpm (the same for every screw)",
                                    "speed of the one screw (rpm)", "resisting force (N)", s, b, a));
  }

  if (has_state(after) && omega_max > 0) {
    const int dof = dofs.front();
    Vec4 omega = Vec4::Zero();
    for (int i = 0; i < 4; ++i)
      if (used[static_cast<std::size_t>(i)]) omega[i] = before.SB(dof, i) >= 0 ? 0.5 * omega_max : -0.5 * omega_max;
    std::vector<double> t;
    for (int i = -20; i <= 150; ++i) t.push_back(0.01 * i);
    charts.push_back(before_after(std::string("Drive force after a step of the screw speeds to ") +
                                      std::to_string(static_cast<int>(0.5 * omega_max + 0.5)) + " rpm at t = 0, along " +
                                      kDofName[dof] + " (eq. (7) with the drive effects)",
                                  "time after the step (s)", std::string("drive force (") + kForceUnit[dof] + ")", t,
                                  drive_step(before, dof, omega, t), drive_step(after, dof, omega, t)));
  }

  if (!d.gantry && d.active[kImuPsi]) {
    std::vector<double> t = grid(t_first, t_last, 301), b(t.size()), a(t.size());
    auto offset = [](const Model& m, double ts) {
      SensorValues s{Vec3::Zero(), 0.0, 0.0, ts};
      for (const auto& e : m.effects) e->sensors(m, Vec3::Zero(), Vec3::Zero(), s);
      return s.imu_psi_rad;
    };
    for (std::size_t i = 0; i < t.size(); ++i) b[i] = offset(before, t[i]), a[i] = offset(after, t[i]);
    if (differs(b, a))
      charts.push_back(before_after("IMU heading minus the true heading over the log (the sensor effects)", "t (s)",
                                    "IMU heading offset (rad)", t, b, a));
  }
  return charts;
}

}  // namespace auger::wb
