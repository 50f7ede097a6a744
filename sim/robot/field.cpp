// Field files: see field.hpp and docs/robot-sim.md "Fields".
#include "field.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include <toml++/toml.h>

namespace auger::sim {
namespace {

constexpr int kFieldSchema = 1;

[[noreturn]] void fail(const std::string& file, const toml::node& n, const std::string& msg) {
  throw ConfigError(file, static_cast<int>(n.source().begin.line), static_cast<int>(n.source().begin.column), msg);
}

double number(const std::string& file, const toml::node& n, const std::string& key) {
  if (!n.is_number()) fail(file, n, "'" + key + "' must be a number");
  const double v = *n.value<double>();
  if (!std::isfinite(v)) fail(file, n, "'" + key + "' must be finite");
  return v;
}

std::string text(const std::string& file, const toml::node& n, const std::string& key) {
  if (!n.is_string()) fail(file, n, "'" + key + "' must be a string");
  return *n.value<std::string>();
}

double cross(const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}

// Closed segments ab and cd share a point (touching counts).
bool segments_meet(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                   const Eigen::Vector2d& d) {
  const double d1 = cross(c, d, a), d2 = cross(c, d, b), d3 = cross(a, b, c), d4 = cross(a, b, d);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) return true;
  auto on = [](const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& r, double o) {
    return o == 0 && std::min(p.x(), q.x()) <= r.x() && r.x() <= std::max(p.x(), q.x()) &&
           std::min(p.y(), q.y()) <= r.y() && r.y() <= std::max(p.y(), q.y());
  };
  return on(c, d, a, d1) || on(c, d, b, d2) || on(a, b, c, d3) || on(a, b, d, d4);
}

std::vector<Eigen::Vector2d> read_polygon(const std::string& file, const toml::node& n) {
  const toml::array* a = n.as_array();
  if (!a) fail(file, n, "'polygon' must be an array of [x_m, y_m] points");
  std::vector<Eigen::Vector2d> poly;
  for (const toml::node& p : *a) {
    const toml::array* xy = p.as_array();
    if (!xy || xy->size() != 2) fail(file, p, "each point of 'polygon' must be [x_m, y_m]");
    poly.emplace_back(number(file, *xy->get(0), "polygon"), number(file, *xy->get(1), "polygon"));
  }
  if (poly.size() >= 2 && poly.front() == poly.back()) poly.pop_back();  // a closed ring is fine
  if (poly.size() < 3) fail(file, n, "'polygon' needs at least 3 distinct points, has " + std::to_string(poly.size()));
  // A simple polygon: no two edges meet except adjacent ones at their shared vertex.
  const std::size_t k = poly.size();
  for (std::size_t i = 0; i < k; ++i)
    for (std::size_t j = i + 1; j < k; ++j) {
      const bool adjacent = j == i + 1 || (i == 0 && j == k - 1);
      if (adjacent) continue;
      if (segments_meet(poly[i], poly[(i + 1) % k], poly[j], poly[(j + 1) % k]))
        fail(file, n, "'polygon' crosses itself: edge " + std::to_string(i + 1) + " meets edge " + std::to_string(j + 1) +
                          " (edge n runs from point n to the next)");
    }
  double area2 = 0;
  for (std::size_t i = 0; i < poly.size(); ++i) area2 += cross(Eigen::Vector2d::Zero(), poly[i], poly[(i + 1) % poly.size()]);
  if (!(std::fabs(area2) > 1e-12)) fail(file, n, "'polygon' encloses no area");
  return poly;
}

std::vector<Eigen::Vector2d> read_rect(const std::string& file, const toml::node& n) {
  const toml::array* a = n.as_array();
  if (!a || a->size() != 4) fail(file, n, "'rect' must be [x_min_m, y_min_m, x_max_m, y_max_m]");
  double v[4];
  for (std::size_t i = 0; i < 4; ++i) v[i] = number(file, *a->get(i), "rect");
  if (!(v[0] < v[2]) || !(v[1] < v[3])) fail(file, n, "'rect' needs x_min < x_max and y_min < y_max");
  return {{v[0], v[1]}, {v[2], v[1]}, {v[2], v[3]}, {v[0], v[3]}};
}

// The keys a zone may have (the background's at the top level, a patch's in its table).
void read_zone_key(const std::string& file, const std::string& key, const toml::node& v, FieldZone& z,
                   const toml::node** terrain_node) {
  if (key == "terrain") {
    z.terrain_name = text(file, v, key);
    *terrain_node = &v;
  } else if (key == "sigma_scale" || key == "drag_scale") {
    const double s = number(file, v, key);
    if (!(s > 0)) fail(file, v, "'" + key + "' must be > 0");
    (key == "sigma_scale" ? z.sigma_scale : z.drag_scale) = s;
  } else if (key == "blocking_rpm") {
    const double b = number(file, v, key);
    if (!(b >= 0)) fail(file, v, "'blocking_rpm' must be >= 0 (0: no blocking)");
    z.blocking_rpm = b;
  }
}

void resolve_terrain(const std::string& file, const ModelFile& model, const toml::node* where, int line,
                     FieldZone& z, Field& f) {
  if (z.terrain_name.empty()) throw ConfigError(file, line, 1, (z.polygon.empty() ? std::string("the field") : "patch '" + z.name + "'") + " needs 'terrain'");
  const TerrainEntry* t = model.find_terrain(z.terrain_name);
  auto bad = [&](const std::string& msg) {
    if (where) fail(file, *where, msg);
    throw ConfigError(file, line, 1, msg);
  };
  if (!t) {
    std::string known;
    for (const auto& e : model.terrains) known += (known.empty() ? "" : ", ") + e.params.name;
    bad("terrain '" + z.terrain_name + "' is not in the model file " + model.path + " (known: " + known + ")");
  }
  if (!std::isfinite(t->params.D_psi))
    bad("terrain '" + z.terrain_name + "' has no D_psi in " + model.path + " (a gantry set?): the robot needs one");
  z.terrain = t->params;
  z.terrain.sigma_long *= z.sigma_scale;
  z.terrain.sigma_lat *= z.sigma_scale;
  z.terrain.D_x *= z.drag_scale;
  z.terrain.D_y *= z.drag_scale;
  z.terrain.D_psi *= z.drag_scale;
  const auto it = std::find(f.terrain_names.begin(), f.terrain_names.end(), z.terrain_name);
  z.terrain_id = static_cast<int>(it - f.terrain_names.begin());
  if (it == f.terrain_names.end()) f.terrain_names.push_back(z.terrain_name);
}

}  // namespace

bool point_in_polygon(const std::vector<Eigen::Vector2d>& poly, double x, double y) {
  bool inside = false;
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Eigen::Vector2d& a = poly[i];
    const Eigen::Vector2d& b = poly[j];
    // Half-open in y: an edge counts when y lies in [min, max) of its ends.
    if ((a.y() > y) != (b.y() > y) && x < (b.x() - a.x()) * (y - a.y()) / (b.y() - a.y()) + a.x()) inside = !inside;
  }
  return inside;
}

int Field::zone_at(double x, double y) const {
  for (std::size_t k = zones.size(); k-- > 1;) {
    const FieldZone& z = zones[k];
    if (x < z.box_min.x() || x > z.box_max.x() || y < z.box_min.y() || y > z.box_max.y()) continue;
    if (point_in_polygon(z.polygon, x, y)) return static_cast<int>(k);
  }
  return 0;
}

Field parse_field(const std::string& source, const std::string& name, const ModelFile& model) {
  toml::table root;
  try {
    root = toml::parse(source, name);
  } catch (const toml::parse_error& e) {
    throw ConfigError(name, static_cast<int>(e.source().begin.line), static_cast<int>(e.source().begin.column),
                      std::string(e.description()));
  }
  Field f;
  f.path = name;
  FieldZone bg;
  bg.name = "background";
  bg.line = 1;
  const toml::node* bg_terrain = nullptr;
  bool have_schema = false;
  const toml::array* patches = nullptr;
  for (auto&& [k, v] : root) {
    const std::string key(k.str());
    if (key == "schema") {
      if (!v.is_integer() || *v.value<std::int64_t>() != kFieldSchema)
        fail(name, v, "'schema' must be " + std::to_string(kFieldSchema));
      have_schema = true;
    } else if (key == "name") {
      f.name = text(name, v, key);
    } else if (key == "patch") {
      patches = v.as_array();
      if (!patches || !patches->is_array_of_tables()) fail(name, v, "'patch' must be [[patch]] tables");
    } else if (key == "terrain" || key == "sigma_scale" || key == "drag_scale" || key == "blocking_rpm") {
      read_zone_key(name, key, v, bg, &bg_terrain);
    } else {
      fail(name, v, "unknown key '" + key + "' (known: schema, name, terrain, sigma_scale, drag_scale, blocking_rpm, [[patch]])");
    }
  }
  if (!have_schema) throw ConfigError(name, 1, 1, "the field needs 'schema = 1'");
  resolve_terrain(name, model, bg_terrain, 1, bg, f);
  f.zones.push_back(bg);
  if (patches) {
    int n = 0;
    for (const toml::node& pn : *patches) {
      const toml::table& t = *pn.as_table();
      FieldZone z;
      z.line = static_cast<int>(pn.source().begin.line);
      z.name = "patch " + std::to_string(++n);
      const toml::node* terrain = nullptr;
      const toml::node* shape = nullptr;
      for (auto&& [k, v] : t) {
        const std::string key(k.str());
        if (key == "name") {
          z.name = text(name, v, key);
        } else if (key == "polygon" || key == "rect") {
          if (shape) fail(name, v, "patch '" + z.name + "' has both 'polygon' and 'rect': give one");
          shape = &v;
          z.polygon = key == "polygon" ? read_polygon(name, v) : read_rect(name, v);
        } else if (key == "terrain" || key == "sigma_scale" || key == "drag_scale" || key == "blocking_rpm") {
          read_zone_key(name, key, v, z, &terrain);
        } else {
          fail(name, v, "unknown key '" + key + "' in [[patch]] (known: name, terrain, polygon, rect, sigma_scale, "
                        "drag_scale, blocking_rpm)");
        }
      }
      if (!shape) throw ConfigError(name, z.line, 1, "patch '" + z.name + "' needs 'polygon' or 'rect'");
      resolve_terrain(name, model, terrain, z.line, z, f);
      z.box_min = z.box_max = z.polygon.front();
      for (const auto& p : z.polygon) {
        z.box_min = z.box_min.cwiseMin(p);
        z.box_max = z.box_max.cwiseMax(p);
      }
      f.zones.push_back(std::move(z));
    }
  }
  return f;
}

Field load_field(const std::string& path, const ModelFile& model) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(path, 0, 0, "cannot read the field file");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_field(text.str(), path, model);
}

Field uniform_field(const ModelFile& model, const std::string& terrain) {
  Field f;
  f.path = "(uniform " + terrain + ")";
  FieldZone z;
  z.name = "background";
  z.terrain_name = terrain;
  resolve_terrain(model.path, model, nullptr, 0, z, f);
  f.zones.push_back(z);
  return f;
}

std::vector<std::string> ground_columns() {
  return {"terrain_id", "terrain_id_0", "terrain_id_1", "terrain_id_2", "terrain_id_3", "zone",
          "true_sigma_long", "true_sigma_lat", "true_D_x", "true_D_y", "true_D_psi"};
}

void ground_values(const Field& field, int centre_zone, const std::array<int, 4>& contact_zones,
                   std::vector<double>& out) {
  out.assign(11, 0.0);
  out[0] = field.zone(centre_zone).terrain_id;
  for (std::size_t i = 0; i < 4; ++i) {
    const FieldZone& z = field.zone(contact_zones[i]);
    out[1 + i] = z.terrain_id;
    out[6] += 0.25 * z.terrain.sigma_long;
    out[7] += 0.25 * z.terrain.sigma_lat;
    out[8] += 0.25 * z.terrain.D_x;
    out[9] += 0.25 * z.terrain.D_y;
    out[10] += 0.25 * z.terrain.D_psi;
  }
  out[5] = centre_zone;
  if (contact_zones[1] == contact_zones[0] && contact_zones[2] == contact_zones[0] && contact_zones[3] == contact_zones[0]) {
    const TerrainParams& t = field.zone(contact_zones[0]).terrain;  // exactly the zone's, not a rounded mean
    out[6] = t.sigma_long, out[7] = t.sigma_lat, out[8] = t.D_x, out[9] = t.D_y, out[10] = t.D_psi;
  }
}

std::string terrain_ids_metadata(const Field& field) {
  std::string s;
  for (std::size_t i = 0; i < field.terrain_names.size(); ++i)
    s += (i ? " " : "") + std::to_string(i) + "=" + field.terrain_names[i];
  return s;
}

double default_blocking_rpm(const std::string& terrain_name) { return terrain_name == "sand" ? 1.5 : 0.0; }

void default_blocking(Field& field, std::optional<double> rpm) {
  for (auto& z : field.zones)
    if (!z.blocking_rpm) z.blocking_rpm = rpm ? *rpm : default_blocking_rpm(z.terrain_name);
}

std::shared_ptr<const Field> load_field_for_run(const std::string& path, const ModelFile& model, double blocking_rpm,
                                                std::string& terrain) {
  auto field = std::make_shared<Field>(load_field(path, model));
  default_blocking(*field, blocking_rpm >= 0 ? std::optional<double>(blocking_rpm) : std::nullopt);
  if (terrain.empty()) terrain = field->zones[0].terrain_name;
  return field;
}

}  // namespace auger::sim
