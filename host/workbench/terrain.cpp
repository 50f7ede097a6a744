// The terrain a subcommand analyses a log with (terrain.hpp).
#include "terrain.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "auger/model_file.hpp"
#include "cli_text.hpp"

namespace auger::wb {

namespace {

// RMS over the active channels of a terrain's nominal model's error over segments of 25 s, as
// multiples of the segment floor (compare's headline, without its windows and regimes).
double segment_ratio(const Dataset& d, const ModelChoice& mc, const ChannelValues& floor) {
  Prediction p;
  simulate(mc.model, d, sim_options_for(mc.model), p);
  const ErrorStats e = error_stats(d, p, floor);
  double s = 0;
  int n = 0;
  for (int c = 0; c < kChannels; ++c) {
    const auto k = static_cast<std::size_t>(c);
    if (!d.active[k] || !std::isfinite(e.ratio_to_noise[k])) continue;
    s += e.ratio_to_noise[k] * e.ratio_to_noise[k];
    ++n;
  }
  return n ? std::sqrt(s / n) : NAN;
}

std::string ratio_words(double r) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f", r);
  return b;
}

std::string listed(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

std::string command_for(const Dataset& d, const std::string& command, const std::string& args,
                        const std::string& terrain) {
  return "auger " + command + " " + typed(d.path) + args + " --terrain " + terrain;
}

}  // namespace

TerrainChoice choose_terrain(Dataset& data, const std::string& model_path, const std::string& option,
                             const std::string& command, const std::string& args) {
  TerrainChoice t;
  // The terrains one could choose among: the tables', or the model file's.
  std::vector<std::string> names;
  if (model_path.empty()) names = table_terrains(data.gantry);
  else
    for (const auto& e : load_model_file(model_path).terrains) names.push_back(e.params.name);
  const std::string where = model_path.empty() ? std::string("the paper's tables (") + (data.gantry ? "Table 2" : "Table 3") + ")"
                                               : "the model file " + model_path;
  const bool listed_name = std::find(names.begin(), names.end(), option) != names.end();
  if (!option.empty() && option != "auto" && !listed_name)
    throw std::runtime_error("--terrain '" + option + "': " + where + (model_path.empty() ? " have" : " has") + std::string(" the terrains ") + listed(names) +
                             " (or --terrain auto)");
  // The fits: with --terrain auto, and for the tables always (a log of another terrain than the
  // one it is analysed with is the first thing to rule out; two segment runs cost little).
  if (option == "auto" || model_path.empty()) {
    NoiseColour colour;
    const ChannelValues noise = estimate_noise_floor(data, &colour), floor = segment_floor(noise, colour);
    for (const auto& n : names) t.fits.push_back({n, segment_ratio(data, choose_model(data, model_path, n), floor)});
  }
  auto fit_of = [&](const std::string& n) {
    for (const auto& f : t.fits)
      if (f.terrain == n) return f.ratio;
    return static_cast<double>(NAN);
  };
  std::string fits_text;
  for (const auto& f : t.fits) fits_text += (fits_text.empty() ? "" : ", ") + f.terrain + " " + ratio_words(f.ratio);
  const std::string segs = " (segments of 25 s, RMS over channels as multiples of the noise floor: " + fits_text + ")";
  if (option == "auto") {
    const auto best = std::min_element(t.fits.begin(), t.fits.end(), [](const TerrainFit& a, const TerrainFit& b) {
      return std::isfinite(a.ratio) && (!std::isfinite(b.ratio) || a.ratio < b.ratio);
    });
    if (best == t.fits.end() || !std::isfinite(best->ratio))
      throw std::runtime_error("--terrain auto: no terrain of " + where + " predicts the log " + data.path);
    t.model = choose_model(data, model_path, best->terrain);
    t.from = "auto";
    t.warnings.push_back("--terrain auto: analysed as terrain '" + best->terrain + "', whose parameters in " + where +
                         " fit the log best" + segs +
                         (data.terrain.empty() || data.terrain == best->terrain
                              ? ""
                              : "; the log names '" + data.terrain + "'"));
    data.terrain = best->terrain;
    return t;
  }
  if (!option.empty()) {
    t.model = choose_model(data, model_path, option);
    t.from = "--terrain";
    if (!data.terrain.empty() && data.terrain != option)
      t.warnings.push_back("--terrain " + option + ": analysed as terrain '" + option + "', not the log's own '" +
                           data.terrain + "'");
    data.terrain = option;
  } else {
    t.model = choose_model(data, model_path);
    if (data.terrain.empty()) {
      t.from = "assumed";
      t.warnings.push_back("the log names no terrain (no `# terrain:` line): analysed as terrain '" + t.model.terrain +
                           "' from " + where + ", an assumption; --terrain NAME says which, --terrain auto picks the one "
                           "that fits best");
    } else {
      t.from = "log";
      if (const std::string w = terrain_warning(data, t.model); !w.empty()) {
        t.from = "log_unknown";
        t.warnings.push_back(w);
      }
    }
  }
  // Another table terrain that explains the log clearly better than the one used.
  const double used = fit_of(t.model.terrain);
  for (const auto& f : t.fits)
    if (f.terrain != t.model.terrain && std::isfinite(f.ratio) && std::isfinite(used) &&
        f.ratio < kTerrainClearlyBetter * used && (t.better.empty() || f.ratio < fit_of(t.better)))
      t.better = f.terrain;
  if (!t.better.empty())
    t.warnings.push_back("the paper's parameters for terrain '" + t.better + "' explain this log clearly better than those of '" +
                         t.model.terrain + "'" + segs + ": is it a log of " + t.better + "? " +
                         command_for(data, command, args, t.better));
  return t;
}

void json_terrain(Json& j, const TerrainChoice& t) {
  j.str("terrain", t.model.terrain).str("terrain_from", t.from).str("terrain_better", t.better);
  j.begin_object("terrain_fits");
  for (const auto& f : t.fits) j.num(f.terrain.c_str(), f.ratio);
  j.end_object();
}

std::string terrain_text(const TerrainChoice& t) {
  const std::string why = t.from == "assumed"     ? "assumed: the log names none; --terrain NAME or --terrain auto"
                          : t.from == "auto"      ? "--terrain auto: the best fit"
                          : t.from == "--terrain" ? "--terrain"
                          : t.from == "log_unknown" ? "assumed: the log's `# terrain:` is not in the model"
                                                  : "the log's `# terrain:`";
  std::string s = "terrain: " + t.model.terrain + " (" + why + ")";
  if (!t.fits.empty()) {
    s += "; each terrain's nominal model over segments of 25 s, RMS over channels:";
    for (const auto& f : t.fits) s += " " + f.terrain + " " + ratio_words(f.ratio);
    s += " times the noise floor";
  }
  return s;
}

std::string terrain_next(const Dataset& data, const TerrainChoice& t, const std::string& command,
                         const std::string& args) {
  if (t.better.empty()) return "";
  return command_for(data, command, args, t.better) + " (the paper's parameters for " + t.better +
         " explain the log clearly better than " + t.model.terrain + "'s)";
}

}  // namespace auger::wb
