// The dictionary of discovered terms and the sparse regression that picks from it (discover.hpp,
// docs/workbench.md "Discovered terms").
#include "discover.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>

#include "auger/dynamics.hpp"
#include "auger/term_form.hpp"

namespace auger::wb {

namespace {

// The reference size of a term's force: about the smallest effect the workbench finds on a
// 240 s log (a 2 N dry friction, a yaw torque of 0.05 N m in the lumped units of eq. (10), half
// an rpm of screw speed), so the sensitivity is computed in the model's linear range.
double reference_size(const std::string& dof) {
  if (dof == "x" || dof == "y") return 2.0;
  if (dof == "yaw") return 0.05;
  return 0.5;
}

}  // namespace

namespace {

// The inputs of a term as the model sees them over the log, every fifth row: the measured speeds,
// their steady body velocity (eq. (6) at rest), the last measured pose, the time since the start.
std::vector<TermInputs> term_rows(const Model& model, const Dataset& data) {
  std::vector<TermInputs> rows;
  TermInputs in;
  for (std::size_t k = 0; k < data.size(); k += 5) {
    in.omega_rpm = data.omega_rpm[k];
    in.zeta = steady_velocity(model, in.omega_rpm);
    const auto& m = data.meas[k];
    if (std::isfinite(m[kX])) in.eta.x() = m[kX];
    if (std::isfinite(m[kY])) in.eta.y() = m[kY];
    if (std::isfinite(m[kPsi])) in.eta.z() = m[kPsi];
    in.t_s = data.t_s[k] - data.t_s.front();
    rows.push_back(in);
  }
  return rows;
}

// The coefficient that makes the term a force of the dof's reference size at its RMS over the
// rows; false if it is zero throughout or (but a constant) does not vary.
bool term_scale_over(const std::vector<TermInputs>& rows, const TermForm& f, double* scale) {
  double sum = 0, sum2 = 0;
  std::size_t n = 0;
  for (const TermInputs& r : rows) {
    double v = 0;
    if (f.dof() >= TermDof::kScrew0) {
      // A screw's term in rpm: the largest over the screws it acts on.
      for (int i = 0; i < 4; ++i) {
        if (f.dof() != TermDof::kScrews && static_cast<int>(f.dof()) - static_cast<int>(TermDof::kScrew0) != i) continue;
        v = std::max(v, std::fabs(f.value(r, i)));
      }
    } else {
      v = f.value(r);
    }
    sum += v;
    sum2 += v * v;
    ++n;
  }
  if (!n) return false;
  const double rms = std::sqrt(sum2 / static_cast<double>(n)), mean = sum / static_cast<double>(n);
  const double spread = std::sqrt(std::max(0.0, sum2 / static_cast<double>(n) - mean * mean));
  // A term that does not vary cannot be told from a constant force (kept: "1") or from nothing.
  if (!(rms > 1e-12) || (f.form_text() != "1" && spread < 1e-6 * rms)) return false;
  *scale = reference_size(f.dof_text()) / rms;
  return true;
}

// The forms a library effect already has, as a term of the dictionary would write them: the
// paper's own drag and traction (paper_params: u on x, v on y, r on yaw, a screw's omega alone,
// every screw's omega), dry friction (sign of u, v, r on their own axis), quadratic drag (u |u|
// ...), the Coriolis terms (rigid_body_coupling: r v on x, r u on y), a slope (sin, cos of the
// heading on x and y), the offset centre of resistance (r on x and y; u and v on yaw), one screw's
// traction (screw_traction_loss: its omega).
bool library_form(const std::string& dof, const std::string& form) {
  static const std::set<std::pair<std::string, std::string>> library = {
      {"x", "u_mps"},         {"x", "sign(u_mps)"},   {"x", "sqs(u_mps)"},   {"x", "r_radps"},
      {"x", "v_mps*r_radps"}, {"x", "sin(psi_rad)"},  {"x", "cos(psi_rad)"}, {"y", "v_mps"},
      {"y", "sign(v_mps)"},   {"y", "sqs(v_mps)"},    {"y", "r_radps"},      {"y", "u_mps*r_radps"},
      {"y", "sin(psi_rad)"},  {"y", "cos(psi_rad)"},  {"yaw", "r_radps"},    {"yaw", "sign(r_radps)"},
      {"yaw", "sqs(r_radps)"}, {"yaw", "u_mps"},      {"yaw", "v_mps"}};
  if (library.count({dof, form})) return true;
  return form == "omega_rpm" && (dof == "screws" || dof.rfind("screw_", 0) == 0);
}

}  // namespace

std::vector<DictionaryTerm> term_dictionary(const Model& model, const Dataset& data) {
  std::vector<std::pair<std::string, std::string>> raw;
  const char* vel[] = {"u_mps", "v_mps", "r_radps"};
  std::vector<std::string> body_dofs;
  if (data.gantry) body_dofs = {data.axis == "lateral" ? "y" : "x"};
  else body_dofs = {"x", "y", "yaw"};
  for (const std::string& dof : body_dofs) {
    for (const char* v : vel) {
      const std::string s(v);
      for (const std::string& f : {s, "sign(" + s + ")", "abs(" + s + ")", "sqs(" + s + ")"}) raw.push_back({dof, f});
      raw.push_back({dof, s + "*t_s"});
    }
    for (const char* f : {"u_mps*r_radps", "v_mps*r_radps", "u_mps*v_mps", "sin(psi_rad)", "cos(psi_rad)",
                          "u_mps*sin2(psi_rad)", "u_mps*cos2(psi_rad)", "v_mps*sin2(psi_rad)", "v_mps*cos2(psi_rad)",
                          "t_s", "x_m", "y_m", "1"})
      raw.push_back({dof, f});
  }
  std::vector<std::string> screw_dofs{"screws", "screw_0", "screw_1"};
  if (!data.gantry) screw_dofs.insert(screw_dofs.end(), {"screw_2", "screw_3"});
  for (const std::string& dof : screw_dofs)
    for (const char* f : {"omega_rpm", "sign(omega_rpm)", "pos(omega_rpm)", "neg(omega_rpm)", "sqs(omega_rpm)",
                          "omega_rpm*t_s"})
      raw.push_back({dof, f});
  // Forms the library has are left out: a term must be what no library effect is (else the
  // regression proposes a Coulomb friction as sign(u) in place of the library's own).
  raw.erase(std::remove_if(raw.begin(), raw.end(), [](const auto& dt) { return library_form(dt.first, dt.second); }),
            raw.end());

  std::vector<DictionaryTerm> out;
  const std::vector<TermInputs> rows = term_rows(model, data);
  for (const auto& [dof, form] : raw) {
    const TermForm f(dof, form);
    double scale = 0;
    if (term_scale_over(rows, f, &scale)) out.push_back({f.dof_text(), f.form_text(), scale});
  }
  return out;
}

double term_scale(const Model& model, const Dataset& data, const std::string& dof, const std::string& form) {
  double scale = 0;
  const TermForm f(dof, form);
  if (!term_scale_over(term_rows(model, data), f, &scale))
    throw std::invalid_argument("the term " + f.dof_text() + ": " + f.form_text() + " does not vary in " + data.path);
  return scale;
}

Selection select_terms(const Eigen::VectorXd& r_train, const Eigen::MatrixXd& S_train, const Eigen::VectorXd& r_held,
                       const Eigen::MatrixXd& S_held, double n_eff, int max_terms, double min_heldout_gain,
                       double min_bic) {
  Selection sel;
  double rss = r_train.squaredNorm(), held = r_held.squaredNorm();
  sel.train_rss.push_back(rss);
  sel.heldout_rss.push_back(held);
  sel.coefficients.resize(0);
  const Eigen::Index P = S_train.cols();
  std::vector<double> norms(static_cast<std::size_t>(P));
  for (Eigen::Index j = 0; j < P; ++j) norms[static_cast<std::size_t>(j)] = S_train.col(j).norm();
  Eigen::VectorXd resid = r_train;
  constexpr std::size_t kShortlist = 8;
  for (int round = 0; round < max_terms; ++round) {
    // The columns that lower the training residual most, each added to those chosen (least
    // squares with them); of the best few, the one that predicts the held-out segments best: a
    // term fitted to the training segments' drift (a slow function of time, of the position on
    // the field) lowers their residual but not the held-out one.
    std::vector<std::pair<double, Eigen::Index>> by_train;
    for (Eigen::Index j = 0; j < P; ++j) {
      if (std::find(sel.columns.begin(), sel.columns.end(), static_cast<int>(j)) != sel.columns.end()) continue;
      const double nj = norms[static_cast<std::size_t>(j)];
      if (!(nj > 1e-12)) continue;
      const double score = std::fabs(S_train.col(j).dot(resid)) / nj;
      by_train.push_back({-score, j});
    }
    if (by_train.empty()) break;
    std::sort(by_train.begin(), by_train.end());
    if (by_train.size() > kShortlist) by_train.resize(kShortlist);
    struct Trial {
      std::vector<int> cols;
      Eigen::VectorXd c, resid;
      double rss = 0, held = 0;
    };
    Trial best;
    best.held = std::numeric_limits<double>::infinity();
    for (const auto& [neg_score, j] : by_train) {
      Trial tr;
      tr.cols = sel.columns;
      tr.cols.push_back(static_cast<int>(j));
      Eigen::MatrixXd A(S_train.rows(), static_cast<Eigen::Index>(tr.cols.size()));
      Eigen::MatrixXd H(S_held.rows(), static_cast<Eigen::Index>(tr.cols.size()));
      for (std::size_t k = 0; k < tr.cols.size(); ++k) {
        A.col(static_cast<Eigen::Index>(k)) = S_train.col(tr.cols[k]);
        H.col(static_cast<Eigen::Index>(k)) = S_held.col(tr.cols[k]);
      }
      tr.c = A.colPivHouseholderQr().solve(-r_train);
      if (!tr.c.allFinite()) continue;
      tr.resid = r_train + A * tr.c;
      tr.rss = tr.resid.squaredNorm();
      tr.held = (r_held + H * tr.c).squaredNorm();
      if (tr.held < best.held) best = std::move(tr);
    }
    if (best.cols.empty()) break;
    const double dbic = n_eff * std::log(std::max(best.rss, 1e-300) / std::max(rss, 1e-300)) + std::log(n_eff);
    if (!(best.held < held * (1.0 - min_heldout_gain)) || !(dbic < -min_bic)) break;
    sel.columns = best.cols;
    sel.coefficients = best.c;
    resid = best.resid;
    rss = best.rss;
    held = best.held;
    sel.train_rss.push_back(rss);
    sel.heldout_rss.push_back(held);
  }
  return sel;
}

}  // namespace auger::wb
