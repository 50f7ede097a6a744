// What the workbench's subcommands print, in one place: numbers with their units, multiples of
// the noise floor named in words (never a bare "x" beside the channel x), fitted parameters
// with their flags, the ranking rule of diagnose, the terrain warning and the "next:" command.
// Used by compare, diagnose, fit, explain and report (docs/workbench.md "Reading the output").
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include "auger/args.hpp"
#include "workbench.hpp"

namespace auger::wb {

// The --model option of every subcommand that runs the model against a log (choose_model).
inline const OptionDoc kModelOption{"--model", "FILE", "the model file (default: the shipped model for the log's kind)"};

// "0.0976 m" (4 significant digits by default), "-" for NaN.
std::string with_unit(double value, const std::string& unit, int digits = 4);
// "34.11 times the noise floor" ("-" for NaN).
std::string times_noise(double ratio);
// A multiple of the noise floor for a table whose title names it: "34.11", "-" for NaN.
std::string ratio_cell(double ratio);

// A log's metadata terrain that the model does not have (the analysis then uses another one):
// the warning naming both, or "" when the log's terrain is the one used.
std::string terrain_warning(const Dataset& data, const ModelChoice& model);
// Prints each warning as "auger CMD: warning: ..." on stderr.
void print_warnings(const char* command, const std::vector<std::string>& warnings);

// "force_x_n = 7.983 +- 0.0058 N" (or "... (held, not fitted)" without an uncertainty).
std::string param_text(const FitParam& p);
// Every parameter of a fitted effect on one line, then one "FLAG name: why" line per flagged one.
void print_fitted(std::FILE* f, const FittedEffect& e, const char* indent);
bool any_flagged(const FittedEffect& e);
// JSON array of fitted effects: effect, description, params, params_sigma, flags (name -> why,
// only flagged parameters), flagged.
void json_fitted(Json& j, const char* key, const std::vector<FittedEffect>& effects);

// diagnose's ranking (search_diagnose.cpp ranks_before), in words: the group a candidate falls
// in, its name in the JSON, and the rule. The text and the report head the candidates that
// lower the held-out error once (plausible and implausible fits rank together: heading_group).
enum class RankGroup { kImproves, kImprovesImplausible, kNoImprovement };
RankGroup rank_group(const Candidate& c, double nominal_heldout_ratio);
const char* rank_group_id(RankGroup g);     // "improves", "improves_implausible", "no_improvement"
const char* rank_group_words(RankGroup g);  // a heading for the group's rows
// The group a heading covers: kImproves for every candidate that lowers the held-out error.
inline RankGroup heading_group(RankGroup g) {
  return g == RankGroup::kImprovesImplausible ? RankGroup::kImproves : g;
}
extern const char* const kRankingRule;

// "a,b,,c" -> {"a", "b", "c"}: the effect ids of --add and --only.
std::vector<std::string> split_ids(const std::string& text);
// True if every id is an effect of the library (auger effects); else prints, naming the first
// unknown one, "PROGRAM: unknown effect 'ID' (auger effects lists them)".
bool known_effects(const char* program, const std::vector<std::string>& ids);

// A path as it would be typed in a shell (quoted when it holds anything but [A-Za-z0-9._/-]),
// for the "next:" commands the subcommands print. Display only: nothing here is run.
std::string typed(const std::string& path);

}  // namespace auger::wb
