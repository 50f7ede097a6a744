// The workbench's subcommands (issue 5), one file each; the `auger` front (host/auger/main.cpp) lists them.
#pragma once

namespace auger::wb {

int run_compare(int argc, char** argv);   // compare.cpp
int run_diagnose(int argc, char** argv);  // diagnose.cpp
int run_fit(int argc, char** argv);       // fit.cpp
int run_effects(int argc, char** argv);   // effects_cmd.cpp: the effect library, documented
int run_identify(int argc, char** argv);  // identify.cpp
int run_merge(int argc, char** argv);     // merge.cpp
int run_report(int argc, char** argv);    // report.cpp
int run_explain(int argc, char** argv);   // explain_cmd.cpp

}  // namespace auger::wb
