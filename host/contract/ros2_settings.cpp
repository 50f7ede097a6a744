// ROS 2's topic name rules and their mapping to DDS (design.ros2.org, "Topic and Service name
// mapping to DDS"), and the check of augerd's [ros2] settings. No DDS here: the configuration
// reader (daemon_config.cpp) uses it in every build.
#include <cctype>
#include <cmath>
#include <stdexcept>

#include "ros2_settings.hpp"

namespace auger::ros2 {
namespace {

[[noreturn]] void bad(const std::string& name, const std::string& why) {
  throw std::invalid_argument("ROS 2 name '" + name + "' " + why);
}

// The rules for a name after any namespace is applied, token by token.
void check_tokens(const std::string& shown, const std::string& full) {
  if (full.size() < 2 || full[0] != '/') bad(shown, "is empty");
  if (full.back() == '/') bad(shown, "must not end with '/'");
  std::size_t start = 1;
  while (start <= full.size()) {
    std::size_t end = full.find('/', start);
    if (end == std::string::npos) end = full.size();
    const std::string token = full.substr(start, end - start);
    if (token.empty()) bad(shown, "must not contain repeated '/'");
    if (std::isdigit(static_cast<unsigned char>(token[0])))
      bad(shown, "has a token starting with a digit ('" + token + "')");
    start = end + 1;
  }
}

}  // namespace

std::string fully_qualified_name(const std::string& name, const std::string& ns) {
  if (name.empty()) bad(name, "is empty");
  for (std::size_t i = 0; i < name.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(name[i]);
    if (c == '~' || c == '{' || c == '}')
      bad(name, "uses a substitution ('~' or '{}'), which augerd does not expand: give the name in full");
    if (!(std::isalnum(c) || c == '_' || c == '/'))
      bad(name, "has the character '" + std::string(1, char(c)) + "' at " + std::to_string(i + 1) +
                    " (only A-Z, a-z, 0-9, '_' and '/')");
    if (c == '_' && i > 0 && name[i - 1] == '_') bad(name, "must not contain repeated '_'");
  }
  std::string full;
  if (name[0] == '/') {
    full = name;
  } else {
    std::string prefix = ns.empty() || ns == "/" ? "" : ns;
    if (!prefix.empty()) {
      if (prefix[0] != '/') prefix = "/" + prefix;
      // The namespace obeys the same rules (it names the topic's leading tokens).
      for (std::size_t i = 0; i < prefix.size(); ++i) {
        const unsigned char c = static_cast<unsigned char>(prefix[i]);
        if (!(std::isalnum(c) || c == '_' || c == '/'))
          bad(ns, "(the namespace) has the character '" + std::string(1, char(c)) + "'");
        if (c == '_' && i > 0 && prefix[i - 1] == '_') bad(ns, "(the namespace) must not contain repeated '_'");
      }
      check_tokens(ns, prefix);
    }
    full = prefix + "/" + name;
  }
  check_tokens(name, full);
  // RTPS carries topic names of up to 256 bytes with the terminating zero; "rt" comes first.
  if (dds_topic_name(full).size() > 255) bad(name, "is too long for DDS (255 bytes with the 'rt' prefix)");
  return full;
}

std::string dds_topic_name(const std::string& fully_qualified) { return "rt" + fully_qualified; }

void check_frame_id(const std::string& frame) {
  if (frame.empty()) throw std::invalid_argument("a frame id must not be empty");
  for (char ch : frame)
    if (!std::isgraph(static_cast<unsigned char>(ch)))
      throw std::invalid_argument("frame id '" + frame + "' has a space or control character");
}

void check_settings(const Settings& s) {
  if (s.domain_id < 0 || s.domain_id > 232)
    throw std::invalid_argument("domain_id " + std::to_string(s.domain_id) + " is outside 0..232");
  for (const std::string* t : {&s.cmd_vel_topic, &s.cmd_vel_stamped_topic, &s.pose_topic, &s.pose_cov_topic,
                               &s.imu_topic, &s.odom_topic, &s.joint_states_topic, &s.diagnostics_topic,
                               &s.tf_topic, &s.online_topic})
    if (!t->empty()) fully_qualified_name(*t, s.ns);
  for (double r : {s.odom_rate_hz, s.joint_states_rate_hz, s.diagnostics_rate_hz, s.online_rate_hz})
    if (!(r >= 0 && r <= 100)) throw std::invalid_argument("a rate is outside 0..100 Hz (augerd's loop runs at 100 Hz)");
  for (double sd : s.pose_std)
    if (!(sd > 0 && std::isfinite(sd))) throw std::invalid_argument("pose_std must be three numbers > 0");
  check_frame_id(s.odom_frame);
  check_frame_id(s.base_frame);
  if (s.odom_frame == s.base_frame) throw std::invalid_argument("odom_frame and base_frame must differ");
  for (const auto& j : s.joint_names) check_frame_id(j);
}

std::vector<std::string> input_topics(const Settings& s) {
  std::vector<std::string> out;
  for (const std::string* t :
       {&s.cmd_vel_topic, &s.cmd_vel_stamped_topic, &s.pose_topic, &s.pose_cov_topic, &s.imu_topic})
    if (!t->empty()) out.push_back(fully_qualified_name(*t, s.ns));
  return out;
}

// As the bridge creates its writers (host/ros2/bridge.cpp): /tf goes with the odometry.
std::vector<std::string> output_topics(const Settings& s) {
  std::vector<std::string> out;
  if (s.odom_rate_hz > 0) out.push_back(fully_qualified_name(s.odom_topic, s.ns));
  if (s.odom_rate_hz > 0 && s.tf) out.push_back(fully_qualified_name(s.tf_topic, s.ns));
  if (s.joint_states_rate_hz > 0) out.push_back(fully_qualified_name(s.joint_states_topic, s.ns));
  if (s.diagnostics_rate_hz > 0) out.push_back(fully_qualified_name(s.diagnostics_topic, s.ns));
  // Allowed whether or not [online] is enabled (the settings do not know); written only when it is.
  if (s.online_rate_hz > 0) out.push_back(fully_qualified_name(s.online_topic, s.ns));
  return out;
}

std::vector<SecurityFile> enclave_files(const std::string& enclave_dir) {
  const std::string e = enclave_dir + "/";
  return {{"dds.sec.auth.identity_ca", e + "identity_ca.cert.pem"},
          {"dds.sec.auth.identity_certificate", e + "cert.pem"},
          {"dds.sec.auth.private_key", e + "key.pem"},
          {"dds.sec.access.permissions_ca", e + "permissions_ca.cert.pem"},
          {"dds.sec.access.governance", e + "governance.p7s"},
          {"dds.sec.access.permissions", e + "permissions.p7s"}};
}

std::vector<SecurityFile> security_files(const Settings& s) {
  if (s.keystore.empty()) return {};
  return enclave_files(s.keystore + "/enclaves/" + kEnclave);
}

std::vector<std::pair<std::string, std::string>> security_properties(const std::string& enclave_dir) {
  std::vector<std::pair<std::string, std::string>> p;
  struct Plugin {
    const char *key, *library, *name;
  };
  for (const Plugin& x : {Plugin{"auth", "dds_security_auth", "authentication"},
                          Plugin{"access", "dds_security_ac", "access_control"},
                          Plugin{"crypto", "dds_security_crypto", "crypto"}}) {
    const std::string k = std::string("dds.sec.") + x.key + ".library.";
    p.push_back({k + "path", x.library});
    p.push_back({k + "init", std::string("init_") + x.name});
    p.push_back({k + "finalize", std::string("finalize_") + x.name});
  }
  for (const auto& f : enclave_files(enclave_dir)) p.push_back({f.property, "file:" + f.path});
  return p;
}

}  // namespace auger::ros2
