// Residual tests (docs/workbench.md "The stop rule"): is what a model leaves white and
// independent of the inputs? Used by explain's stop rule and its verdict.
#pragma once

#include <string>
#include <vector>

#include "auger/model.hpp"
#include "dataset.hpp"

namespace auger::wb {

// What a model leaves, white and independent of the
// inputs? (MATLAB's `resid` for an output-error model: the simulation error over segments of
// 25 s, each segment's mean removed.)
struct ChannelResidualTest {
  int channel = 0;
  std::size_t n = 0;            // residuals tested (fewer than 50: not tested)
  std::vector<double> acf;      // lags 1..max_lag
  double whiteness_q = 0, whiteness_limit = 0;  // Ljung-Box Q and its 1 % limit
  bool white = true;
  double independence_z = 0, independence_limit = 0;  // largest |correlation| sqrt(n) with an input
  int worst_input = 0, worst_lag = 0;  // input: drive force x, y, yaw torque (eq. (7)); lag in samples
  bool independent = true;
  int whitened_order = 0;  // > 0: tested after the camera noise's AR filter of that order
};
struct ResidualTests {
  int max_lag = 10;
  std::vector<ChannelResidualTest> channels;
  bool white = true, independent = true;
};
// With a whitening filter (NoiseColour::whiten) the camera's channels and the inputs are both
// filtered by it first (Box and Jenkins' prewhitening): coloured camera noise is then no finding.
ResidualTests residual_tests(const Model& model, const Dataset& data, const ChannelValues& noise,
                             const WhiteningFilter& whiten = {}, int max_lag = 10);
std::string describe_residual_tests(const ResidualTests& t);  // plain words, "" never

}  // namespace auger::wb
