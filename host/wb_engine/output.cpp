// The workbench's JSON output (output.hpp).
#include "output.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

namespace auger::wb {

Json& Json::add(const char* key, nlohmann::ordered_json value, bool open) {
  nlohmann::ordered_json* slot = nullptr;
  if (open_.empty()) {
    if (!root_.is_null()) throw std::logic_error("Json: a second value at the top level");
    root_ = std::move(value);
    slot = &root_;
  } else if (open_.back()->is_array()) {
    open_.back()->push_back(std::move(value));
    slot = &open_.back()->back();
  } else {
    if (!key) throw std::logic_error("Json: a value in an object needs a key");
    slot = &((*open_.back())[key] = std::move(value));
  }
  if (open) open_.push_back(slot);
  return *this;
}

Json& Json::begin_object(const char* key) { return add(key, nlohmann::ordered_json::object(), true); }
Json& Json::begin_array(const char* key) { return add(key, nlohmann::ordered_json::array(), true); }
Json& Json::end_object() {
  open_.pop_back();
  return *this;
}
Json& Json::end_array() {
  open_.pop_back();
  return *this;
}

nlohmann::ordered_json json_number(double v, int digits) {
  if (!std::isfinite(v)) return nullptr;
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  const double rounded = std::strtod(buf, nullptr);
  if (rounded == std::trunc(rounded) && std::fabs(rounded) < 1e15) return static_cast<long long>(rounded);
  return rounded;
}

std::string json_for_script(const nlohmann::ordered_json& j) {
  const std::string text = j.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    if (c == '<')
      out += "\\u003c";
    else if (c == '>')
      out += "\\u003e";
    else if (c == '&')
      out += "\\u0026";
    else
      out += c;
  }
  return out;
}

// 10 significant digits: what the analysis resolves.
Json& Json::num(const char* key, double v) { return add(key, json_number(v, 10), false); }

Json& Json::str(const char* key, const std::string& v) { return add(key, v, false); }
Json& Json::boolean(const char* key, bool v) { return add(key, v, false); }

Json& Json::channels(const char* key, const ChannelValues& v, const std::array<bool, kChannels>& active) {
  begin_object(key);
  for (int c = 0; c < kChannels; ++c)
    if (active[static_cast<std::size_t>(c)]) num(channel_name(c), v[static_cast<std::size_t>(c)]);
  return end_object();
}

std::string Json::text() const {
  return root_.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

void json_windows(Json& j, const char* key, const std::vector<Window>& windows) {
  j.begin_array(key);
  for (const auto& w : windows) {
    j.begin_object();
    j.num("t_start_s", w.t_start_s).num("t_end_s", w.t_end_s).str("dof", channel_name(w.dof));
    j.num("rms", w.rms).num("ratio_to_noise", w.ratio_to_noise);
    j.end_object();
  }
  j.end_array();
}

}  // namespace auger::wb
