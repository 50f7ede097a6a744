// The model workbench's engine (docs/workbench.md), by concern: datasets and the noise floor
// (dataset.hpp), the model run against a log (simulation.hpp), the effect search: diagnose and fit
// (search.hpp), explain (explain.hpp), the residual tests (residual_tests.hpp), and the JSON output
// (output.hpp). The subcommands (compare.cpp, diagnose.cpp,
// fit.cpp, explain_cmd.cpp, report.cpp, ...) are thin shells around these functions.
#pragma once

#include "dataset.hpp"
#include "explain.hpp"
#include "output.hpp"
#include "residual_tests.hpp"
#include "search.hpp"
#include "simulation.hpp"
