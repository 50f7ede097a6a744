// augerd's [ros2] settings and ROS 2's name rules (docs/ros2.md), without any DDS type: the
// configuration reader (daemon_config.hpp) checks them in every build, and the bridge
// (host/ros2) uses them when it is built with Cyclone DDS.
#pragma once

#include <array>
#include <string>
#include <utility>
#include <vector>

namespace auger::ros2 {

struct Settings {
  bool enabled = false;
  int domain_id = 0;            // ROS_DOMAIN_ID: 0..232 (Cyclone's default port mapping)
  std::string dds_config;       // Cyclone DDS XML file; "" = CYCLONEDDS_URI, else Cyclone's defaults
  std::string ns;               // ROS namespace of the relative topic names ("" = /)
  // Inputs, each subscribed only when its topic is not "".
  std::string cmd_vel_topic = "cmd_vel";  // geometry_msgs/msg/Twist, as `vel` (0.5 s dead-man)
  std::string cmd_vel_stamped_topic;      // geometry_msgs/msg/TwistStamped, the same
  std::string pose_topic;                 // geometry_msgs/msg/PoseStamped, as the sensors socket's `pose`
  std::string pose_cov_topic;             // geometry_msgs/msg/PoseWithCovarianceStamped, the same
  std::string imu_topic;                  // sensor_msgs/msg/Imu, as the sensors socket's `imu`
  // PoseStamped carries no uncertainty: these standard deviations go with it (m, m, rad).
  std::array<double, 3> pose_std = {0.003, 0.003, 0.005};
  // Outputs, each published only when its rate is > 0.
  std::string odom_topic = "odom";                 // nav_msgs/msg/Odometry
  std::string joint_states_topic = "joint_states"; // sensor_msgs/msg/JointState
  std::string diagnostics_topic = "/diagnostics";  // diagnostic_msgs/msg/DiagnosticArray
  std::string tf_topic = "/tf";                    // tf2_msgs/msg/TFMessage (odom -> base_link)
  // std_msgs/msg/Float64MultiArray: the [online] estimate and SDs, only while [online] is enabled.
  std::string online_topic = "online_estimate";
  double odom_rate_hz = 50, joint_states_rate_hz = 50, diagnostics_rate_hz = 1, online_rate_hz = 10;
  bool tf = true;  // the odom -> base_link transform with each Odometry (off when another node,
                   // e.g. robot_localization, publishes it)
  std::string odom_frame = "odom", base_frame = "base_link";
  std::array<std::string, 4> joint_names = {"screw_0_joint", "screw_1_joint", "screw_2_joint", "screw_3_joint"};
  // Who may command the robot over DDS (docs/ros2.md "Who may command the robot"): with a
  // keystore (`auger ros2-keys`) augerd's participant uses DDS Security (authenticated by the
  // keystore's CA, allowed only its own topics, encrypted as the governance says) and ignores
  // every participant without a certificate of that CA; insecure = true runs without, and anyone
  // who reaches the domain may command the robot. Enabled needs exactly one of the two.
  std::string keystore;
  bool insecure = false;
  // A network cmd_vel never overrides a local command (docs/ros2.md "Arbitration"): it is refused
  // while a local goto, follow, vel or spin runs and this long after it ended (or arrived).
  double local_priority_s = 2.0;
};

// The fully qualified ROS 2 names of the topics augerd subscribes (inputs whose topic is not "")
// and publishes (outputs whose rate is > 0) with these settings: what its permissions allow.
std::vector<std::string> input_topics(const Settings& s);
std::vector<std::string> output_topics(const Settings& s);

// augerd's identity in the keystore: the enclave of this name (SROS2's layout, enclaves/NAME).
inline constexpr const char* kEnclave = "augerd";

// The files of a participant's DDS Security identity in its enclave directory (auger ros2-keys)
// and the DDS Security property each one is given to (dds.sec.auth.identity_ca, ...).
struct SecurityFile {
  const char* property;
  std::string path;
};
std::vector<SecurityFile> enclave_files(const std::string& enclave_dir);
// augerd's: the keystore's enclaves/augerd/ (none without a keystore).
std::vector<SecurityFile> security_files(const Settings& s);
// Every DDS Security property of a participant with that enclave, as Cyclone DDS takes them in
// the participant's QoS: the plugins (Debian's libddsc0debian) and "file:" + each enclave file.
std::vector<std::pair<std::string, std::string>> security_properties(const std::string& enclave_dir);

// ---- ROS 2 names (design.ros2.org, "Topic and Service name mapping to DDS") ----

// The fully qualified name of topic `name` in namespace `ns`: a relative name is put under the
// namespace, an absolute one (leading '/') stays. Throws std::invalid_argument naming the rule a
// name breaks (empty, a character other than [A-Za-z0-9_/], a token starting with a digit,
// repeated '/' or '_', a trailing '/', '~' or '{}' substitutions, which augerd does not expand).
std::string fully_qualified_name(const std::string& name, const std::string& ns);
// The DDS topic of a ROS 2 topic: "rt" + the fully qualified name ("/odom" -> "rt/odom").
std::string dds_topic_name(const std::string& fully_qualified);
// Checks a frame id ("odom", "base_link"): non-empty, printable, no spaces. Throws
// std::invalid_argument.
void check_frame_id(const std::string& frame);
// Checks every name and rate of the settings (throws std::invalid_argument naming the key).
void check_settings(const Settings& s);

}  // namespace auger::ros2
