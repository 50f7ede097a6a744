// The one kit of the two TOML readers, the model file's (src/model_file.cpp) and augerd's
// configuration's (host/contract/daemon_config.cpp): an error at a node names the file, line and
// column (ConfigError), typed values with the same messages, an unknown key listing the known
// ones. It needs toml++ (header-only, docs/design.md): include it only from those two readers.
#pragma once

#include <string>

#include <toml++/toml.h>

#include "auger/effect.hpp"
#include "auger/model.hpp"

namespace auger::toml_kit {

inline int line_of(const toml::node& n) { return static_cast<int>(n.source().begin.line); }
inline int col_of(const toml::node& n) { return static_cast<int>(n.source().begin.column); }

[[noreturn]] inline void fail(const std::string& file, const toml::node& n, const std::string& msg) {
  throw ConfigError(file, line_of(n), col_of(n), msg);
}

inline double number(const std::string& file, const toml::node& n, const std::string& key) {
  if (!n.is_number()) fail(file, n, "'" + key + "' must be a number");
  return *n.value<double>();
}

inline std::string text(const std::string& file, const toml::node& n, const std::string& key) {
  if (!n.is_string()) fail(file, n, "'" + key + "' must be a string");
  return *n.value<std::string>();
}

inline bool boolean(const std::string& file, const toml::node& n, const std::string& key) {
  if (!n.is_boolean()) fail(file, n, "'" + key + "' must be true or false");
  return *n.value<bool>();
}

// hint: how the table is written, for the error (augerd's configuration: " [serial]").
inline const toml::table& as_table(const std::string& file, const toml::node& n, const std::string& key,
                                   const std::string& hint = "") {
  if (!n.is_table()) fail(file, n, "'" + key + "' must be a table" + hint);
  return *n.as_table();
}

// The array of a Vec3 (x, y, yaw); its elements are read by the caller's rule for numbers.
inline const toml::array& vec3_array(const std::string& file, const toml::node& n, const std::string& key) {
  const toml::array* a = n.as_array();
  if (!a || a->size() != 3) fail(file, n, "'" + key + "' must be an array of 3 numbers (x, y, yaw)");
  return *a;
}

// An unknown key of table `where`; known: the known keys, comma-separated.
[[noreturn]] inline void unknown_key(const std::string& file, const toml::node& n, const std::string& key,
                                     const std::string& where, const std::string& known) {
  fail(file, n, "unknown key '" + key + "' in " + where + " (known: " + known + ")");
}

}  // namespace auger::toml_kit
