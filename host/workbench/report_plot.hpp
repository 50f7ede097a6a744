// Plots for `auger report` that are not time series (the path, the candidates, the effect's
// curves), drawn by host/io's gnuplot driver (gnuplot.hpp), and the decimation of long series.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "gnuplot.hpp"

namespace auger::wb {

using io::gp_quote;
using io::Gnuplot;
using io::PlotError;

// Keeps at most max_points of a series for plotting: per bin, the sample of largest |value|
// (so error peaks survive) for `peaks`, else every k-th sample.
std::vector<std::size_t> decimate(const std::vector<double>& t, const std::vector<double>& v, std::size_t max_points,
                                  bool peaks);

}  // namespace auger::wb
