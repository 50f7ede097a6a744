// The benches' quantile of a sample (online_bench, online_fil): the value at rank q n of the
// sorted sample (no interpolation), NaN for none.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

namespace auger::bench {

inline double quantile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, std::size_t(q * double(v.size())))];
}

}  // namespace auger::bench
