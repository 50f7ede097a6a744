// A DDS participant with DDS Security for test_ros2_secure.py: Debian's Cyclone DDS with its
// security plugins (the Python binding's own build of the C library carries none), given an
// enclave of `auger ros2-keys` (or "none": no security). It publishes a Twist or a PoseStamped
// (stamped 30 ms ago, as a camera's) at 20 Hz, or counts Odometry samples, and prints what it saw:
//   ros2_secure_peer DOMAIN ENCLAVE_DIR|none DDS_CONFIG twist TOPIC U V R SECONDS   -> "matched N"
//   ros2_secure_peer DOMAIN ENCLAVE_DIR|none DDS_CONFIG pose TOPIC X Y YAW SECONDS  -> "matched N"
//   ros2_secure_peer DOMAIN ENCLAVE_DIR|none DDS_CONFIG odom TOPIC SECONDS          -> "received N"
// (TOPIC is the DDS topic, e.g. rt/robot1/cmd_vel; N the most readers matched / samples taken;
// "refused ..." when its own access control refuses the endpoint.)
#include <dds/dds.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

#include "auger/ros2_settings.hpp"
#include "ros2_messages.h"

namespace {

int usage() {
  std::fprintf(stderr,
               "usage: ros2_secure_peer DOMAIN ENCLAVE|none DDS_CONFIG twist TOPIC U V R SECONDS\n"
               "       ros2_secure_peer DOMAIN ENCLAVE|none DDS_CONFIG pose TOPIC X Y YAW SECONDS\n"
               "       ros2_secure_peer DOMAIN ENCLAVE|none DDS_CONFIG odom TOPIC SECONDS\n");
  return 2;
}

dds_qos_t* topic_qos() {
  // ROS 2's default profile (reliable, volatile, keep last 10), XCDR1.
  dds_qos_t* q = dds_create_qos();
  dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  dds_qset_durability(q, DDS_DURABILITY_VOLATILE);
  dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 10);
  const dds_data_representation_id_t xcdr1 = DDS_DATA_REPRESENTATION_XCDR1;
  dds_qset_data_representation(q, 1, &xcdr1);
  return q;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 6) return usage();
  const dds_domainid_t domain = dds_domainid_t(std::atoi(argv[1]));
  const std::string enclave = argv[2], config = std::string("file://") + argv[3], action = argv[4], topic = argv[5];
  if (dds_create_domain(domain, config.c_str()) < 0) {
    std::fprintf(stderr, "ros2_secure_peer: cannot create the domain from %s\n", argv[3]);
    return 1;
  }
  dds_qos_t* pq = dds_create_qos();
  if (enclave != "none")
    for (const auto& [name, value] : auger::ros2::security_properties(enclave))
      dds_qset_prop(pq, name.c_str(), value.c_str());
  const dds_entity_t pp = dds_create_participant(domain, pq, nullptr);
  dds_delete_qos(pq);
  if (pp < 0) {
    std::fprintf(stderr, "ros2_secure_peer: cannot create the participant: %s\n", dds_strretcode(pp));
    return 1;
  }
  const bool twist = action == "twist" && argc == 10, pose = action == "pose" && argc == 10,
             odom = action == "odom" && argc == 7;
  if (!twist && !pose && !odom) return usage();
  const double seconds = std::atof(argv[odom ? 6 : 9]);
  const dds_topic_descriptor_t* desc = twist  ? &geometry_msgs_msg_dds__Twist__desc
                                       : pose ? &geometry_msgs_msg_dds__PoseStamped__desc
                                              : &nav_msgs_msg_dds__Odometry__desc;
  const dds_entity_t t = dds_create_topic(pp, desc, topic.c_str(), nullptr, nullptr);
  dds_qos_t* q = topic_qos();
  const dds_entity_t ep = t < 0 ? t
                          : odom ? dds_create_reader(pp, t, q, nullptr)
                                 : dds_create_writer(pp, t, q, nullptr);
  dds_delete_qos(q);
  if (ep < 0) {
    // Access control refuses an endpoint its permissions do not allow.
    std::printf("refused %s\n", dds_strretcode(ep));
    dds_delete(DDS_CYCLONEDDS_HANDLE);
    return 0;
  }
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  long seen = 0;
  const double a = std::atof(argv[6]), b = odom ? 0 : std::atof(argv[7]), c = odom ? 0 : std::atof(argv[8]);
  geometry_msgs_msg_dds__Twist_ tw{};
  tw.linear.x = a;
  tw.linear.y = b;
  tw.angular.z = c;
  geometry_msgs_msg_dds__PoseStamped_ ps{};
  char frame[] = "world";
  ps.header.frame_id = frame;
  ps.pose.position.x = a;
  ps.pose.position.y = b;
  ps.pose.orientation.z = std::sin(c / 2);
  ps.pose.orientation.w = std::cos(c / 2);
  while (std::chrono::steady_clock::now() < end) {
    if (!odom) {
      dds_publication_matched_status_t st;
      if (dds_get_publication_matched_status(ep, &st) == 0 && long(st.current_count) > seen) seen = st.current_count;
      timespec now;
      clock_gettime(CLOCK_REALTIME, &now);
      const double stamp_s = double(now.tv_sec) + 1e-9 * double(now.tv_nsec) - 0.03;
      ps.header.stamp.sec = int32_t(stamp_s);
      ps.header.stamp.nanosec = uint32_t((stamp_s - double(int32_t(stamp_s))) * 1e9);
      dds_write(ep, twist ? static_cast<const void*>(&tw) : static_cast<const void*>(&ps));
    } else {
      void* buf[16] = {nullptr};
      dds_sample_info_t info[16];
      const int n = dds_take(ep, buf, info, 16, 16);
      for (int i = 0; i < n; ++i) seen += info[i].valid_data ? 1 : 0;
      if (n > 0) dds_return_loan(ep, buf, n);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  std::printf("%s %ld\n", odom ? "received" : "matched", seen);
  dds_delete(DDS_CYCLONEDDS_HANDLE);
  return 0;
}
