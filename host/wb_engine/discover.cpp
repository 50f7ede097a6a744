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
  if (dof == "x" || dof == "y" || dof == "drag") return 2.0;  // drag: its force in the plane
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
bool term_scale_over(const Model& model, const std::vector<TermInputs>& rows, const TermForm& f, double* scale) {
  double sum = 0, sum2 = 0;
  std::size_t n = 0;
  for (const TermInputs& r : rows) {
    double v = 0;
    if (f.dof() == TermDof::kDrag) {
      // A fraction of the drag: its force (N) in the plane, where the reference size is.
      v = f.value(r) * model.D_diag.head<2>().cwiseProduct(r.zeta.head<2>()).norm();
    } else if (f.dof() >= TermDof::kScrew0) {
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
  // The ground's drag on every axis alike growing or falling over the log or across the field
  // (soil that the screws work softer or the robot sinks into), as one term where three of the
  // body dofs' (u t on x, v t on y, r t on yaw) would each pay for its own column.
  if (!data.gantry)
    for (const char* f : {"t_s", "x_m", "y_m"}) raw.push_back({"drag", f});
  // Traction that changes with how the body moves over the ground (soil churned by turning,
  // screws slipping sideways or at speed), on every screw alike: omega times |u|, |v|, |r|.
  for (const char* f : {"omega_rpm*abs(u_mps)", "omega_rpm*abs(v_mps)", "omega_rpm*abs(r_radps)"})
    raw.push_back({"screws", f});
  // Forms the library has are left out: a term must be what no library effect is (else the
  // regression proposes a Coulomb friction as sign(u) in place of the library's own).
  raw.erase(std::remove_if(raw.begin(), raw.end(), [](const auto& dt) { return library_form(dt.first, dt.second); }),
            raw.end());

  std::vector<DictionaryTerm> out;
  const std::vector<TermInputs> rows = term_rows(model, data);
  for (const auto& [dof, form] : raw) {
    const TermForm f(dof, form);
    double scale = 0;
    if (term_scale_over(model, rows, f, &scale)) out.push_back({f.dof_text(), f.form_text(), scale});
  }
  return out;
}

std::vector<int> harmonic_partners(const std::vector<DictionaryTerm>& dict) {
  std::vector<int> partner(dict.size(), -1);
  auto swap_fn = [](std::string form) {
    // sin2 <-> cos2, sin <-> cos (of the heading), the rest of the form the same.
    for (const auto& [a, b] : {std::pair<std::string, std::string>{"sin2(psi_rad)", "cos2(psi_rad)"},
                               {"sin(psi_rad)", "cos(psi_rad)"}}) {
      std::size_t at = form.find(a);
      if (at != std::string::npos) return form.replace(at, a.size(), b);
      at = form.find(b);
      if (at != std::string::npos) return form.replace(at, b.size(), a);
    }
    return std::string();
  };
  for (std::size_t i = 0; i < dict.size(); ++i) {
    const std::string other = swap_fn(dict[i].form);
    if (other.empty()) continue;
    for (std::size_t j = 0; j < dict.size(); ++j)
      if (j != i && dict[j].dof == dict[i].dof && dict[j].form == other) partner[i] = static_cast<int>(j);
  }
  return partner;
}

double matched_coefficient(const Model& model, const Dataset& data, const std::string& dof, const std::string& from,
                           double c, const std::string& to) {
  const TermForm a(dof, from), b(dof, to);
  double ab = 0, bb = 0;
  for (const TermInputs& r : term_rows(model, data))
    for (int i = a.dof() >= TermDof::kScrew0 ? 0 : -1; i < (a.dof() >= TermDof::kScrew0 ? 4 : 0); ++i) {
      const double va = a.value(r, i), vb = b.value(r, i);
      ab += va * vb;
      bb += vb * vb;
    }
  return bb > 0 ? c * ab / bb : 0.0;
}

double term_scale(const Model& model, const Dataset& data, const std::string& dof, const std::string& form) {
  double scale = 0;
  const TermForm f(dof, form);
  if (!term_scale_over(model, term_rows(model, data), f, &scale))
    throw std::invalid_argument("the term " + f.dof_text() + ": " + f.form_text() + " does not vary in " + data.path);
  return scale;
}

namespace {

// The columns cols of one fold's rows.
Eigen::MatrixXd columns_of(const Eigen::MatrixXd& S, const std::vector<int>& cols) {
  Eigen::MatrixXd A(S.rows(), static_cast<Eigen::Index>(cols.size()));
  for (std::size_t k = 0; k < cols.size(); ++k) A.col(static_cast<Eigen::Index>(k)) = S.col(cols[k]);
  return A;
}

// Every fold's block but skip's, stacked by rows: block(parts[f]) is fold f's part, n_cols wide.
template <class Out, class Part, class Block>
Out stack_folds(const std::vector<Part>& parts, int skip, Eigen::Index n_cols, Block block) {
  Eigen::Index n = 0;
  for (std::size_t f = 0; f < parts.size(); ++f)
    if (static_cast<int>(f) != skip) n += parts[f].rows();
  Out out(n, n_cols);
  Eigen::Index at = 0;
  for (std::size_t f = 0; f < parts.size(); ++f) {
    if (static_cast<int>(f) == skip) continue;
    out.middleRows(at, parts[f].rows()) = block(parts[f]);
    at += parts[f].rows();
  }
  return out;
}

// The columns cols of every fold's rows but skip's, stacked.
Eigen::MatrixXd stack_cols(const std::vector<Eigen::MatrixXd>& S, const std::vector<int>& cols, int skip) {
  return stack_folds<Eigen::MatrixXd>(S, skip, static_cast<Eigen::Index>(cols.size()),
                                      [&cols](const Eigen::MatrixXd& s) { return columns_of(s, cols); });
}

// The rows of every fold but skip's, stacked.
Eigen::VectorXd stack_rows(const std::vector<Eigen::VectorXd>& r, int skip) {
  return stack_folds<Eigen::VectorXd>(r, skip, 1, [](const Eigen::VectorXd& v) -> const Eigen::VectorXd& { return v; });
}

}  // namespace

Selection select_terms(const std::vector<Eigen::VectorXd>& r, const std::vector<Eigen::MatrixXd>& S, int nuisance,
                       const std::vector<int>& partner, double n_eff, int max_terms, double min_heldout_gain,
                       double min_bic) {
  Selection sel;
  const Eigen::VectorXd r_all = stack_rows(r, -1);
  const int folds = static_cast<int>(r.size());
  sel.coefficients.resize(0);
  if (S.empty()) return sel;
  std::vector<int> always(static_cast<std::size_t>(nuisance));
  for (int k = 0; k < nuisance; ++k) always[static_cast<std::size_t>(k)] = k;
  const Eigen::MatrixXd S_all = [&] {
    std::vector<int> every(static_cast<std::size_t>(S.front().cols()));
    for (std::size_t j = 0; j < every.size(); ++j) every[j] = static_cast<int>(j);
    return stack_cols(S, every, -1);
  }();
  const Eigen::Index P = S_all.cols();
  Eigen::VectorXd resid = r_all;
  constexpr std::size_t kShortlist = 8;
  struct Trial {
    std::vector<int> cols;  // the terms' columns (the nuisance columns are in every fit)
    Eigen::VectorXd c, resid;
    double rss = 0, held = std::numeric_limits<double>::infinity();
  };
  auto trial = [&](std::vector<int> cols) {
    Trial tr;
    tr.cols = std::move(cols);
    std::vector<int> with = always;
    with.insert(with.end(), tr.cols.begin(), tr.cols.end());
    if (with.empty()) {
      tr.resid = r_all;
      tr.rss = tr.held = r_all.squaredNorm();
      return tr;
    }
    const Eigen::MatrixXd A = stack_cols(S, with, -1);
    const Eigen::VectorXd c = A.colPivHouseholderQr().solve(-r_all);
    if (!c.allFinite()) return tr;
    tr.c = c.tail(static_cast<Eigen::Index>(tr.cols.size()));
    tr.resid = r_all + A * c;
    tr.rss = tr.resid.squaredNorm();
    if (folds <= 1) {
      tr.held = tr.rss;
      return tr;
    }
    // Only the terms are cross-validated: the paper's parameters keep their fit on every fold.
    // Refitted on two thirds, they may be left unidentified by a motion that only the third
    // holds (one fold of a 120 s battery-sag log predicted 175 times worse than by the fit on
    // every fold), and the held-out residual then ranks the terms by how well they mend that
    // instead of by the log's physics.
    std::vector<Eigen::VectorXd> left(r);  // each fold's residual with the paper's parameters' share
    if (nuisance > 0)
      for (std::size_t f = 0; f < left.size(); ++f) left[f] += columns_of(S[f], always) * c.head(nuisance);
    tr.held = 0;
    for (int f = 0; f < folds; ++f) {
      Eigen::VectorXd rf = left[static_cast<std::size_t>(f)];
      if (!tr.cols.empty()) {
        const Eigen::VectorXd cf = stack_cols(S, tr.cols, f).colPivHouseholderQr().solve(-stack_rows(left, f));
        if (!cf.allFinite()) {
          tr.held = std::numeric_limits<double>::infinity();
          break;
        }
        rf += columns_of(S[static_cast<std::size_t>(f)], tr.cols) * cf;
      }
      tr.held += rf.squaredNorm();
    }
    return tr;
  };
  // The start: the model's own (nuisance) parameters alone, refitted as every trial refits them.
  const Trial start = trial({});
  if (start.resid.size() == r_all.size()) resid = start.resid;
  double rss = resid.squaredNorm(), held = std::isfinite(start.held) ? start.held : rss;
  sel.train_rss.push_back(rss);
  sel.heldout_rss.push_back(held);
  while (static_cast<int>(sel.columns.size()) < max_terms) {
    // The columns that lower the residual most, each added to those chosen; of the best few, the
    // one that predicts each fold best from the others: a term fitted to one part of the log's
    // drift (a slow function of time, of the position on the field) lowers its residual there
    // but not elsewhere. Every segment is judged once: with a few 25 s segments to a log, one
    // held-out third alone can miss the motion the term needs (the turns of a log).
    // Each column is scored by what it would take off the residual, which is its part outside
    // the columns already in the fit (the paper's parameters and the terms chosen): a term much
    // like a change of sigma (every screw's backward part) is mostly taken up by them, and by
    // its whole length it would rank far below what it explains beyond them.
    std::vector<int> in_fit = always;
    in_fit.insert(in_fit.end(), sel.columns.begin(), sel.columns.end());
    Eigen::MatrixXd Q;
    if (!in_fit.empty()) {
      const Eigen::MatrixXd A = columns_of(S_all, in_fit);
      Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
      Q = qr.householderQ() * Eigen::MatrixXd::Identity(A.rows(), qr.rank());
    }
    std::vector<std::pair<double, Eigen::Index>> by_fit;
    for (Eigen::Index j = nuisance; j < P; ++j) {
      if (std::find(sel.columns.begin(), sel.columns.end(), static_cast<int>(j)) != sel.columns.end()) continue;
      Eigen::VectorXd s = S_all.col(j);
      const double nj = s.norm();
      if (!(nj > 1e-12)) continue;
      if (Q.cols() > 0) s -= Q * (Q.transpose() * s);
      const double nj_out = s.norm();
      if (!(nj_out > 1e-6 * nj)) continue;  // within the fit's columns already
      by_fit.push_back({-std::fabs(s.dot(resid)) / nj_out, j});
    }
    if (by_fit.empty()) break;
    std::sort(by_fit.begin(), by_fit.end());
    if (by_fit.size() > kShortlist) by_fit.resize(kShortlist);
    auto chosen = [&](int j) { return std::find(sel.columns.begin(), sel.columns.end(), j) != sel.columns.end(); };
    // A term of the heading's harmonics (u sin 2psi) is also tried with its partner (u cos 2psi):
    // together they are one direction on the field whose angle the data fix (furrows, a slope),
    // which neither alone is. The pair must predict 2 % better than the best single term, as a
    // term must.
    Trial best, best_pair;
    for (const auto& [neg_score, j] : by_fit) {
      std::vector<int> cols = sel.columns;
      cols.push_back(static_cast<int>(j));
      Trial tr = trial(cols);
      if (tr.held < best.held) best = tr;
      const int pj = partner.empty() || partner[static_cast<std::size_t>(j - nuisance)] < 0
                         ? -1
                         : partner[static_cast<std::size_t>(j - nuisance)] + nuisance;
      if (pj < 0 || chosen(pj)) continue;
      cols.push_back(pj);
      Trial pr = trial(cols);
      if (pr.held < best_pair.held) best_pair = std::move(pr);
    }
    if (!best_pair.cols.empty() && best_pair.held < best.held * (1.0 - min_heldout_gain)) best = std::move(best_pair);
    if (best.cols.empty() || !std::isfinite(best.held)) break;
    const double added = static_cast<double>(best.cols.size() - sel.columns.size());
    const double dbic = n_eff * std::log(std::max(best.rss, 1e-300) / std::max(rss, 1e-300)) + added * std::log(n_eff);
    if (!(best.held < held * (1.0 - min_heldout_gain)) || !(dbic < -added * min_bic)) break;
    sel.columns = best.cols;
    sel.coefficients = best.c;
    resid = best.resid;
    rss = best.rss;
    held = best.held;
    for (double k = 0; k < added; ++k) {
      sel.train_rss.push_back(rss);
      sel.heldout_rss.push_back(held);
    }
  }
  for (int& c : sel.columns) c -= nuisance;
  return sel;
}

}  // namespace auger::wb
