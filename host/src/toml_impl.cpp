// toml++'s implementation, compiled once for every reader of TOML (host/CMakeLists.txt says why).
#define TOML_IMPLEMENTATION
#include <toml++/toml.h>
