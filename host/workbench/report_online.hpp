// augerd's online estimate beside the offline fit of the same log (`auger report` on a log with
// augerd's on_* columns, docs/workbench-tools.md "report"): per terrain parameter the online
// estimate at a row and the offline fit (`auger fit LOG --add paper_params --hold ...`, eqs.
// (15)-(17)) holding what the online estimate held, and how far apart they are in their combined
// uncertainty.
#pragma once

#include <string>
#include <vector>

#include "workbench.hpp"

namespace auger::wb {

// The parameters the online estimate held at their configured values (augerd's
// drag_prior_rel_sd = 0.01 holds D_x, D_y, D_psi): those whose SD never rises above
// auger::kHeldRelSd of the value (it returns to the prior at a change). Empty without online columns.
std::vector<std::string> online_held(const Dataset& d);

struct OnlineAgreement {
  std::string name, unit;  // "sigma_long", "N/rpm"
  double online = kNaN, online_sd = kNaN;
  double offline = kNaN, offline_sd = kNaN;
  bool held = false;  // held online, and so in the offline fit: not compared
  // Informed online: its SD at the row below half its prior (the largest in the log), as the
  // estimator counts it (OnlineEstimate::informed). Not informed: the prior, not compared.
  bool informed = false;
  // |online - offline| / sqrt(online_sd^2 + offline_sd^2); NaN when held or not informed.
  double z = kNaN;
};

// The five parameters at row k of the log. offline: paper_params' parameters of a fit holding
// online_held(d) (with D held on both sides, sigma is in both the same quantity: what the steady
// speed per rpm says with the configured drag). Throws std::invalid_argument if the log has no
// online columns or offline lacks a parameter.
std::vector<OnlineAgreement> online_agreement(const Dataset& d, std::size_t k, const std::vector<FitParam>& offline);

}  // namespace auger::wb
