// A field for the simulated robot (docs/robot-sim.md "Fields"): terrain patches in the world
// frame, read from a TOML file, so the truth's terrain changes where the robot is. Each zone
// (the background, then each [[patch]] in file order) carries one terrain of the model file,
// optionally scaled, and its blocking threshold; the true robot looks up the zone under each
// screw's contact point (true_robot.hpp).
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "auger/model.hpp"
#include "auger/model_file.hpp"

namespace auger::sim {

struct FieldZone {
  std::string name;            // the patch's `name` (the background: "background")
  std::string terrain_name;    // a [terrain.NAME] of the model file
  int terrain_id = 0;          // index into Field::terrain_names
  TerrainParams terrain;       // the model file's row times sigma_scale and drag_scale
  double sigma_scale = 1.0, drag_scale = 1.0;
  std::optional<double> blocking_rpm;  // screws slower than this block here (0: off); unset: the caller's default
  std::vector<Eigen::Vector2d> polygon;  // world frame, m; empty for the background
  Eigen::Vector2d box_min = Eigen::Vector2d::Zero(), box_max = Eigen::Vector2d::Zero();
  int line = 0;                // where the file defines it
};

struct Field {
  std::string path;
  std::string name;
  std::vector<std::string> terrain_names;  // distinct terrains in order of first use; id = index
  std::vector<FieldZone> zones;            // zones[0]: the background; zones[k]: the k-th [[patch]]
  // The zone at a world point: the last patch whose polygon contains it (a later patch lies on
  // top of an earlier one), else 0. Edges are half-open (even-odd crossing rule), so a point on
  // the shared edge of two adjacent patches belongs to exactly one of them.
  int zone_at(double x_m, double y_m) const;
  const FieldZone& zone(int id) const { return zones[static_cast<std::size_t>(id)]; }
};

// Even-odd point-in-polygon test (a simple polygon, vertices in either order).
bool point_in_polygon(const std::vector<Eigen::Vector2d>& polygon, double x_m, double y_m);

// Parses a field file's text; name is what errors call the source, model the model file whose
// terrains the patches name. Throws ConfigError (file:line:column: message).
Field parse_field(const std::string& text, const std::string& name, const ModelFile& model);
Field load_field(const std::string& path, const ModelFile& model);

// A field of one terrain everywhere (no patches), for the ground columns of a uniform run.
Field uniform_field(const ModelFile& model, const std::string& terrain);

// The truth log's ground columns (docs/robot-sim.md "Fields"): terrain_id (under the body's
// centre), terrain_id_0 .. terrain_id_3 (under each screw's contact), zone (under the centre: 0
// the background, k the k-th [[patch]]), and the true terrain parameters as the nominal model
// would see them, the mean over the four contacts' zones: true_sigma_long, true_sigma_lat
// (N/rpm), true_D_x, true_D_y (N s/m), true_D_psi (N m s/rad). The mean is exact for the
// translation drag (each contact carries a quarter of its zone's D_x, D_y).
std::vector<std::string> ground_columns();
void ground_values(const Field& field, int centre_zone, const std::array<int, 4>& contact_zones,
                   std::vector<double>& out);
// "0=sand 1=frozen_grass": what the terrain ids of the ground columns name.
std::string terrain_ids_metadata(const Field& field);

// Sets every zone's unset blocking_rpm: `rpm` if given, else 1.5 on sand and 0 elsewhere (the
// rule auger-sim-drive applies to --terrain).
void default_blocking(Field& field, std::optional<double> rpm);
double default_blocking_rpm(const std::string& terrain_name);

// A program's --field: the file loaded and default_blocking applied (blocking_rpm >= 0: the
// program's --blocking-rpm); an empty terrain (the controller's and the log's) becomes the
// field's background terrain.
std::shared_ptr<const Field> load_field_for_run(const std::string& path, const ModelFile& model, double blocking_rpm,
                                                std::string& terrain);

}  // namespace auger::sim
