// augerd's online estimate beside the offline fit of the same log (`auger report` on a log with
// augerd's on_* columns, docs/workbench-tools.md "report"): per terrain parameter the online
// estimate at a time and the offline fit (`auger fit LOG --add paper_params`, eqs. (15)-(17)),
// and how far apart they are in their combined uncertainty.
#pragma once

#include <string>
#include <vector>

#include "workbench.hpp"

namespace auger::wb {

struct OnlineAgreement {
  std::string name, unit;            // "sigma_long", "N/rpm"; a ratio "sigma_long / D_x"
  double online = kNaN, online_sd = kNaN;
  double offline = kNaN, offline_sd = kNaN;
  // Held online (augerd's drag_prior_rel_sd: its SD never above auger::kHeldRelSd of its value):
  // the configured value, not an estimate; not compared (then its DOF's sigma / D ratio is).
  bool held = false;
  // A sigma whose DOF's D was held online carries that DOF's sigma / D (scaled by the configured D):
  // compared through the ratio, not alone.
  bool via_ratio = false;
  // |online - offline| / sqrt(online_sd^2 + offline_sd^2); NaN when not compared.
  double z = kNaN;
};

// The five parameters (and, for each DOF whose D was held online, the ratio sigma / D that the
// online estimate then identifies: x sigma_long / D_x, y sigma_lat / D_y, yaw sigma_lat / D_psi;
// its offline SD adds the relative SDs in quadrature, an upper bound as the fit's sigma and D are
// correlated) at row k of the log. offline: paper_params' fitted parameters. Throws
// std::invalid_argument if the log has no online columns or offline lacks a parameter.
std::vector<OnlineAgreement> online_agreement(const Dataset& d, std::size_t k, const std::vector<FitParam>& offline);

}  // namespace auger::wb
