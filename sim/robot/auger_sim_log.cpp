// auger-sim-log: writes robot or gantry logs (docs/log-format.md) with one hidden effect, in batch
// (ideal screws, no firmware, no pacing). docs/robot-sim.md "auger-sim-log".
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <string>

#include "auger/args.hpp"
#include "auger/model_file.hpp"
#include "log_gen.hpp"

namespace {

const auger::CommandLine kCli{
    "auger-sim-log",
    "--out FILE [--effect ID[:name=value,...]]... [OPTIONS]",
    "A robot log (gantry log with --gantry) of the simulated truth with hidden effects, driven\n"
    "open loop by ideal screws; metadata only format and terrain (gantry: also axis, mass_kg).\n"
    "A summary (effect size, resolved parameters) goes to stderr as one JSON line.\n",
    {{"--out", "FILE", "the log to write"},
     {"--effect", "ID[:name=value,...]", "a hidden effect (again for each; default none; a gantry log\n"
      "takes one)"},
     {"--seed", "N", "the random seed (default 1)"},
     {"--trajectory", "single-dof|manual", "the screw speeds driven (default manual)"},
     {"--seconds", "S", "the log's length (default 150 s)"},
     {"--terrain", "NAME", "the terrain (default sand)"},
     {"--gantry", "longitudinal|lateral", "a gantry log along that axis"},
     {"--model", "FILE", "the true model file (default " AUGER_DEFAULT_MODEL ",\n"
      "gantry: " AUGER_DEFAULT_GANTRY_MODEL ")"},
     {"--pose-noise-m", "S", "camera position noise (default 0.003 m)"},
     {"--psi-noise-rad", "S", "camera heading noise (default 0.005 rad)"},
     {"--pose-rate-hz", "F", "camera rate (default 20 Hz)"},
     {"--imu-psi-noise-rad", "S", "IMU heading noise (default 0.005 rad)"},
     {"--imu-r-noise-radps", "S", "IMU yaw rate noise (default 0.003 rad/s)"},
     {"--gantry-position-noise-m", "S", "gantry position noise (default 0.002 m)"},
     {"--gantry-force-noise-n", "S", "gantry force noise (default 0.5 N)"},
     {"--physical-base", "", "the robot's base physics is the physical robot's (Coriolis\n"
      "terms, the real lever arms' yaw time constant, blocking of screws\n"
      "slower than --blocking-rpm on sand), not the paper's linear model"},
     {"--blocking-rpm", "X", "with --physical-base: screw blocking speed (default 1.5 rpm)"},
     {"--truth-out", "FILE", "write the true pose and where the effect acts there"},
     {"--list-effects", "", "list the effects and their parameters, then exit"}},
    "Exit 2: bad usage.\n"};

void usage(std::FILE* f) { kCli.print_usage(f); }

double number(const char* opt, const char* text) {
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0') {
    std::fprintf(stderr, "auger-sim-log: %s: '%s' is not a number\n", opt, text);
    std::exit(2);
  }
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  auger::sim::LogGenConfig cfg;
  std::string out_path, truth_path, model_path;
  bool terrain_given = false;
  auger::Args args;
  if (const int rc = kCli.parse_or_answer(argc, argv, args); rc >= 0) return rc;
  if (!args.positional.empty()) {
    std::fprintf(stderr, "auger-sim-log: unknown option '%s'\n", args.positional[0].c_str());
    usage(stderr);
    return 2;
  }
  for (const auto& [a, value] : args.options) {  // in order: --effect repeats, the last of others wins
    auto val = [&value = value] { return value.c_str(); };
    try {
      if (a == "--out") out_path = val();
      else if (a == "--truth-out") truth_path = val();
      else if (a == "--model") model_path = val();
      else if (a == "--effect") cfg.effects.push_back(auger::sim::parse_effect_spec(val()));
      else if (a == "--physical-base") cfg.physical_base = true;
      else if (a == "--blocking-rpm") cfg.blocking_rpm = number("--blocking-rpm", val());
      else if (a == "--seed") cfg.seed = static_cast<std::uint64_t>(number("--seed", val()));
      else if (a == "--seconds") cfg.seconds = number("--seconds", val());
      else if (a == "--terrain") { cfg.terrain = val(); terrain_given = true; }
      else if (a == "--pose-noise-m") { const double s = number("--pose-noise-m", val()); cfg.pose_noise[0] = cfg.pose_noise[1] = s; }
      else if (a == "--psi-noise-rad") cfg.pose_noise[2] = number("--psi-noise-rad", val());
      else if (a == "--pose-rate-hz") cfg.pose_rate_hz = number("--pose-rate-hz", val());
      else if (a == "--imu-psi-noise-rad") cfg.imu_psi_noise_rad = number("--imu-psi-noise-rad", val());
      else if (a == "--imu-r-noise-radps") cfg.imu_r_noise_radps = number("--imu-r-noise-radps", val());
      else if (a == "--gantry-position-noise-m") cfg.gantry_position_noise_m = number("--gantry-position-noise-m", val());
      else if (a == "--gantry-force-noise-n") cfg.gantry_force_noise_n = number("--gantry-force-noise-n", val());
      else if (a == "--trajectory") {
        const std::string t = val();
        if (t == "single-dof") cfg.trajectory = auger::sim::Trajectory::single_dof;
        else if (t == "manual") cfg.trajectory = auger::sim::Trajectory::manual;
        else { std::fprintf(stderr, "auger-sim-log: --trajectory: '%s' is not single-dof or manual\n", t.c_str()); return 2; }
      } else if (a == "--gantry") {
        const std::string g = val();
        if (g == "longitudinal") cfg.gantry = auger::sim::GantryAxis::longitudinal;
        else if (g == "lateral") cfg.gantry = auger::sim::GantryAxis::lateral;
        else { std::fprintf(stderr, "auger-sim-log: --gantry: '%s' is not longitudinal or lateral\n", g.c_str()); return 2; }
      } else if (a == "--list-effects") {
        for (const auto& e : auger::sim::known_effects()) {
          std::printf("%-20s %s%s  ", e.id.c_str(), e.robot ? "robot" : "", e.gantry ? (e.robot ? ",gantry" : "gantry") : "");
          for (const auto& [n, v] : e.params) std::printf("%s=%g ", n.c_str(), v);
          std::printf(" # %s\n", e.doc.c_str());
        }
        return 0;
      }
    } catch (const std::exception& ex) {
      std::fprintf(stderr, "auger-sim-log: %s: %s\n", a.c_str(), ex.what());
      return 2;
    }
  }
  if (out_path.empty()) { usage(stderr); return 2; }
  const bool gantry = cfg.gantry != auger::sim::GantryAxis::none;
  if (!terrain_given) cfg.terrain = "sand";
  if (model_path.empty()) model_path = gantry ? AUGER_DEFAULT_GANTRY_MODEL : AUGER_DEFAULT_MODEL;
  try {
    const auto wall0 = std::chrono::steady_clock::now();
    const auger::ModelFile file = auger::load_model_file(model_path);
    std::ofstream out(out_path);
    if (!out) { std::fprintf(stderr, "auger-sim-log: cannot write %s\n", out_path.c_str()); return 1; }
    auger::sim::LogGenResult res;
    if (gantry) {
      const auger::TerrainEntry* t = file.find_terrain(cfg.terrain);
      if (!t) { std::fprintf(stderr, "auger-sim-log: %s has no terrain '%s'\n", model_path.c_str(), cfg.terrain.c_str()); return 2; }
      if (!file.gantry_mass_kg) { std::fprintf(stderr, "auger-sim-log: %s has no [gantry] mass_kg\n", model_path.c_str()); return 2; }
      res = auger::sim::generate_gantry_log(t->params, *file.gantry_mass_kg, cfg, out);
    } else {
      res = auger::sim::generate_robot_log(auger::build_model(file, cfg.terrain), cfg, out);
    }
    out.close();
    if (!out) { std::fprintf(stderr, "auger-sim-log: writing %s failed\n", out_path.c_str()); return 1; }
    if (!truth_path.empty()) {
      std::ofstream tr(truth_path);
      auger::sim::write_truth(res, tr);
      if (!tr) { std::fprintf(stderr, "auger-sim-log: writing %s failed\n", truth_path.c_str()); return 1; }
    }
    const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    std::string ids;
    for (const auto& e : cfg.effects) ids += (ids.empty() ? "\"" : ", \"") + e.id + "\"";
    std::fprintf(stderr, "{\"effects\": [%s], \"effect_rms\": [%.6g, %.6g, %.6g], \"rows\": %zu, \"wall_s\": %.3f",
                 ids.c_str(), res.effect_rms[0], res.effect_rms[1], res.effect_rms[2], res.truth.size(), wall_s);
    for (std::size_t i = 0; i < res.notes.size(); ++i) std::fprintf(stderr, "%s\"%s\"", i ? ", " : ", \"notes\": [", res.notes[i].c_str());
    std::fprintf(stderr, "%s}\n", res.notes.empty() ? "" : "]");
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "auger-sim-log: %s\n", ex.what());
    return 1;
  }
  return 0;
}
