// `auger report`'s page, shared by report.cpp (the command, the page) and report_sections.cpp
// (one function per section): what the engine found, and the pieces a section is made of.
#pragma once

#include <string>
#include <vector>

#include "report_charts.hpp"
#include "report_plot.hpp"
#include "workbench.hpp"

namespace auger::wb {

// What the engine found: everything a section draws from.
struct Findings {
  explicit Findings(const Dataset& data) : d(data) {}
  const Dataset& d;
  std::vector<int> chans;  // active channels
  std::vector<std::string> warnings;
  std::string terrain;  // the terrain used and why (terrain_text)
  CompareResult cmp;
  bool have_diag = false;
  DiagnoseResult dg;
  bool have_explain = false;
  ExplainResult ex;
  // The model after: explain's (--explain), else the fit of --effect ID or of diagnose's first
  // candidate. after_name is what was added ("" = no model after).
  std::string after_name;
  bool effect_given = false;           // --effect ID
  std::vector<FittedEffect> after_fitted;
  CompareResult after;                 // compare() of the model after
  std::string next;                    // the command to run next
  // A log with augerd's on_* columns: `fit --add paper_params`'s parameters (report_online.hpp).
  std::vector<FitParam> offline;
};

struct Section {
  std::string id, title, html;
};

// Sections (report_sections.cpp); the time charts join the chart group "time".
Section summary_section(const Findings& f, const Gnuplot& gp, const ChartSet& charts);
Section model_section(const Findings& f, Gnuplot& gp, ChartSet& charts);
Section error_section(const Findings& f, ChartSet& charts);
Section ranking_section(const Findings& f, Gnuplot& gp);
Section before_after_section(const Findings& f, ChartSet& charts);
Section effect_section(const Findings& f, ChartSet& charts);
Section explain_section(const Findings& f, ChartSet& charts);
Section online_section(const Findings& f, ChartSet& charts);  // report_online.cpp

}  // namespace auger::wb
