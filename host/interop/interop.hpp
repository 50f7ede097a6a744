// The subcommands of host/interop, one file each; the `auger` front (host/auger/main.cpp) lists them.
#pragma once

namespace auger::interop {

int run_import(int argc, char** argv);  // import.cpp: runs python/auger_interop in the project's venv
int run_export(int argc, char** argv);  // export.cpp: robot log -> MCAP

}  // namespace auger::interop
