// The project's version (CMakeLists.txt, project(VERSION)): what every program prints for
// --version, in one form, "PROGRAM VERSION".
#pragma once

namespace auger {

const char* version();
// Prints "PROGRAM VERSION" and a newline on stdout.
void print_version(const char* program);

}  // namespace auger
