// The paper's identification of sigma and D from gantry logs (eqs. (11)-(17), docs/model-notes.md
// "Identification"), with confidence intervals. Called by `auger identify` (identify.cpp) and by
// the tests; pure computation on logs already in memory.
#pragma once

#include <string>
#include <vector>

namespace auger::wb {

// One gantry log in memory. drive_rpm is B_axis . omega_s of eqs. (12)/(14): B_x = [-1, -1] for
// the longitudinal rig, B_y = [-1, 1] for the lateral one, so that force ~ sigma * drive_rpm.
struct GantryData {
  std::string file;
  std::string axis;     // "longitudinal" or "lateral" (metadata `axis`)
  std::string terrain;  // metadata `terrain`, "unknown" if absent
  double mass_kg = 16;  // metadata `mass_kg` (module plus load; the paper's 16 kg if absent)
  bool mass_from_log = false;
  std::vector<double> t_s, drive_rpm, force_n, position_m;  // NaN = not measured
};

// Reads a gantry log (GantryLogReader); throws auger::LogError naming file, line and column for
// bad input, including a missing or unknown `axis` and a non-positive `mass_kg`.
GantryData read_gantry_data(const std::string& path);

struct Estimate {
  double value = 0;
  double se = 0;             // standard error
  double lo = 0, hi = 0;     // confidence interval at IdentifyOptions::confidence
  double n_eff = 0;          // effective number of independent samples behind the interval
  std::string ci_method;     // how the interval was computed, in words
};

struct IdentifyOptions {
  double confidence = 0.95;
  double settle_time_constants = 5;  // a piece is steady after 5 m/D (e^-5 = 0.7 % left)
  double min_steady_s = 0.5;         // shorter steady parts are not used for D
  double drive_tol_rpm = 0.5;        // a piece of constant drive: within max(0.5 rpm, 5 %)
  double sigma_edge_s = 0.1;         // sigma skips the first and last 0.1 s of each piece
};

// One steady piece of constant screw speed: what eq. (17) regresses.
struct SteadyPiece {
  std::string file;
  double t_start_s = 0, t_end_s = 0;  // the steady part used
  double drive_rpm = 0;               // mean B_axis . omega
  double tau_n = 0;                   // eq. (12)/(14) with the identified sigma
  double velocity_mps = 0;            // slope of position over the steady part
  double velocity_se_mps = 0;
};

// Result for one (terrain, axis) group of logs.
struct GantryIdentification {
  std::string terrain, axis;
  std::vector<std::string> files;
  double mass_kg = 16;
  std::size_t n_samples = 0;       // samples of eq. (16): constant screw speed, force measured
  Estimate sigma;                  // sigma_long or sigma_lat, N per rpm, eq. (16)
  double force_residual_rms_n = 0; // F - sigma B omega
  Estimate D;                      // D_x or D_y, N/(m/s), eq. (17)
  std::vector<SteadyPiece> pieces;
  std::vector<std::string> warnings;
};

// Groups logs by (terrain, axis) and identifies each group. Throws std::runtime_error with a
// message naming the group when it cannot be identified (no drive, no steady piece).
std::vector<GantryIdentification> identify_gantry(const std::vector<GantryData>& logs,
                                                  const IdentifyOptions& options = {});

// Two-sided quantile of Student's t with dof degrees of freedom (normal for large dof).
double t_quantile(double confidence, double dof);

// Effective sample size of a series with autocorrelation, n / (1 + 2 sum rho_k), the sum over
// Geyer's initial positive sequence; series are the per-log pieces (no correlation across them).
double effective_sample_size(const std::vector<std::vector<double>>& series);

}  // namespace auger::wb
