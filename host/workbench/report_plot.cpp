// Decimation of long series for `auger report`'s plots (report_plot.hpp).
#include "report_plot.hpp"

#include <algorithm>
#include <cmath>

namespace auger::wb {

std::vector<std::size_t> decimate(const std::vector<double>& t, const std::vector<double>& v, std::size_t max_points,
                                  bool peaks) {
  std::vector<std::size_t> keep;
  const std::size_t n = t.size();
  if (n <= max_points || max_points == 0) {
    for (std::size_t i = 0; i < n; ++i) keep.push_back(i);
    return keep;
  }
  const std::size_t bin = (n + max_points - 1) / max_points;
  for (std::size_t b = 0; b < n; b += bin) {
    std::size_t best = b;
    if (peaks) {
      for (std::size_t i = b; i < std::min(n, b + bin); ++i)
        if (std::isfinite(v[i]) && (!std::isfinite(v[best]) || std::fabs(v[i]) > std::fabs(v[best]))) best = i;
    }
    keep.push_back(best);
  }
  return keep;
}

}  // namespace auger::wb
