// Model file reader and writer (toml++, header-only, used only here and in augerd's configuration
// reader, with the same kit: auger/toml_kit.hpp).
#include "auger/model_file.hpp"

#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include <toml++/toml.h>

#include "auger/toml_kit.hpp"

namespace auger {
namespace {

// The TOML kit shared with augerd's configuration reader.
using toml_kit::as_table;
using toml_kit::col_of;
using toml_kit::fail;
using toml_kit::line_of;
using toml_kit::number;
using toml_kit::text;

// Fills named doubles of a table; an unknown key is an error naming its line.
struct NumberField {
  const char* key;
  double* target;
  bool required;
  double scale;  // e.g. degrees to radians
};

void read_numbers(const std::string& file, const toml::table& t, const std::string& where,
                  std::vector<NumberField> fields, int table_line) {
  std::set<std::string> seen;
  for (auto&& [k, v] : t) {
    const std::string key(k.str());
    auto it = std::find_if(fields.begin(), fields.end(), [&](const NumberField& f) { return key == f.key; });
    if (it == fields.end()) {
      std::string known;
      for (const auto& f : fields) known += (known.empty() ? "" : ", ") + std::string(f.key);
      toml_kit::unknown_key(file, v, key, where, known);
    }
    *it->target = number(file, v, key) * it->scale;
    seen.insert(key);
  }
  for (const auto& f : fields)
    if (f.required && !seen.count(f.key))
      throw ConfigError(file, table_line, 1, where + " needs '" + std::string(f.key) + "'");
}

Vec3 vec3(const std::string& file, const toml::node& n, const std::string& key) {
  const toml::array& a = toml_kit::vec3_array(file, n, key);
  Vec3 v;
  for (std::size_t i = 0; i < 3; ++i) v[static_cast<Eigen::Index>(i)] = number(file, *a.get(i), key);
  return v;
}

// The names of [control]'s choices, for the reader and the writer.
const std::pair<const char*, AllocatorKind> kAllocatorNames[] = {{"pseudo_inverse", AllocatorKind::pseudo_inverse},
                                                                 {"null_space", AllocatorKind::null_space}};
const std::pair<const char*, AllocationPriority> kPriorityNames[] = {{"yaw", AllocationPriority::yaw},
                                                                     {"translation", AllocationPriority::translation}};
const std::pair<const char*, EstimatorKind> kEstimatorNames[] = {{"dead_reckoning", EstimatorKind::dead_reckoning},
                                                                 {"dead_reckoning_imu", EstimatorKind::dead_reckoning_imu},
                                                                 {"ekf", EstimatorKind::ekf}};

template <class E, std::size_t N>
const char* name_of(const std::pair<const char*, E> (&options)[N], E value) {
  for (const auto& [name, v] : options)
    if (v == value) return name;
  return "";
}

template <class E, std::size_t N>
E choice(const std::string& file, const toml::node& n, const std::string& key,
         const std::pair<const char*, E> (&options)[N]) {
  const std::string v = text(file, n, key);
  std::string known;
  for (const auto& [name, value] : options) {
    if (v == name) return value;
    known += (known.empty() ? "" : ", ") + std::string(name);
  }
  fail(file, n, "'" + key + "' = '" + v + "' is not one of: " + known);
}

void read_control(const std::string& file, const toml::table& t, ControlSection& c) {
  for (auto&& [k, v] : t) {
    const std::string key(k.str());
    if (key == "gamma_per_s") c.gamma_per_s = vec3(file, v, key);
    else if (key == "kp") c.kp = vec3(file, v, key);
    else if (key == "kd") c.kd = vec3(file, v, key);
    else if (key == "ki") c.ki = vec3(file, v, key);
    else if (key == "integral_limit") c.integral_limit = vec3(file, v, key);
    else if (key == "omega_min_rpm") c.omega_min_rpm = number(file, v, key);
    else if (key == "engage_rpm") c.engage_rpm = number(file, v, key);
    else if (key == "sign_hold_rpm") c.sign_hold_rpm = number(file, v, key);
    else if (key == "allocator")
      c.allocator = choice(file, v, key, kAllocatorNames);
    else if (key == "priority")
      c.priority = choice(file, v, key, kPriorityNames);
    else if (key == "estimator")
      c.estimator = choice(file, v, key, kEstimatorNames);
    else
      fail(file, v, "unknown key '" + key + "' in [control] (known: gamma_per_s, kp, kd, ki, integral_limit, "
                    "allocator, priority, omega_min_rpm, engage_rpm, sign_hold_rpm, estimator)");
    const bool non_negative_vec =
        (key == "gamma_per_s" || key == "kp" || key == "kd" || key == "ki" || key == "integral_limit");
    if (non_negative_vec && !(vec3(file, v, key).minCoeff() >= 0)) fail(file, v, "'" + key + "' must be >= 0");
    if ((key == "omega_min_rpm" || key == "engage_rpm" || key == "sign_hold_rpm") && !(number(file, v, key) >= 0))
      fail(file, v, "'" + key + "' must be >= 0");
  }
}

// ---- writer ----

// The degree value that deg_to_rad turns back into exactly `rad`: the plain conversion can be an
// ulp off, so its neighbours are tried. Every angle read from a file (degrees) has one.
double degrees_for(double rad) {
  double deg = rad * 180.0 / kPi;
  for (int i = 0; i < 16 && deg_to_rad(deg) != rad; ++i)
    deg = std::nextafter(deg, deg_to_rad(deg) < rad ? std::numeric_limits<double>::infinity()
                                                    : -std::numeric_limits<double>::infinity());
  return deg_to_rad(deg) == rad ? deg : rad * 180.0 / kPi;
}

toml::array toml_vec3(const Vec3& v) { return toml::array{v[0], v[1], v[2]}; }

// One table as toml++ formats it (doubles to 17 significant digits, so they read back to the
// same bits; keys in toml++'s order), after its comment lines.
void put(std::ostringstream& o, const toml::table& t, const std::string& comment = "") {
  std::istringstream lines(comment);
  for (std::string line; std::getline(lines, line);) o << "# " << line << "\n";
  o << toml::toml_formatter(t, toml::format_flags::none) << "\n";
}

}  // namespace

std::string write_model_file(const ModelFile& f) {
  std::ostringstream o;
  {
    std::istringstream lines(f.comment);
    for (std::string line; std::getline(lines, line);) o << "# " << line << "\n";
  }
  // schema first, one key at a time: a table would sort them.
  o << toml::toml_formatter(toml::table{{"schema", f.schema}}, toml::format_flags::none) << "\n";
  o << toml::toml_formatter(toml::table{{"omega_unit", f.omega_unit}}, toml::format_flags::none) << "\n";
  o << toml::toml_formatter(toml::table{{"frame", f.frame}}, toml::format_flags::none) << "\n\n";
  if (f.robot) {
    const RobotParams& r = *f.robot;
    put(o, toml::table{{"robot", toml::table{{"r_s_m", r.r_s_m},
                                             {"phi_deg", degrees_for(r.phi_rad)},
                                             {"l_x_m", r.l_x_m},
                                             {"l_y_m", r.l_y_m},
                                             {"alpha_deg", degrees_for(r.alpha_rad)},
                                             {"m_kg", r.m_kg},
                                             {"I_z_kgm2", r.I_z_kgm2},
                                             {"omega_max_rpm", r.omega_max_rpm}}}});
  }
  if (f.gantry_mass_kg) put(o, toml::table{{"gantry", toml::table{{"mass_kg", *f.gantry_mass_kg}}}});
  for (const TerrainEntry& e : f.terrains) {
    const TerrainParams& p = e.params;
    toml::table t{{"sigma_long", p.sigma_long}, {"sigma_lat", p.sigma_lat}, {"D_x", p.D_x}, {"D_y", p.D_y}};
    if (!std::isnan(p.D_psi)) t.insert("D_psi", p.D_psi);
    put(o, toml::table{{"terrain", toml::table{{p.name, std::move(t)}}}}, e.comment);
  }
  for (const EffectConfig& c : f.effects) {
    toml::table t{{"id", c.id}};
    for (const auto& p : c.texts) t.insert(p.name, p.value);
    for (const auto& p : c.params) {
      if (p.online) t.insert(p.name, toml::table{{"value", p.value}, {"online", true}});
      else t.insert(p.name, p.value);
    }
    put(o, toml::table{{"effect", toml::array{std::move(t)}}}, c.comment);
  }
  const ControlSection& c = f.control;
  toml::table control;
  if (c.gamma_per_s) control.insert("gamma_per_s", toml_vec3(*c.gamma_per_s));
  if (c.kp) control.insert("kp", toml_vec3(*c.kp));
  if (c.kd) control.insert("kd", toml_vec3(*c.kd));
  if (c.ki) control.insert("ki", toml_vec3(*c.ki));
  if (c.integral_limit) control.insert("integral_limit", toml_vec3(*c.integral_limit));
  if (c.allocator) control.insert("allocator", name_of(kAllocatorNames, *c.allocator));
  if (c.priority) control.insert("priority", name_of(kPriorityNames, *c.priority));
  if (c.omega_min_rpm) control.insert("omega_min_rpm", *c.omega_min_rpm);
  if (c.engage_rpm) control.insert("engage_rpm", *c.engage_rpm);
  if (c.sign_hold_rpm) control.insert("sign_hold_rpm", *c.sign_hold_rpm);
  if (c.estimator) control.insert("estimator", name_of(kEstimatorNames, *c.estimator));
  if (!control.empty()) put(o, toml::table{{"control", std::move(control)}});
  std::string text = o.str();
  while (text.size() > 1 && text[text.size() - 1] == '\n' && text[text.size() - 2] == '\n') text.pop_back();
  return text;
}

const TerrainEntry* ModelFile::find_terrain(const std::string& name) const {
  for (const auto& t : terrains)
    if (t.params.name == name) return &t;
  return nullptr;
}

namespace {
// `NAME = { value = 0.05, online = true }`: an effect's parameter that augerd estimates online
// (docs/model.md); the registry refuses it for a parameter that cannot be (EffectRegistry::create).
EffectParamValue online_param(const std::string& file, const toml::table& t, const std::string& key) {
  EffectParamValue p{key, 0, line_of(t), col_of(t)};
  bool have_value = false;
  for (auto&& [k, v] : t) {
    const std::string sub(k.str());
    if (sub == "value") {
      p.value = number(file, v, key + ".value");
      have_value = true;
    } else if (sub == "online") {
      p.online = toml_kit::boolean(file, v, key + ".online");
      p.online_line = line_of(v);
      p.online_column = col_of(v);
    } else {
      toml_kit::unknown_key(file, v, sub, "'" + key + "'", "value, online");
    }
  }
  if (!have_value)
    throw ConfigError(file, p.line, p.column, "'" + key + "' needs 'value' (write " + key + " = { value = 0.0, online = true })");
  return p;
}
}  // namespace

ModelFile parse_model_file(const std::string& source, const std::string& name) {
  toml::table root;
  try {
    root = toml::parse(source, name);
  } catch (const toml::parse_error& e) {
    throw ConfigError(name, static_cast<int>(e.source().begin.line),
                      static_cast<int>(e.source().begin.column), std::string(e.description()));
  }
  ModelFile f;
  f.path = name;
  bool have_schema = false;
  for (auto&& [k, v] : root) {
    const std::string key(k.str());
    if (key == "schema") {
      if (!v.is_integer()) fail(name, v, "'schema' must be an integer");
      f.schema = static_cast<int>(*v.value<std::int64_t>());
      if (f.schema != kModelSchema)
        fail(name, v, "schema " + std::to_string(f.schema) + " is not supported (this reader knows " +
                          std::to_string(kModelSchema) + ")");
      have_schema = true;
    } else if (key == "omega_unit") {
      f.omega_unit = text(name, v, key);
      // sigma of Tables 2-3 is per rpm (docs/model-notes.md decision); a file in rad/s would silently
      // scale every force by 9.5, so it is refused rather than guessed.
      if (f.omega_unit != "rpm")
        fail(name, v, "omega_unit '" + f.omega_unit + "' is not supported: sigma must be per rpm");
    } else if (key == "frame") {
      f.frame = text(name, v, key);
      if (f.frame != "rep103")
        fail(name, v, "frame '" + f.frame + "' is not supported (rep103: x forward, y left, psi CCW)");
    } else if (key == "robot") {
      const auto& t = as_table(name, v, key);
      RobotParams r;
      double phi_deg = 30, alpha_deg = 26.5;
      read_numbers(name, t, "[robot]",
                   {{"r_s_m", &r.r_s_m, true, 1},
                    {"phi_deg", &phi_deg, true, 1},
                    {"l_x_m", &r.l_x_m, true, 1},
                    {"l_y_m", &r.l_y_m, true, 1},
                    {"alpha_deg", &alpha_deg, true, 1},
                    {"m_kg", &r.m_kg, true, 1},
                    {"I_z_kgm2", &r.I_z_kgm2, true, 1},
                    {"omega_max_rpm", &r.omega_max_rpm, true, 1}},
                   line_of(v));
      r.phi_rad = deg_to_rad(phi_deg);
      r.alpha_rad = deg_to_rad(alpha_deg);
      f.robot = r;
      f.robot_line = line_of(v);
    } else if (key == "gantry") {
      double mass = 0;
      read_numbers(name, as_table(name, v, key), "[gantry]", {{"mass_kg", &mass, true, 1}}, line_of(v));
      f.gantry_mass_kg = mass;
    } else if (key == "terrain") {
      for (auto&& [tk, tv] : as_table(name, v, key)) {
        TerrainEntry e;
        e.params.name = std::string(tk.str());
        e.line = line_of(tv);
        TerrainParams& p = e.params;
        read_numbers(name, as_table(name, tv, "terrain." + p.name), "[terrain." + p.name + "]",
                     {{"sigma_long", &p.sigma_long, true, 1},
                      {"sigma_lat", &p.sigma_lat, true, 1},
                      {"D_x", &p.D_x, true, 1},
                      {"D_y", &p.D_y, true, 1},
                      {"D_psi", &p.D_psi, false, 1}},
                     e.line);
        f.terrains.push_back(std::move(e));
      }
    } else if (key == "effect") {
      if (!v.is_array_of_tables()) fail(name, v, "'effect' must be an array of tables ([[effect]])");
      for (auto&& item : *v.as_array()) {
        const auto& t = *item.as_table();
        EffectConfig c;
        c.file = name;
        c.line = line_of(item);
        c.column = col_of(item);
        bool have_id = false;
        for (auto&& [ek, ev] : t) {
          const std::string ekey(ek.str());
          if (ekey == "id") {
            c.id = text(name, ev, "id");
            have_id = true;
          } else if (ev.is_string()) {
            c.texts.push_back({ekey, text(name, ev, ekey), line_of(ev), col_of(ev)});
          } else if (ev.is_table()) {
            c.params.push_back(online_param(name, *ev.as_table(), ekey));
          } else {
            c.params.push_back({ekey, number(name, ev, ekey), line_of(ev), col_of(ev)});
          }
        }
        if (!have_id) throw ConfigError(name, c.line, c.column, "[[effect]] needs 'id'");
        f.effects.push_back(std::move(c));
      }
    } else if (key == "control") {
      read_control(name, as_table(name, v, key), f.control);
    } else {
      fail(name, v, "unknown key '" + key +
                        "' (known: schema, omega_unit, frame, robot, gantry, terrain, effect, control)");
    }
  }
  if (!have_schema) throw ConfigError(name, 1, 1, "model file needs 'schema = " + std::to_string(kModelSchema) + "'");
  return f;
}

ModelFile load_model_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path, 0, 0, "cannot open model file");
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse_model_file(ss.str(), path);
}

Model build_model(const ModelFile& f, const std::string& terrain, const EffectRegistry& registry) {
  if (!f.robot) throw ConfigError(f.path, 1, 1, "model file has no [robot]");
  const TerrainEntry* t = f.find_terrain(terrain);
  if (!t) throw ConfigError(f.path, 1, 1, "model file has no terrain '" + terrain + "'");
  if (!std::isfinite(t->params.D_psi))
    throw ConfigError(f.path, t->line, 1, "terrain '" + terrain + "' has no D_psi (needed for the robot)");
  std::vector<std::shared_ptr<const Effect>> effects;
  for (const auto& c : f.effects) effects.push_back(registry.create(c));
  try {
    return make_model(*f.robot, t->params, std::move(effects));
  } catch (const std::invalid_argument& e) {
    throw ConfigError(f.path, f.robot_line, 1, e.what());
  }
}

ControllerConfig controller_config(const ModelFile& f, const std::string& terrain) {
  ControllerConfig c;
  c.gains = table5_gains(terrain);
  if (f.robot) c.allocator.omega_max_rpm = f.robot->omega_max_rpm;
  const ControlSection& s = f.control;
  if (s.gamma_per_s) c.gamma_per_s = *s.gamma_per_s;
  if (s.kp) c.gains.kp = *s.kp;
  if (s.kd) c.gains.kd = *s.kd;
  if (s.ki) c.gains.ki = *s.ki;
  if (s.integral_limit) c.gains.integral_limit = *s.integral_limit;
  if (s.allocator) c.allocator.kind = *s.allocator;
  if (s.priority) c.allocator.priority = *s.priority;
  if (s.omega_min_rpm) c.allocator.omega_min_rpm = *s.omega_min_rpm;
  if (s.engage_rpm) c.allocator.engage_rpm = *s.engage_rpm;
  if (s.sign_hold_rpm) c.allocator.sign_hold_rpm = *s.sign_hold_rpm;
  if (s.estimator) c.estimator = *s.estimator;
  return c;
}

}  // namespace auger
