// What the workbench's subcommands check before they answer (issue 13: no exit 0 on nonsense):
// a log long and dense enough for a fit, and results that are numbers. Each throws
// std::runtime_error with the reason and the next thing to try; the shells exit 2.
#pragma once

#include <string>

#include "workbench.hpp"

namespace auger::wb {

// diagnose, fit and report's search split the log into segments of at least 5 s for training
// and held-out errors: at least kMinFitSeconds of log with kMinFitPoses measured poses.
constexpr double kMinFitSeconds = 15.0;
constexpr int kMinFitPoses = 30;
void require_fit_data(const Dataset& data, const char* command);

// A robot log without pose: what the commands compare it in, and what they cannot check (a
// warning for stderr and the JSON's `warnings`); "" for a log with a pose.
std::string unchecked_warning(const Dataset& data);

// Every active channel's error is finite and covers at least half of its measurements (a model
// that predicts NaN, e.g. D_x = 0 through eq. (6), gave "null" or a perfect 0 before); and the
// noise floor, which every "x noise" figure divides by, is a number.
void require_finite(const Dataset& data, const ErrorStats& e, const ModelChoice& model, const std::string& what);
void require_noise_floor(const Dataset& data, const ChannelValues& noise);

}  // namespace auger::wb
