// The project's version (version.hpp); AUGER_VERSION comes from host/CMakeLists.txt.
#include "auger/version.hpp"

#include <cstdio>

namespace auger {

const char* version() { return AUGER_VERSION; }

void print_version(const char* program) { std::printf("%s %s\n", program, AUGER_VERSION); }

}  // namespace auger
