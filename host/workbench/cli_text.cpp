// What the workbench's subcommands print (cli_text.hpp).
#include "cli_text.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace auger::wb {

std::string with_unit(double value, const std::string& unit, int digits) {
  if (!std::isfinite(value)) return "-";
  char b[48];
  std::snprintf(b, sizeof b, "%.*g", digits, value);
  return unit.empty() || unit == "-" ? std::string(b) : std::string(b) + " " + unit;
}

std::string ratio_cell(double ratio) {
  if (!std::isfinite(ratio)) return "-";
  char b[32];
  std::snprintf(b, sizeof b, ratio < 100 ? "%.2f" : "%.1f", ratio);
  return b;
}

std::string times_noise(double ratio) {
  if (!std::isfinite(ratio)) return "-";
  return ratio_cell(ratio) + " times the noise floor";
}

std::string terrain_warning(const Dataset& data, const ModelChoice& model) {
  if (data.terrain.empty() || data.terrain == model.terrain) return "";
  return "the log's terrain '" + data.terrain + "' is not in the model; analysed as terrain '" + model.terrain +
         "' (for its own parameters: --model FILE with that terrain, docs/model.md)";
}

void print_warnings(const char* command, const std::vector<std::string>& warnings) {
  for (const auto& w : warnings) std::fprintf(stderr, "auger %s: warning: %s\n", command, w.c_str());
}

std::string param_text(const FitParam& p) {
  const std::string unit = p.unit.empty() || p.unit == "-" ? "" : " " + p.unit;
  char b[160];
  if (std::isfinite(p.sigma))
    std::snprintf(b, sizeof b, "%s = %.4g +- %.2g%s", p.name.c_str(), p.value, p.sigma, unit.c_str());
  else
    std::snprintf(b, sizeof b, "%s = %.4g%s (no uncertainty: searched on a grid or held)", p.name.c_str(), p.value, unit.c_str());
  return b;
}

bool any_flagged(const FittedEffect& e) {
  for (const auto& p : e.params)
    if (!p.flag.empty()) return true;
  return false;
}

void print_fitted(std::FILE* f, const FittedEffect& e, const char* indent) {
  std::string line;
  for (const auto& p : e.params) line += (line.empty() ? "" : "; ") + param_text(p);
  std::fprintf(f, "%s%s\n", indent, line.c_str());
  for (const auto& p : e.params)
    if (!p.flag.empty()) std::fprintf(f, "%sFLAG %s: %s\n", indent, p.name.c_str(), p.flag.c_str());
}

void json_fitted(Json& j, const char* key, const std::vector<FittedEffect>& effects) {
  j.begin_array(key);
  for (const auto& e : effects) {
    j.begin_object().str("effect", e.effect).str("description", e.description);
    for (const auto& [name, value] : e.texts) j.str(name.c_str(), value);
    j.begin_object("params");
    for (const auto& p : e.params) j.num(p.name.c_str(), p.value);
    j.end_object().begin_object("params_sigma");
    for (const auto& p : e.params) j.num(p.name.c_str(), p.sigma);
    j.end_object().begin_object("flags");
    for (const auto& p : e.params)
      if (!p.flag.empty()) j.str(p.name.c_str(), p.flag);
    j.end_object().boolean("flagged", any_flagged(e)).end_object();
  }
  j.end_array();
}

RankGroup rank_group(const Candidate& c, double nominal_heldout_ratio) {
  if (!lowers_heldout(c, nominal_heldout_ratio)) return RankGroup::kNoImprovement;
  return c.implausible ? RankGroup::kImprovesImplausible : RankGroup::kImproves;
}

const char* rank_group_id(RankGroup g) {
  switch (g) {
    case RankGroup::kImproves: return "improves";
    case RankGroup::kImprovesImplausible: return "improves_implausible";
    case RankGroup::kNoImprovement: return "no_improvement";
  }
  return "";
}

const char* rank_group_words(RankGroup g) {
  switch (g) {
    case RankGroup::kImproves:
    case RankGroup::kImprovesImplausible:
      return "lower the held-out error by 2 % or more (an implausible fit's counted 15 % higher)";
    case RankGroup::kNoImprovement:
      return "do not lower the held-out error by 2 % (a training-data gain that does not carry over)";
  }
  return "";
}

const char* const kRankingRule =
    "candidates that lower the held-out error by 2 % or more (as explain asks of a step) come first, lower held-out "
    "error first, that of an implausible fit (a value at or beyond its physical range; a parameter flagged only as "
    "not identified does not count) taken as 15 % higher (as explain ranks a step's candidates; held-out errors "
    "within 2 % of each other by lower delta BIC); among the rest lower delta BIC first";

std::string typed(const std::string& path) {
  bool plain = !path.empty();
  for (char c : path)
    plain = plain && ((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
                      c == '_' || c == '/' || c == '-');
  if (plain) return path;
  std::string q = "'";
  for (char c : path) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::vector<std::string> split_ids(const std::string& text) {
  std::vector<std::string> ids;
  std::stringstream ss(text);
  std::string id;
  while (std::getline(ss, id, ','))
    if (!id.empty()) ids.push_back(id);
  return ids;
}

bool known_effects(const char* program, const std::vector<std::string>& ids) {
  const std::vector<LibraryEffect> library = effect_library();
  for (const auto& id : ids)
    if (std::none_of(library.begin(), library.end(), [&](const LibraryEffect& le) { return le.id == id; })) {
      std::fprintf(stderr, "%s: unknown effect '%s' (auger effects lists them)\n", program, id.c_str());
      return false;
    }
  return true;
}

}  // namespace auger::wb
