// Which log column goes to which MCAP channel (docs/formats.md "MCAP" lists them).
#include "auger/log_mcap.hpp"

#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include "auger/log.hpp"

namespace auger {

namespace {

// JSON schemas of Foxglove's well-known types (foxglove.PoseInFrame, foxglove.FrameTransform):
// with these names Foxglove's 3D panel draws the pose without any setup.
const char* kTime = R"({"type":"object","properties":{"sec":{"type":"integer","minimum":0},"nsec":{"type":"integer","minimum":0,"maximum":999999999}}})";
const char* kVec3 = R"({"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"}}})";
const char* kQuat = R"({"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"},"w":{"type":"number"}}})";

std::string pose_in_frame_schema() {
  return std::string(R"({"title":"foxglove.PoseInFrame","type":"object","properties":{"timestamp":)") + kTime +
         R"(,"frame_id":{"type":"string"},"pose":{"type":"object","properties":{"position":)" + kVec3 +
         R"(,"orientation":)" + kQuat + "}}}}";
}

std::string frame_transform_schema() {
  return std::string(R"({"title":"foxglove.FrameTransform","type":"object","properties":{"timestamp":)") + kTime +
         R"(,"parent_frame_id":{"type":"string"},"child_frame_id":{"type":"string"},"translation":)" + kVec3 +
         R"(,"rotation":)" + kQuat + "}}";
}

// A flat message: t_s and the named columns (numbers; integers for status words).
std::string flat_schema(const std::string& title, const std::vector<std::string>& fields) {
  std::string s = R"({"title":")" + title + R"(","type":"object","properties":{"t_s":{"type":"number"})";
  for (const auto& f : fields) {
    const bool integer = f.rfind("status_", 0) == 0 || f.rfind("seq_ack_", 0) == 0;
    s += ",\"" + f + "\":{\"type\":\"" + (integer ? "integer" : "number") + "\"}";
  }
  return s + "}}";
}

bool starts(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

void json_number(std::string& out, double v) { append_number(out, v); }

void json_time(std::string& out, std::uint64_t ns) {
  out += R"("timestamp":{"sec":)" + std::to_string(ns / 1000000000ull) + R"(,"nsec":)" +
         std::to_string(ns % 1000000000ull) + "}";
}

void json_pose(std::string& out, double x, double y, double psi, const char* pos_key, const char* rot_key) {
  out += std::string("\"") + pos_key + "\":{\"x\":";
  json_number(out, x);
  out += ",\"y\":";
  json_number(out, y);
  out += ",\"z\":0},\"" + std::string(rot_key) + "\":{\"x\":0,\"y\":0,\"z\":";
  json_number(out, std::sin(psi / 2));  // a rotation by psi about z
  out += ",\"w\":";
  json_number(out, std::cos(psi / 2));
  out += "}";
}

}  // namespace

RobotLogMcapWriter::RobotLogMcapWriter(std::ostream& out,
                                       const std::vector<std::pair<std::string, std::string>>& metadata,
                                       const std::vector<std::string>& columns, std::size_t chunk_bytes)
    : mcap_(out, "", "auger", chunk_bytes), columns_(columns) {
  for (const auto& [k, v] : metadata) {
    if (k != "t0_unix_s") continue;
    char* end = nullptr;
    const double t0 = std::strtod(v.c_str(), &end);
    if (end == v.c_str() || !std::isfinite(t0) || t0 < 0)
      throw std::invalid_argument("t0_unix_s '" + v + "' is not a time in seconds since 1970");
    // whole seconds and the fraction apart, so nanoseconds survive the double
    const double whole = std::floor(t0);
    const std::size_t dot = v.find('.');
    std::int64_t frac_ns = 0;
    if (dot != std::string::npos) {
      std::string digits = v.substr(dot + 1, 9);
      while (digits.size() < 9) digits += '0';
      bool ok = true;
      for (char c : digits) ok = ok && c >= '0' && c <= '9';
      frac_ns = ok ? std::stoll(digits) : std::llround((t0 - whole) * 1e9);
    }
    t0_ns_ = static_cast<std::int64_t>(whole) * 1000000000ll + frac_ns;
  }
  McapWriter::Metadata meta(metadata.begin(), metadata.end());
  mcap_.write_metadata("auger-log", meta);

  struct Def {
    const char* topic;
    const char* title;
    bool (*takes)(const std::string&);
  };
  static const Def defs[] = {
      {"/screws", "auger.Screws",
       [](const std::string& c) {
         return starts(c, "omega_rpm_") || starts(c, "cmd_rpm_") || starts(c, "current_a_") ||
                starts(c, "voltage_v_") || starts(c, "pwm_");
       }},
      {"/pose_2d", "auger.Pose2D", [](const std::string& c) { return c == "x_m" || c == "y_m" || c == "psi_rad"; }},
      {"/imu", "auger.Imu",
       [](const std::string& c) {
         return c == "imu_psi_rad" || c == "imu_r_radps" || c == "imu_ax_mps2" || c == "imu_ay_mps2";
       }},
      {"/reference", "auger.Reference",
       [](const std::string& c) { return c == "xd_m" || c == "yd_m" || c == "psid_rad"; }},
      {"/status", "auger.Status",
       [](const std::string& c) { return starts(c, "status_") || starts(c, "seq_ack_") || c == "loop_dt_s"; }},
  };
  std::vector<bool> taken(columns.size(), false);
  for (std::size_t i = 0; i < columns.size(); ++i) {
    const auto& c = columns[i];
    if (c == "t_s") t_col_ = static_cast<int>(i), taken[i] = true;
    if (c == "x_m") x_col_ = static_cast<int>(i);
    if (c == "y_m") y_col_ = static_cast<int>(i);
    if (c == "psi_rad") psi_col_ = static_cast<int>(i);
    if (c == "xd_m") xd_col_ = static_cast<int>(i);
    if (c == "yd_m") yd_col_ = static_cast<int>(i);
    if (c == "psid_rad") psid_col_ = static_cast<int>(i);
  }
  if (t_col_ < 0) throw std::invalid_argument("the log has no t_s column");
  auto add_group = [&](const std::string& topic, const std::string& title, const std::vector<int>& cols) {
    if (cols.empty()) return;
    std::vector<std::string> names;
    for (int c : cols) names.push_back(columns[static_cast<std::size_t>(c)]);
    Group g;
    g.channel = mcap_.add_channel(mcap_.add_schema(title, "jsonschema", flat_schema(title, names)), topic, "json");
    g.cols = cols;
    groups_.push_back(std::move(g));
  };
  for (const auto& d : defs) {
    std::vector<int> cols;
    for (std::size_t i = 0; i < columns.size(); ++i)
      if (!taken[i] && d.takes(columns[i])) cols.push_back(static_cast<int>(i)), taken[i] = true;
    add_group(d.topic, d.title, cols);
  }
  std::vector<int> rest;  // columns of other programs, augerd's replay columns, ...
  for (std::size_t i = 0; i < columns.size(); ++i)
    if (!taken[i]) rest.push_back(static_cast<int>(i));
  add_group("/other", "auger.Other", rest);

  pose_schema_ = mcap_.add_schema("foxglove.PoseInFrame", "jsonschema", pose_in_frame_schema());
  const std::uint16_t tf_schema = mcap_.add_schema("foxglove.FrameTransform", "jsonschema", frame_transform_schema());
  if (x_col_ >= 0 && y_col_ >= 0 && psi_col_ >= 0) pose_ch_ = mcap_.add_channel(pose_schema_, "/pose", "json");
  tf_ch_ = mcap_.add_channel(tf_schema, "/tf", "json");
  if (xd_col_ >= 0 && yd_col_ >= 0 && psid_col_ >= 0)
    ref_pose_ch_ = mcap_.add_channel(pose_schema_, "/reference/pose", "json");
}

namespace {
std::vector<std::string> robot_and(const std::vector<std::string>& extra) {
  std::vector<std::string> c = robot_log_columns();
  c.insert(c.end(), extra.begin(), extra.end());
  return c;
}
}  // namespace

RobotLogMcapWriter::RobotLogMcapWriter(std::ostream& out,
                                       const std::vector<std::pair<std::string, std::string>>& metadata,
                                       const RobotColumnsAnd& columns, std::size_t chunk_bytes)
    : RobotLogMcapWriter(out, metadata, robot_and(columns.extra), chunk_bytes) {}

void RobotLogMcapWriter::write(const RobotSample& sample, const std::vector<double>& extra) {
  if (columns_.size() != robot_log_columns().size() + extra.size())
    throw std::invalid_argument("RobotLogMcapWriter::write: wrong number of extra values");
  robot_log_row(sample, extra, row_);
  write_row(row_.data(), row_.size());
}

std::uint64_t RobotLogMcapWriter::time_ns(double t_s) const {
  const std::int64_t ns = t0_ns_ + std::llround(t_s * 1e9);
  if (ns < 0) throw std::invalid_argument("a time before 1970 cannot be written to MCAP (t_s " + std::to_string(t_s) + ")");
  return static_cast<std::uint64_t>(ns);
}

void RobotLogMcapWriter::write_pose(std::uint16_t pose_channel, std::uint16_t tf_channel, const char* child,
                                    std::uint64_t ns, double x, double y, double psi) {
  if (pose_channel) {
    msg_ = "{";
    json_time(msg_, ns);
    msg_ += R"(,"frame_id":"world","pose":{)";
    json_pose(msg_, x, y, psi, "position", "orientation");
    msg_ += "}}";
    mcap_.write_message(pose_channel, ns, ns, msg_);
  }
  if (tf_channel) {
    msg_ = "{";
    json_time(msg_, ns);
    msg_ += std::string(R"(,"parent_frame_id":"world","child_frame_id":")") + child + "\",";
    json_pose(msg_, x, y, psi, "translation", "rotation");
    msg_ += "}";
    mcap_.write_message(tf_channel, ns, ns, msg_);
  }
}

void RobotLogMcapWriter::write_row(const double* values, std::size_t count) {
  if (count != columns_.size()) throw std::invalid_argument("write_row: wrong number of values");
  const double t_s = values[t_col_];
  const std::uint64_t ns = time_ns(t_s);
  for (const auto& g : groups_) {
    msg_ = "{\"t_s\":";
    json_number(msg_, t_s);
    bool any = false;
    for (int c : g.cols) {
      const double v = values[c];
      if (std::isnan(v)) continue;
      msg_ += ",\"" + columns_[static_cast<std::size_t>(c)] + "\":";
      json_number(msg_, v);
      any = true;
    }
    if (!any) continue;
    msg_ += "}";
    mcap_.write_message(g.channel, ns, ns, msg_);
  }
  auto all = [&](int a, int b, int c) {
    return a >= 0 && !std::isnan(values[a]) && !std::isnan(values[b]) && !std::isnan(values[c]);
  };
  if (all(x_col_, y_col_, psi_col_))
    write_pose(pose_ch_, tf_ch_, "base_link", ns, values[x_col_], values[y_col_], values[psi_col_]);
  if (all(xd_col_, yd_col_, psid_col_))
    write_pose(ref_pose_ch_, 0, "", ns, values[xd_col_], values[yd_col_], values[psid_col_]);
}

void RobotLogMcapWriter::write_prediction(double t_s, double x_m, double y_m, double psi_rad, double imu_psi_rad) {
  if (!model_flat_ch_) {
    model_flat_ch_ = mcap_.add_channel(
        mcap_.add_schema("auger.ModelPrediction", "jsonschema",
                         flat_schema("auger.ModelPrediction", {"x_m", "y_m", "psi_rad", "imu_psi_rad"})),
        "/model/pose_2d", "json");
    model_pose_ch_ = mcap_.add_channel(pose_schema_, "/model/pose", "json");
  }
  const std::uint64_t ns = time_ns(t_s);
  msg_ = "{\"t_s\":";
  json_number(msg_, t_s);
  const char* names[] = {"x_m", "y_m", "psi_rad", "imu_psi_rad"};
  const double vals[] = {x_m, y_m, psi_rad, imu_psi_rad};
  bool any = false;
  for (int i = 0; i < 4; ++i) {
    if (std::isnan(vals[i])) continue;
    msg_ += ",\"" + std::string(names[i]) + "\":";
    json_number(msg_, vals[i]);
    any = true;
  }
  msg_ += "}";
  if (any) mcap_.write_message(model_flat_ch_, ns, ns, msg_);
  if (!std::isnan(x_m) && !std::isnan(y_m) && !std::isnan(psi_rad))
    write_pose(model_pose_ch_, tf_ch_, "base_link_model", ns, x_m, y_m, psi_rad);
}

}  // namespace auger
