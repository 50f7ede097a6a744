// The effect `term`: a generalized force no library effect has, in a form of the documented
// vocabulary (auger/term_form.hpp, docs/workbench.md "Discovered terms"). `auger explain`
// proposes such terms from the residuals; a model file carries them like any effect, so compare,
// fit and augerd load them.
#include <cmath>
#include <sstream>

#include "auger/term_form.hpp"
#include "effects.hpp"

namespace auger {
namespace {

struct Named {
  const char* name;
  int value;
};
constexpr Named kDofs[] = {{"x", 0}, {"y", 1}, {"yaw", 2}, {"drag", 3}, {"screw_0", 4}, {"screw_1", 5},
                           {"screw_2", 6}, {"screw_3", 7}, {"screws", 8}};
constexpr Named kInputs[] = {{"omega_rpm_0", 0}, {"omega_rpm_1", 1}, {"omega_rpm_2", 2}, {"omega_rpm_3", 3},
                             {"omega_rpm", 4}, {"u_mps", 5}, {"v_mps", 6}, {"r_radps", 7}, {"psi_rad", 8},
                             {"x_m", 9}, {"y_m", 10}, {"t_s", 11}, {"1", 12}};
constexpr Named kFns[] = {{"", 0}, {"sign", 1}, {"abs", 2}, {"pos", 3}, {"neg", 4}, {"sqs", 5},
                          {"sq", 6}, {"sin", 7}, {"cos", 8}, {"sin2", 9}, {"cos2", 10}};
const char* kInputUnits[] = {"rpm", "rpm", "rpm", "rpm", "rpm", "m/s", "m/s", "rad/s", "rad", "m", "m", "s", ""};

template <std::size_t N>
int lookup(const Named (&table)[N], const std::string& s) {
  for (const Named& n : table)
    if (s == n.name) return n.value;
  return -1;
}
template <std::size_t N>
std::string known(const Named (&table)[N]) {
  std::string k;
  for (const Named& n : table)
    if (*n.name) k += (k.empty() ? "" : ", ") + std::string(n.name);
  return k;
}
template <std::size_t N>
const char* name_of(const Named (&table)[N], int v) {
  for (const Named& n : table)
    if (n.value == v) return n.name;
  return "?";
}

bool is_screw_dof(TermDof d) { return d >= TermDof::kScrew0; }

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t"), e = s.find_last_not_of(" \t");
  return b == std::string::npos ? "" : s.substr(b, e - b + 1);
}

TermFactor parse_factor(const std::string& text, const std::string& form) {
  const std::string s = trim(text);
  TermFactor f;
  std::string input = s;
  const auto open = s.find('(');
  if (open != std::string::npos) {
    if (s.back() != ')') throw std::invalid_argument("term form '" + form + "': '" + s + "' lacks its closing ')'");
    const int fn = lookup(kFns, trim(s.substr(0, open)));
    if (fn <= 0)
      throw std::invalid_argument("term form '" + form + "': unknown function '" + trim(s.substr(0, open)) +
                                  "' (known: " + known(kFns) + ")");
    f.fn = static_cast<TermFn>(fn);
    input = trim(s.substr(open + 1, s.size() - open - 2));
  }
  const int in = lookup(kInputs, input);
  if (in < 0)
    throw std::invalid_argument("term form '" + form + "': unknown input '" + input + "' (known: " + known(kInputs) + ")");
  f.input = static_cast<TermInput>(in);
  return f;
}

double apply(TermFn fn, double a) {
  switch (fn) {
    case TermFn::kId: return a;
    case TermFn::kSign: return a > 0 ? 1.0 : a < 0 ? -1.0 : 0.0;
    case TermFn::kAbs: return std::fabs(a);
    case TermFn::kPos: return a > 0 ? a : 0.0;
    case TermFn::kNeg: return a < 0 ? a : 0.0;
    case TermFn::kSqs: return a * std::fabs(a);
    case TermFn::kSq: return a * a;
    case TermFn::kSin: return std::sin(a);
    case TermFn::kCos: return std::cos(a);
    case TermFn::kSin2: return std::sin(2 * a);
    case TermFn::kCos2: return std::cos(2 * a);
  }
  return 0.0;
}

std::string factor_unit(const TermFactor& f) {
  const std::string u = kInputUnits[static_cast<int>(f.input)];
  switch (f.fn) {
    case TermFn::kSign: case TermFn::kSin: case TermFn::kCos: case TermFn::kSin2: case TermFn::kCos2: return "";
    case TermFn::kSqs: case TermFn::kSq: return u.empty() ? "" : (u.find('/') != std::string::npos ? "(" + u + ")^2" : u + "^2");
    default: return u;
  }
}

}  // namespace

TermForm::TermForm(const std::string& dof, const std::string& form) {
  const int d = lookup(kDofs, trim(dof));
  if (d < 0) throw std::invalid_argument("term dof '" + dof + "' (known: " + known(kDofs) + ")");
  dof_ = static_cast<TermDof>(d);
  dof_text_ = name_of(kDofs, d);
  const auto star = form.find('*');
  if (trim(form).empty()) throw std::invalid_argument("term form is empty");
  factors_.push_back(parse_factor(form.substr(0, star), form));
  if (star != std::string::npos) {
    if (form.find('*', star + 1) != std::string::npos)
      throw std::invalid_argument("term form '" + form + "': at most two factors");
    factors_.push_back(parse_factor(form.substr(star + 1), form));
  }
  bool has_own = false;
  for (const TermFactor& f : factors_) has_own = has_own || f.input == TermInput::kOmegaOwn;
  for (const TermFactor& f : factors_) {
    const bool own = f.input == TermInput::kOmegaOwn;
    if (own && !is_screw_dof(dof_))
      throw std::invalid_argument("term form '" + form + "': omega_rpm (the screw's own) needs a screw dof "
                                  "(screw_0..screw_3, screws); on " + dof_text_ + " name the screw: omega_rpm_0..3");
    // A screw's speed may change with time or, beside its own speed, with the body's motion over
    // the ground (traction that falls in turns: omega_rpm*abs(r_radps)).
    const bool body = f.input == TermInput::kU || f.input == TermInput::kV || f.input == TermInput::kR;
    if (is_screw_dof(dof_) && !own && f.input != TermInput::kT && f.input != TermInput::kOne && !(body && has_own))
      throw std::invalid_argument("term form '" + form + "' on " + dof_text_ +
                                  ": a screw's term reads its own omega_rpm and t_s, or u_mps, v_mps, r_radps "
                                  "beside its own omega_rpm");
  }
  std::string canon;
  for (const TermFactor& f : factors_) {
    const std::string in = name_of(kInputs, static_cast<int>(f.input));
    canon += (canon.empty() ? "" : "*") +
             (f.fn == TermFn::kId ? in : std::string(name_of(kFns, static_cast<int>(f.fn))) + "(" + in + ")");
  }
  form_text_ = canon;
}

double TermForm::value(const TermInputs& in, int screw) const {
  double v = 1.0;
  for (const TermFactor& f : factors_) {
    double a = 1.0;
    switch (f.input) {
      case TermInput::kOmega0: case TermInput::kOmega1: case TermInput::kOmega2: case TermInput::kOmega3:
        a = in.omega_rpm[static_cast<int>(f.input)];
        break;
      case TermInput::kOmegaOwn: a = screw >= 0 ? in.omega_rpm[screw] : 0.0; break;
      case TermInput::kU: a = in.zeta.x(); break;
      case TermInput::kV: a = in.zeta.y(); break;
      case TermInput::kR: a = in.zeta.z(); break;
      case TermInput::kPsi: a = in.eta.z(); break;
      case TermInput::kX: a = in.eta.x(); break;
      case TermInput::kY: a = in.eta.y(); break;
      case TermInput::kT: a = in.t_s; break;
      case TermInput::kOne: a = 1.0; break;
    }
    v *= apply(f.fn, a);
  }
  return v;
}

Vec3 TermForm::force(const Model& model, const TermInputs& in, double c) const {
  Vec3 f = Vec3::Zero();
  switch (dof_) {
    case TermDof::kX: f.x() = c * value(in); break;
    case TermDof::kY: f.y() = c * value(in); break;
    case TermDof::kYaw: f.z() = c * value(in); break;
    // eq. (6)'s drag D zeta, every axis scaled alike by the form.
    case TermDof::kDrag: f = -c * value(in) * model.D_diag.cwiseProduct(in.zeta); break;
    case TermDof::kScrews:
      for (int i = 0; i < 4; ++i) f += model.SB.col(i) * (c * value(in, i));  // eq. (7), each screw's column
      break;
    default: {
      const int i = static_cast<int>(dof_) - static_cast<int>(TermDof::kScrew0);
      f = model.SB.col(i) * (c * value(in, i));
    }
  }
  return f;
}

std::vector<std::string> TermForm::input_names() const {
  std::vector<std::string> out;
  auto add = [&](const std::string& s) {
    for (const auto& x : out)
      if (x == s) return;
    out.push_back(s);
  };
  if (dof_ == TermDof::kDrag)
    for (const char* v : {"u_mps", "v_mps", "r_radps"}) add(v);
  for (const TermFactor& f : factors_) {
    if (f.input == TermInput::kOne) continue;
    if (f.input != TermInput::kOmegaOwn) {
      add(name_of(kInputs, static_cast<int>(f.input)));
    } else if (dof_ == TermDof::kScrews) {
      for (int i = 0; i < 4; ++i) add("omega_rpm_" + std::to_string(i));
    } else {
      add("omega_rpm_" + std::to_string(static_cast<int>(dof_) - static_cast<int>(TermDof::kScrew0)));
    }
  }
  return out;
}

std::string TermForm::form_unit() const {
  std::string u;
  for (const TermFactor& f : factors_) {
    const std::string x = factor_unit(f);
    if (!x.empty()) u += (u.empty() ? "" : " ") + x;
  }
  return u;
}

std::string TermForm::dof_unit() const {
  if (dof_ == TermDof::kDrag) return "-";  // a fraction of the drag
  return dof_ == TermDof::kX || dof_ == TermDof::kY ? "N" : dof_ == TermDof::kYaw ? "N m" : "rpm";
}

std::string TermForm::coefficient_unit() const {
  const std::string f = form_unit();
  // A fraction of the drag per unit of the form: 1/s for t_s.
  const std::string d = dof_ == TermDof::kDrag ? (f.empty() ? "-" : "1") : dof_unit();
  if (f.empty()) return d;
  if (f == d) return "-";
  const bool wrap = f.find(' ') != std::string::npos || (f.find('/') != std::string::npos && f.front() != '(');
  return d + "/" + (wrap ? "(" + f + ")" : f);
}

std::string TermForm::describe(double c) const {
  std::string where;
  switch (dof_) {
    case TermDof::kX: where = "a force along x"; break;
    case TermDof::kY: where = "a force along y"; break;
    case TermDof::kYaw: where = "a yaw torque (the model's lumped units)"; break;
    case TermDof::kDrag: where = "the ground's drag D zeta (every axis alike) changed as a fraction"; break;
    case TermDof::kScrews: where = "every screw's effective speed changed"; break;
    default: where = "screw " + std::to_string(static_cast<int>(dof_) - static_cast<int>(TermDof::kScrew0)) +
                     "'s effective speed changed";
  }
  std::ostringstream o;
  o << where << " by " << effects::fmt(c) << " " << coefficient_unit() << " x " << form_text_
    << ": a discovered term, not a library effect";
  return o.str();
}

namespace effects {
namespace {

class Term final : public Effect {
 public:
  Term(TermForm form, double coefficient) : form_(std::move(form)), c_(coefficient) {}
  const std::string& id() const override {
    static const std::string s = "term";
    return s;
  }
  std::vector<std::pair<std::string, double>> params() const override { return {{"coefficient", c_}}; }
  std::vector<std::pair<std::string, std::string>> text_params() const override {
    return {{"dof", form_.dof_text()}, {"form", form_.form_text()}};
  }
  // eq. (6): evaluated at the step's start state (its dt is short against the terms' variation).
  void body_force(const Model& model, const EffectContext& ctx, Vec3& force_n, double*) const override {
    TermInputs in;
    in.eta = ctx.eta;
    in.zeta = ctx.zeta;
    in.omega_rpm = ctx.omega_rpm;
    in.t_s = ctx.t_s;
    force_n = form_.force(model, in, c_);
  }

 private:
  TermForm form_;
  double c_;
};

}  // namespace

void register_term(EffectRegistry& r) {
  EffectRegistry::Entry e;
  e.id = "term";
  e.doc = "a discovered term: a force (x, y), yaw torque or screw speed change of a form the library has not "
          "(docs/workbench.md \"Discovered terms\")";
  ParamSpec c{"coefficient", 0, true, "the term's coefficient (unit: the dof's over the form's)", "", -1e12, 1e12, 1};
  e.params = {c};
  e.text_params = {"dof", "form"};
  e.make = [](const std::vector<double>&) -> std::shared_ptr<const Effect> {
    throw std::invalid_argument("a term needs its dof and form");
  };
  e.make_text = [](const std::vector<double>& v, const std::vector<std::string>& texts) -> std::shared_ptr<const Effect> {
    if (!std::isfinite(v[0])) throw std::invalid_argument("coefficient must be finite");
    return std::make_shared<Term>(TermForm(texts.at(0), texts.at(1)), v[0]);
  };
  e.describe = nullptr;
  r.add(std::move(e));
}

}  // namespace effects
}  // namespace auger
