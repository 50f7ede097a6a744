// The workbench's JSON output: every command's --json prints one object, built with
// nlohmann::json (keys in the order written). Numbers carry 10 significant digits, NaN and
// infinities are null; text that is not valid UTF-8 (a path) is written with U+FFFD in place of
// the bad bytes, so the output always parses.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "dataset.hpp"
#include "simulation.hpp"

namespace auger::wb {

class Json {
 public:
  Json& begin_object(const char* key = nullptr);
  Json& end_object();
  Json& begin_array(const char* key = nullptr);
  Json& end_array();
  Json& num(const char* key, double v);  // NaN/inf -> null
  Json& str(const char* key, const std::string& v);
  Json& boolean(const char* key, bool v);
  Json& channels(const char* key, const ChannelValues& v, const std::array<bool, kChannels>& active);
  std::string text() const;

 private:
  Json& add(const char* key, nlohmann::ordered_json value, bool open);
  nlohmann::ordered_json root_;
  std::vector<nlohmann::ordered_json*> open_;  // the objects and arrays being filled, innermost last
};
void json_windows(Json& j, const char* key, const std::vector<Window>& windows);

// v to `digits` significant digits as a JSON number (whole numbers as integers), null if not
// finite: what Json::num (10 digits) and the report's chart data (6) write.
nlohmann::ordered_json json_number(double v, int digits);
// JSON text that is safe inside an HTML <script> element: "<", ">" and "&" (in JSON only ever
// inside strings) written as \u003c, \u003e, \u0026, so no "</script>" can end the element.
std::string json_for_script(const nlohmann::ordered_json& j);

}  // namespace auger::wb
