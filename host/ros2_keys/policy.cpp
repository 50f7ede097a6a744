// The governance and permissions documents of `auger ros2-keys` (ros2_keys.hpp), as OMG DDS
// Security 1.1 (9.4.1.2, 9.4.1.3) defines them; Cyclone DDS's access control plugin reads them.
#include <cctype>

#include "ros2_keys.hpp"

namespace auger::ros2_keys {
namespace {

std::string iso_utc(std::time_t t) {
  std::tm tm{};
  gmtime_r(&t, &tm);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%S", &tm);
  return b;
}

// Topic names are ROS 2 names already checked (only [A-Za-z0-9_/]); nothing to escape in XML.
std::string topics(const char* element, const std::vector<std::string>& names) {
  if (names.empty()) return "";
  std::string x = std::string("        <") + element + ">\n          <topics>\n";
  for (const auto& n : names) x += "            <topic>" + n + "</topic>\n";
  return x + "          </topics>\n        </" + element + ">\n";
}

}  // namespace

std::string governance_xml(int domain_id) {
  const std::string d = std::to_string(domain_id);
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<!-- auger ros2-keys: DDS Security governance (docs/ros2.md) -->\n"
         "<dds xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
         "xsi:noNamespaceSchemaLocation=\"http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd\">\n"
         "  <domain_access_rules>\n"
         "    <domain_rule>\n"
         "      <domains><id>" + d + "</id></domains>\n"
         "      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>\n"
         "      <enable_join_access_control>true</enable_join_access_control>\n"
         "      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>\n"
         "      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>\n"
         "      <rtps_protection_kind>SIGN</rtps_protection_kind>\n"
         "      <topic_access_rules>\n"
         "        <topic_rule>\n"
         "          <topic_expression>*</topic_expression>\n"
         "          <enable_discovery_protection>true</enable_discovery_protection>\n"
         "          <enable_liveliness_protection>true</enable_liveliness_protection>\n"
         "          <enable_read_access_control>true</enable_read_access_control>\n"
         "          <enable_write_access_control>true</enable_write_access_control>\n"
         "          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>\n"
         "          <data_protection_kind>ENCRYPT</data_protection_kind>\n"
         "        </topic_rule>\n"
         "      </topic_access_rules>\n"
         "    </domain_rule>\n"
         "  </domain_access_rules>\n"
         "</dds>\n";
}

std::string permissions_xml(const std::string& grant, const std::string& subject, int domain_id,
                            const std::vector<std::string>& publish, const std::vector<std::string>& subscribe,
                            std::time_t not_before, std::time_t not_after) {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<!-- auger ros2-keys: DDS Security permissions of " + grant + " (docs/ros2.md) -->\n"
         "<dds xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
         "xsi:noNamespaceSchemaLocation=\"http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd\">\n"
         "  <permissions>\n"
         "    <grant name=\"" + grant + "\">\n"
         "      <subject_name>" + subject + "</subject_name>\n"
         "      <validity>\n"
         "        <not_before>" + iso_utc(not_before) + "</not_before>\n"
         "        <not_after>" + iso_utc(not_after) + "</not_after>\n"
         "      </validity>\n"
         "      <allow_rule>\n"
         "        <domains><id>" + std::to_string(domain_id) + "</id></domains>\n" +
         topics("publish", publish) + topics("subscribe", subscribe) +
         "      </allow_rule>\n"
         "      <default>DENY</default>\n"
         "    </grant>\n"
         "  </permissions>\n"
         "</dds>\n";
}

std::string check_name(const std::string& name) {
  if (name.empty() || name.size() > 64) return "must have 1 to 64 characters";
  if (!std::isalpha(static_cast<unsigned char>(name[0]))) return "must start with a letter";
  for (char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_'))
      return std::string("has the character '") + c + "' (only letters, digits and '_')";
  return "";
}

}  // namespace auger::ros2_keys
