// host/io's gnuplot driver (gnuplot.hpp) under the workbench's names, for `auger report`'s plots
// (report_charts.cpp: the path, the candidates, the effect's curves).
#pragma once

#include "gnuplot.hpp"

namespace auger::wb {

using io::gp_quote;
using io::Gnuplot;
using io::PlotError;

}  // namespace auger::wb
