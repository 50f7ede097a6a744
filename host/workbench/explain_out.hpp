// explain's output: the JSON object (--json) and the text (explain_out.cpp).
#pragma once

#include <string>
#include <vector>

#include "workbench.hpp"

namespace auger::wb {

void print_explain_json(const ExplainResult& r, const std::vector<Dataset>& logs, const std::vector<ModelChoice>& models,
                        const std::string& out, const std::string& next, const std::vector<std::string>& warnings);
// Everything but the last lines (the model file written, next), which the command prints.
void print_explain_text(const ExplainResult& r, const std::vector<Dataset>& logs, const std::vector<ModelChoice>& models,
                        double seconds);

}  // namespace auger::wb
