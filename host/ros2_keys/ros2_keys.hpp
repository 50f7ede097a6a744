// `auger ros2-keys`: the DDS Security keystore of augerd's ROS 2 interface (docs/ros2.md "Who may
// command the robot"), in SROS2's layout: a CA (public/ca.cert.pem, private/ca.key.pem), a signed
// governance (enclaves/governance.p7s) and one enclave per participant (enclaves/NAME/: its key
// and certificate, the CA's certificate, the signed governance and its signed permissions). Made
// with the openssl program, run with argument vectors (no shell); the XML documents are written
// here (policy.cpp).
#pragma once

#include <ctime>
#include <string>
#include <vector>

namespace auger::ros2_keys {

// `auger ros2-keys ...` (argv[0] is "ros2-keys"). Exit 0 done, 1 openssl failed, 2 bad usage.
int run(int argc, char** argv);

// The governance of every participant in the keystore (OMG DDS Security 1.1, 9.4.1.2): in
// `domain_id` only authenticated participants take part, and all discovery, liveliness and
// topic data are encrypted; reading and writing a topic needs the permission to.
std::string governance_xml(int domain_id);

// The permissions of the participant whose certificate subject is `subject` ("CN=augerd"):
// in `domain_id` it may publish `publish` and subscribe `subscribe` (DDS topic names), nothing
// else, from `not_before` to `not_after` (UTC).
std::string permissions_xml(const std::string& grant, const std::string& subject, int domain_id,
                            const std::vector<std::string>& publish, const std::vector<std::string>& subscribe,
                            std::time_t not_before, std::time_t not_after);

// A participant's name as it goes into its certificate's subject (CN=NAME) and its enclave's
// directory: a letter, then letters, digits or '_', at most 64. "" when valid, else why not.
std::string check_name(const std::string& name);

}  // namespace auger::ros2_keys
