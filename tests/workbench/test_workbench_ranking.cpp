// diagnose's ranking rule (host/wb_engine/search.hpp ranking_order; docs/workbench.md "diagnose",
// 3), on candidates made up for it: the numbers, not a fit, decide.
#include <catch2/catch.hpp>

#include <string>
#include <vector>

#include "search.hpp"

using namespace auger::wb;

namespace {

Candidate candidate(const char* effect, double heldout_ratio, double delta_bic, bool implausible = false) {
  Candidate c;
  c.fitted.effect = effect;
  c.heldout_ratio = heldout_ratio;
  c.delta_bic = delta_bic;
  c.implausible = implausible;
  c.flagged = implausible;
  return c;
}

std::vector<std::string> ranked(const std::vector<Candidate>& c, double nominal) {
  std::vector<std::string> out;
  for (std::size_t i : ranking_order(c, nominal)) out.push_back(c[i].fitted.effect);
  return out;
}

}  // namespace

TEST_CASE("diagnose's ranking: an implausible fit counts 15 % worse, as in explain's steps, not last") {
  // As on a log of the independent generator: quadratic drag at its coefficient's range end
  // predicts the held-out segments at 0.96 times the noise floor, a plausible terrain change at
  // 4.9; explain named the drag. Ranked after every plausible fit, the change came first.
  const std::vector<Candidate> far{candidate("terrain_change", 4.92, -5475), candidate("quadratic_drag", 0.96, -8956, true),
                                   candidate("force_lag", 31.6, 17)};
  CHECK(ranked(far, 31.6) == std::vector<std::string>{"quadratic_drag", "terrain_change", "force_lag"});
  // Within the 15 %, the plausible fit goes first although its held-out error is higher ...
  const std::vector<Candidate> near{candidate("terrain_change", 1.10, -300), candidate("quadratic_drag", 1.00, -900, true)};
  CHECK(ranked(near, 2.0) == std::vector<std::string>{"terrain_change", "quadratic_drag"});
  // ... and penalised errors within 2 % of each other rank by delta BIC.
  const std::vector<Candidate> tie{candidate("terrain_change", 1.16, -300), candidate("quadratic_drag", 1.00, -900, true)};
  CHECK(ranked(tie, 2.0) == std::vector<std::string>{"quadratic_drag", "terrain_change"});
  // A candidate that does not lower the held-out error by 2 % ranks after every one that does,
  // whatever its BIC gain, and among those by delta BIC.
  const std::vector<Candidate> rest{candidate("a", 1.99, -50000), candidate("b", 1.5, -10, true),
                                    candidate("c", 2.5, -60000)};
  CHECK(ranked(rest, 2.0) == std::vector<std::string>{"b", "c", "a"});
}
