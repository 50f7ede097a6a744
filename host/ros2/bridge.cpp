// The bridge on Eclipse Cyclone DDS (docs/ros2.md). Threads: augerd's loop calls poll() and
// publish(), which only try to take a mutex and copy plain data; Cyclone's receive thread runs
// the readers' listeners (take, convert, keep the newest); the bridge's own thread writes the
// outputs. So no DDS call, allocation or socket write ever happens on the 100 Hz loop.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include <dds/dds.h>

#include "auger/model.hpp"
#include "convert.hpp"
#include "diagnostics.hpp"
#include "ros2.hpp"
#include "ros2_messages.h"

namespace auger::ros2 {
namespace {

// ROS 2's QoS profiles (rmw's qos_profiles.h): the default one (reliable, volatile, keep
// last 10) for commands, odometry, joint states and diagnostics; the sensor data one (best
// effort, volatile, keep last 5) for the camera pose and the IMU; /tf as tf2_ros's broadcaster
// (the default one, keep last 100). Writers never block: keep-last history bounds what a
// reliable writer holds for a slow reader, and max_blocking_time 0 makes a write that would
// wait fail at once (counted) instead. XCDR1, the representation ROS 2's rmw_cyclonedds uses.
enum class Profile { default_, sensor_data, tf };

dds_qos_t* make_qos(Profile p) {
  dds_qos_t* q = dds_create_qos();
  const bool reliable = p != Profile::sensor_data;
  dds_qset_reliability(q, reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT, 0);
  dds_qset_durability(q, DDS_DURABILITY_VOLATILE);
  dds_qset_history(q, DDS_HISTORY_KEEP_LAST, p == Profile::tf ? 100 : p == Profile::sensor_data ? 5 : 10);
  const dds_data_representation_id_t xcdr1 = DDS_DATA_REPRESENTATION_XCDR1;
  dds_qset_data_representation(q, 1, &xcdr1);
  return q;
}

// No DDS peer may crash augerd (docs/ros2.md "Robustness"). Debian's Cyclone DDS 0.10.2 does not
// know XTypes' int8/uint8 type kinds: when it asks a peer for the type object of an endpoint it
// wants to match and the answer has such a member, its type library keeps a null member type and
// then dereferences it (a segfault in the discovery thread; upstream knows int8/uint8 from release
// 11.0, no 0.10.x does). Cyclone asks only while matching two endpoints that both carry XTypes
// type information and whose reader allows type coercion (then it must resolve both types to
// check assignability). So augerd never lets that happen: its readers disallow type coercion (a
// writer with type information must have exactly augerd's type, compared by type identifier,
// nothing to resolve), and its writers carry no type information (a remote reader's QoS decides
// for a writer; without an identifier on one side Cyclone matches by type name, as ROS 2's
// rmw_cyclonedds does).
dds_qos_t* make_reader_qos(Profile p) {
  dds_qos_t* q = make_qos(p);
  dds_qset_type_consistency(q, DDS_TYPE_CONSISTENCY_DISALLOW_TYPE_COERCION, false, false, false, false, false);
  return q;
}

std::unique_ptr<dds_topic_descriptor_t> without_type_information(const dds_topic_descriptor_t& d) {
  return std::unique_ptr<dds_topic_descriptor_t>(new dds_topic_descriptor_t{
      d.m_size, d.m_align, d.m_flagset & ~uint32_t(DDS_TOPIC_XTYPES_METADATA), d.m_nkeys, d.m_typename, d.m_keys,
      d.m_nops, d.m_ops, d.m_meta, {nullptr, 0}, {nullptr, 0}, d.restrict_data_representation});
}

void copy_text(std::array<char, 200>& to, const std::string& s) {
  const std::size_t n = std::min(s.size(), to.size() - 1);
  std::memcpy(to.data(), s.data(), n);
  to[n] = '\0';
}

// Keeps std::string storage alive for the char* fields of a sample being written.
char* text(std::string& s) { return s.data(); }

class CycloneBridge final : public Bridge {
 public:
  explicit CycloneBridge(const Settings& s);
  ~CycloneBridge() override;
  bool poll(Inputs& in) override;
  void publish(const Snapshot& s) override;
  std::string describe() const override { return description_; }

 private:
  struct Reader {
    CycloneBridge* self;
    dds_entity_t reader;
    void (CycloneBridge::*take)(dds_entity_t);
  };
  dds_entity_t topic(const dds_topic_descriptor_t* desc, const std::string& ros_name);
  void add_reader(const std::string& ros_name, const dds_topic_descriptor_t* desc, Profile p,
                  void (CycloneBridge::*take)(dds_entity_t), const char* type);
  dds_entity_t add_writer(const std::string& ros_name, const dds_topic_descriptor_t* desc, Profile p, const char* type);
  static void on_data(dds_entity_t reader, void* arg);
  // Listener bodies (Cyclone's receive thread).
  void take_twist(dds_entity_t r);
  void take_twist_stamped(dds_entity_t r);
  void take_pose(dds_entity_t r);
  void take_pose_cov(dds_entity_t r);
  void take_imu(dds_entity_t r);
  // A pose with its standard deviations and, where the message gave them, its variances (x, y, yaw).
  void pose_in(double t, const geometry_msgs_msg_dds__Pose_& p, const std::array<double, 3>& sd, const double* variance);
  void refuse(const std::string& why);  // with in_mu_ held
  // The writer thread.
  void run();
  void write_odometry(const Snapshot& s);
  void write_joint_states(const Snapshot& s);
  void write_diagnostics(const Snapshot& s);
  void write_online(const Snapshot& s);
  void write(dds_entity_t w, const void* sample, const char* what);

  Settings settings_;
  dds_entity_t domain_ = 0, participant_ = 0;
  std::vector<std::unique_ptr<Reader>> readers_;
  std::vector<std::unique_ptr<dds_topic_descriptor_t>> untyped_;  // the writers' descriptors (add_writer)
  dds_entity_t odom_w_ = 0, joints_w_ = 0, diag_w_ = 0, tf_w_ = 0, online_w_ = 0;
  std::string description_;

  std::mutex in_mu_;
  Inputs in_;  // pending for the next poll

  std::mutex out_mu_;
  std::condition_variable out_cv_;
  Snapshot out_;
  bool out_new_ = false, stop_ = false;
  long skipped_ = 0;       // cycles whose snapshot could not be handed over (writer busy)
  double next_due_s_ = 0;  // publish(): the next snapshot time an output is due
  double next_odom_s_ = 0, next_joints_s_ = 0, next_diag_s_ = 0, next_online_s_ = 0;  // the writer thread's
  long write_failures_ = 0;
  std::thread thread_;
};

CycloneBridge::CycloneBridge(const Settings& s) : settings_(s) {
  // The domain's configuration is dds_config or else Cyclone's built-in defaults, never the
  // CYCLONEDDS_URI of augerd's environment: what `augerd --check` checked is what runs.
  const std::string config = s.dds_config.empty() ? "" : "file://" + s.dds_config;
  domain_ = dds_create_domain(dds_domainid_t(s.domain_id), config.c_str());
  if (domain_ < 0)
    throw std::runtime_error("ROS 2: cannot create DDS domain " + std::to_string(s.domain_id) + " from " +
                             (s.dds_config.empty() ? "Cyclone DDS's defaults" : s.dds_config) + ": " +
                             dds_strretcode(domain_));
  dds_qos_t* pq = dds_create_qos();
  dds_qset_entity_name(pq, "augerd");
  // DDS Security (docs/ros2.md "Who may command the robot"): the plugins of Debian's
  // libddsc0debian, augerd's identity, governance and permissions from the keystore.
  if (!s.keystore.empty())
    for (const auto& [name, value] : security_properties(s.keystore + "/enclaves/" + kEnclave))
      dds_qset_prop(pq, name.c_str(), value.c_str());
  participant_ = dds_create_participant(dds_domainid_t(s.domain_id), pq, nullptr);
  dds_delete_qos(pq);
  if (participant_ < 0) {
    dds_delete(domain_);
    throw std::runtime_error("ROS 2: cannot create the DDS participant in domain " + std::to_string(s.domain_id) +
                             ": " + dds_strretcode(participant_) +
                             (s.keystore.empty() ? " (check the Cyclone DDS configuration)"
                                                 : " (check the keystore " + s.keystore + ": auger ros2-keys)"));
  }
  try {
    description_ = "domain " + std::to_string(s.domain_id) +
                   (s.keystore.empty()
                        ? " WITHOUT DDS Security (insecure = true: anyone who reaches the domain may command the robot)"
                        : ", DDS Security with " + s.keystore + "/enclaves/" + kEnclave) +
                   "; in:";
    add_reader(s.cmd_vel_topic, &geometry_msgs_msg_dds__Twist__desc, Profile::default_, &CycloneBridge::take_twist,
               "Twist");
    add_reader(s.cmd_vel_stamped_topic, &geometry_msgs_msg_dds__TwistStamped__desc, Profile::default_,
               &CycloneBridge::take_twist_stamped, "TwistStamped");
    add_reader(s.pose_topic, &geometry_msgs_msg_dds__PoseStamped__desc, Profile::sensor_data, &CycloneBridge::take_pose,
               "PoseStamped");
    add_reader(s.pose_cov_topic, &geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc, Profile::sensor_data,
               &CycloneBridge::take_pose_cov, "PoseWithCovarianceStamped");
    add_reader(s.imu_topic, &sensor_msgs_msg_dds__Imu__desc, Profile::sensor_data, &CycloneBridge::take_imu, "Imu");
    description_ += "; out:";
    if (s.odom_rate_hz > 0) {
      odom_w_ = add_writer(s.odom_topic, &nav_msgs_msg_dds__Odometry__desc, Profile::default_, "Odometry");
      if (s.tf) tf_w_ = add_writer(s.tf_topic, &tf2_msgs_msg_dds__TFMessage__desc, Profile::tf, "TFMessage");
    }
    if (s.joint_states_rate_hz > 0)
      joints_w_ = add_writer(s.joint_states_topic, &sensor_msgs_msg_dds__JointState__desc, Profile::default_,
                             "JointState");
    if (s.diagnostics_rate_hz > 0)
      diag_w_ = add_writer(s.diagnostics_topic, &diagnostic_msgs_msg_dds__DiagnosticArray__desc, Profile::default_,
                           "DiagnosticArray");
    if (s.online_rate_hz > 0)
      online_w_ = add_writer(s.online_topic, &std_msgs_msg_dds__Float64MultiArray__desc, Profile::default_,
                             "Float64MultiArray");
  } catch (...) {
    dds_delete(participant_);
    dds_delete(domain_);
    throw;
  }
  thread_ = std::thread([this] { run(); });
}

CycloneBridge::~CycloneBridge() {
  {
    std::lock_guard<std::mutex> lk(out_mu_);
    stop_ = true;
  }
  out_cv_.notify_one();
  thread_.join();
  // Deleting the participant deletes its readers (their listeners stop first) and writers.
  dds_delete(participant_);
  dds_delete(domain_);
}

dds_entity_t CycloneBridge::topic(const dds_topic_descriptor_t* desc, const std::string& ros_name) {
  const std::string name = dds_topic_name(fully_qualified_name(ros_name, settings_.ns));
  const dds_entity_t t = dds_create_topic(participant_, desc, name.c_str(), nullptr, nullptr);
  if (t < 0) throw std::runtime_error("ROS 2: cannot create DDS topic " + name + ": " + dds_strretcode(t));
  return t;
}

void CycloneBridge::add_reader(const std::string& ros_name, const dds_topic_descriptor_t* desc, Profile p,
                               void (CycloneBridge::*take)(dds_entity_t), const char* type) {
  if (ros_name.empty()) return;
  const dds_entity_t t = topic(desc, ros_name);
  auto r = std::make_unique<Reader>(Reader{this, 0, take});
  dds_listener_t* l = dds_create_listener(r.get());
  dds_lset_data_available(l, &CycloneBridge::on_data);
  dds_qos_t* q = make_reader_qos(p);
  r->reader = dds_create_reader(participant_, t, q, l);
  dds_delete_qos(q);
  dds_delete_listener(l);  // the reader keeps its own copy
  if (r->reader < 0)
    throw std::runtime_error("ROS 2: cannot create a reader of " + ros_name + ": " + dds_strretcode(r->reader));
  description_ += " " + fully_qualified_name(ros_name, settings_.ns) + " (" + type + ")";
  readers_.push_back(std::move(r));
}

dds_entity_t CycloneBridge::add_writer(const std::string& ros_name, const dds_topic_descriptor_t* desc, Profile p,
                                       const char* type) {
  untyped_.push_back(without_type_information(*desc));
  const dds_entity_t t = topic(untyped_.back().get(), ros_name);
  dds_qos_t* q = make_qos(p);
  const dds_entity_t w = dds_create_writer(participant_, t, q, nullptr);
  dds_delete_qos(q);
  if (w < 0) throw std::runtime_error("ROS 2: cannot create a writer of " + ros_name + ": " + dds_strretcode(w));
  description_ += " " + fully_qualified_name(ros_name, settings_.ns) + " (" + type + ")";
  return w;
}

// ---- inputs (Cyclone's receive thread) ----

void CycloneBridge::on_data(dds_entity_t reader, void* arg) {
  auto* r = static_cast<Reader*>(arg);
  (r->self->*(r->take))(reader);
}

// Takes every sample waiting (loaned, no copy) and hands the valid ones to f, oldest first.
template <class Msg, class F>
void take_all(dds_entity_t reader, F&& f) {
  constexpr int kMax = 16;
  void* buf[kMax] = {nullptr};
  dds_sample_info_t info[kMax];
  for (;;) {
    const dds_return_t n = dds_take(reader, buf, info, kMax, kMax);
    if (n <= 0) return;
    for (int i = 0; i < n; ++i)
      if (info[i].valid_data) f(*static_cast<const Msg*>(buf[i]));
    dds_return_loan(reader, buf, n);
    buf[0] = nullptr;  // the next take lends again (a non-null buf[0] would be copied into)
    if (n < kMax) return;
  }
}

void CycloneBridge::refuse(const std::string& why) {
  ++in_.refused;
  copy_text(in_.refusal, why);
}

void CycloneBridge::take_twist(dds_entity_t r) {
  take_all<geometry_msgs_msg_dds__Twist_>(r, [this](const geometry_msgs_msg_dds__Twist_& m) {
    std::lock_guard<std::mutex> lk(in_mu_);
    ++in_.received;
    // A planar robot: linear.z and the roll and pitch rates have no screw speeds to go to.
    in_.has_vel = true;
    in_.u_mps = m.linear.x;
    in_.v_mps = m.linear.y;
    in_.r_radps = m.angular.z;
  });
}

void CycloneBridge::take_twist_stamped(dds_entity_t r) {
  take_all<geometry_msgs_msg_dds__TwistStamped_>(r, [this](const geometry_msgs_msg_dds__TwistStamped_& m) {
    std::lock_guard<std::mutex> lk(in_mu_);
    ++in_.received;
    in_.has_vel = true;
    in_.u_mps = m.twist.linear.x;
    in_.v_mps = m.twist.linear.y;
    in_.r_radps = m.twist.angular.z;
  });
}

void CycloneBridge::pose_in(double t, const geometry_msgs_msg_dds__Pose_& p, const std::array<double, 3>& sd,
                            const double* variance) {
  // in_mu_ held by the caller.
  ++in_.received;
  double yaw = 0;
  std::string why;
  if (!yaw_from_quaternion(p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w, yaw, why))
    return refuse("pose: " + why);
  if (in_.n_poses == Inputs::kMaxPoses) {  // the oldest goes (counted among `received`, superseded)
    std::move(in_.poses.begin() + 1, in_.poses.end(), in_.poses.begin());
    --in_.n_poses;
  }
  auger::daemon::SensorMessage& m = in_.poses[std::size_t(in_.n_poses++)];
  m = auger::daemon::SensorMessage{};
  m.kind = auger::daemon::SensorKind::pose;
  m.t_unix_s = t;
  m.x_m = p.position.x;
  m.y_m = p.position.y;
  m.psi_rad = yaw;
  m.sx_m = sd[0];
  m.sy_m = sd[1];
  m.spsi_rad = sd[2];
  if (variance) m.var_x_m2 = variance[0], m.var_y_m2 = variance[1], m.var_psi_rad2 = variance[2];
}

void CycloneBridge::take_pose(dds_entity_t r) {
  take_all<geometry_msgs_msg_dds__PoseStamped_>(r, [this](const geometry_msgs_msg_dds__PoseStamped_& m) {
    std::lock_guard<std::mutex> lk(in_mu_);
    pose_in(stamp_to_unix_s(m.header.stamp.sec, m.header.stamp.nanosec), m.pose, settings_.pose_std, nullptr);
  });
}

void CycloneBridge::take_pose_cov(dds_entity_t r) {
  take_all<geometry_msgs_msg_dds__PoseWithCovarianceStamped_>(
      r, [this](const geometry_msgs_msg_dds__PoseWithCovarianceStamped_& m) {
        std::lock_guard<std::mutex> lk(in_mu_);
        // The diagonal's x, y and rot Z variances go to the estimator as they are; their square
        // roots to the checks and the log. A negative one gives NaN, which augerd's checks refuse
        // like any non-finite standard deviation.
        const double* c = m.pose.covariance;
        const double variance[3] = {c[0], c[7], c[35]};
        pose_in(stamp_to_unix_s(m.header.stamp.sec, m.header.stamp.nanosec), m.pose.pose,
                {std::sqrt(c[0]), std::sqrt(c[7]), std::sqrt(c[35])}, variance);
      });
}

void CycloneBridge::take_imu(dds_entity_t r) {
  take_all<sensor_msgs_msg_dds__Imu_>(r, [this](const sensor_msgs_msg_dds__Imu_& m) {
    std::lock_guard<std::mutex> lk(in_mu_);
    ++in_.received;
    // sensor_msgs/Imu: element 0 of a covariance at -1 means that estimate is absent; augerd's
    // IMU input is the heading and the yaw rate together (the sensors socket's `imu`).
    if (m.orientation_covariance[0] == -1)
      return refuse("imu: no orientation (orientation_covariance[0] = -1); augerd needs the heading");
    if (m.angular_velocity_covariance[0] == -1)
      return refuse("imu: no angular velocity (angular_velocity_covariance[0] = -1); augerd needs the yaw rate");
    double yaw = 0;
    std::string why;
    if (!yaw_from_quaternion(m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w, yaw, why))
      return refuse("imu: " + why);
    in_.has_imu = true;
    in_.imu = auger::daemon::SensorMessage{};
    in_.imu.kind = auger::daemon::SensorKind::imu;
    in_.imu.t_unix_s = stamp_to_unix_s(m.header.stamp.sec, m.header.stamp.nanosec);
    in_.imu.imu_psi_rad = yaw;
    in_.imu.imu_r_radps = m.angular_velocity.z;
    // The accelerometer's specific force in the body frame (REP 103: x forward, y left), the
    // imu line's optional fields; absent where its covariance says so (REP 145), and where all
    // three are exactly 0: a message never filled in (an accelerometer reads gravity, about
    // 9.81 m/s^2 up), which taken as measured would say the robot never accelerates. Its
    // variance is not used: the kinematic filter has its own noise setting ([online] acc_noise_...).
    const auto& a = m.linear_acceleration;
    in_.imu.has_acc = m.linear_acceleration_covariance[0] != -1 && !(a.x == 0 && a.y == 0 && a.z == 0);
    in_.imu.ax_mps2 = m.linear_acceleration.x;
    in_.imu.ay_mps2 = m.linear_acceleration.y;
  });
}

bool CycloneBridge::poll(Inputs& in) {
  std::unique_lock<std::mutex> lk(in_mu_, std::try_to_lock);
  if (!lk || in_.received == 0) return false;
  in = in_;
  in_ = Inputs{};
  return true;
}

// ---- outputs ----

void CycloneBridge::publish(const Snapshot& s) {
  if (s.t_unix_s < next_due_s_) return;
  std::unique_lock<std::mutex> lk(out_mu_, std::try_to_lock);
  if (!lk) {
    ++skipped_;
    return;
  }
  out_ = s;
  out_new_ = true;
  lk.unlock();
  out_cv_.notify_one();
  // The next time any output is due: the fastest rate's period (the writer thread keeps each
  // output to its own rate).
  const double fastest = std::max({settings_.odom_rate_hz, settings_.joint_states_rate_hz, settings_.diagnostics_rate_hz,
                                   settings_.online_rate_hz});
  next_due_s_ = fastest > 0 ? s.t_unix_s + 1.0 / fastest - 0.002 : 1e300;
}

void CycloneBridge::run() {
  Snapshot s;
  for (;;) {
    {
      std::unique_lock<std::mutex> lk(out_mu_);
      out_cv_.wait(lk, [this] { return out_new_ || stop_; });
      if (stop_) return;
      s = out_;
      out_new_ = false;
    }
    // Each output on its own schedule, to within 2 ms of the loop's cycle (which is 10 ms).
    auto due = [&](double& next, double rate_hz) {
      if (rate_hz <= 0 || s.t_unix_s < next - 0.002) return false;
      next = std::max(next + 1.0 / rate_hz, s.t_unix_s + 0.5 / rate_hz);
      return true;
    };
    if (due(next_odom_s_, settings_.odom_rate_hz)) write_odometry(s);
    if (due(next_joints_s_, settings_.joint_states_rate_hz)) write_joint_states(s);
    if (due(next_diag_s_, settings_.diagnostics_rate_hz)) write_diagnostics(s);
    // Only while augerd runs the estimator ([online] enabled).
    if (s.online.enabled && due(next_online_s_, settings_.online_rate_hz)) write_online(s);
  }
}

void CycloneBridge::write(dds_entity_t w, const void* sample, const char* what) {
  const dds_return_t rc = dds_write(w, sample);
  if (rc == DDS_RETCODE_OK) return;
  // Reported at the first failure and then every 100th (a reader that stopped acknowledging).
  if (write_failures_++ % 100 == 0)
    std::fprintf(stderr, "augerd: ROS 2: writing %s failed (%s); %ld failure(s) so far\n", what, dds_strretcode(rc),
                 write_failures_);
}

void CycloneBridge::write_odometry(const Snapshot& s) {
  std::string odom_frame = settings_.odom_frame, base_frame = settings_.base_frame;
  nav_msgs_msg_dds__Odometry_ m{};
  unix_s_to_stamp(s.t_unix_s, m.header.stamp.sec, m.header.stamp.nanosec);
  m.header.frame_id = text(odom_frame);
  m.child_frame_id = text(base_frame);
  double q[4];
  quaternion_from_yaw(s.eta[2], q);
  m.pose.pose.position.x = s.eta[0];
  m.pose.pose.position.y = s.eta[1];
  m.pose.pose.orientation.x = q[0];
  m.pose.pose.orientation.y = q[1];
  m.pose.pose.orientation.z = q[2];
  m.pose.pose.orientation.w = q[3];
  m.twist.twist.linear.x = s.zeta[0];
  m.twist.twist.linear.y = s.zeta[1];
  m.twist.twist.angular.z = s.zeta[2];
  // Without the EKF's covariance (dead-reckoning estimators) the covariances stay all zeros,
  // ROS's "unknown".
  if (s.has_cov) odometry_covariance(s.cov, m.pose.covariance, m.twist.covariance);
  write(odom_w_, &m, "Odometry");
  if (!tf_w_) return;
  geometry_msgs_msg_dds__TransformStamped_ ts{};
  ts.header = m.header;
  ts.child_frame_id = m.child_frame_id;
  ts.transform.translation.x = s.eta[0];
  ts.transform.translation.y = s.eta[1];
  ts.transform.rotation = m.pose.pose.orientation;
  tf2_msgs_msg_dds__TFMessage_ tf{};
  tf.transforms._length = tf.transforms._maximum = 1;
  tf.transforms._buffer = &ts;
  tf.transforms._release = false;
  write(tf_w_, &tf, "TFMessage");
}

void CycloneBridge::write_joint_states(const Snapshot& s) {
  std::string frame;  // JointState's header frame is empty by convention
  std::array<std::string, 4> names = settings_.joint_names;
  char* name_ptrs[4];
  double velocity_radps[4], effort_a[4];
  for (int i = 0; i < 4; ++i) {
    name_ptrs[i] = text(names[std::size_t(i)]);
    const ModuleSnapshot& mod = s.module[i];
    // A module not answering has no speed or current to report: NaN, not its last value.
    velocity_radps[i] = mod.answering ? mod.omega_rpm * auger::kRpmToRadps : NAN;
    effort_a[i] = mod.answering ? mod.current_a : NAN;
  }
  sensor_msgs_msg_dds__JointState_ m{};
  unix_s_to_stamp(s.t_unix_s, m.header.stamp.sec, m.header.stamp.nanosec);
  m.header.frame_id = text(frame);
  m.name._length = m.name._maximum = 4;
  m.name._buffer = name_ptrs;
  m.velocity._length = m.velocity._maximum = 4;
  m.velocity._buffer = velocity_radps;
  m.effort._length = m.effort._maximum = 4;
  m.effort._buffer = effort_a;
  // position stays empty: augerd does not know the counts per screw turn (module EEPROM).
  write(joints_w_, &m, "JointState");
}

void CycloneBridge::write_diagnostics(const Snapshot& s) {
  // Storage for the strings the sample points into (this thread only; allocation is fine here).
  std::vector<DiagnosticEntry> st = diagnostics(s, skipped_);
  std::vector<diagnostic_msgs_msg_dds__DiagnosticStatus_> status(st.size());
  std::vector<std::vector<diagnostic_msgs_msg_dds__KeyValue_>> kvs(st.size());
  for (std::size_t i = 0; i < st.size(); ++i) {
    for (auto& [k, v] : st[i].kv) kvs[i].push_back({text(k), text(v)});
    auto& d = status[i];
    d.level = st[i].level;
    d.name = text(st[i].name);
    d.message = text(st[i].message);
    d.hardware_id = text(st[i].hardware_id);
    d.values._length = d.values._maximum = uint32_t(kvs[i].size());
    d.values._buffer = kvs[i].data();
    d.values._release = false;
  }
  std::string frame;
  diagnostic_msgs_msg_dds__DiagnosticArray_ m{};
  unix_s_to_stamp(s.t_unix_s, m.header.stamp.sec, m.header.stamp.nanosec);
  m.header.frame_id = text(frame);
  m.status._length = m.status._maximum = uint32_t(status.size());
  m.status._buffer = status.data();
  m.status._release = false;
  write(diag_w_, &m, "DiagnosticArray");
}

// Float64MultiArray (docs/ros2.md "Online estimate"): numbers a plot or a node takes without
// parsing text, self-described by the layout's labels, and a type every ROS 2 installation has.
void CycloneBridge::write_online(const Snapshot& s) {
  std::string parameter = "parameter", value_sd = "value_sd";
  std_msgs_msg_dds__MultiArrayDimension_ dim[2] = {
      {text(parameter), uint32_t(kOnlineParams), uint32_t(kOnlineParams * kOnlineColumns)},
      {text(value_sd), uint32_t(kOnlineColumns), uint32_t(kOnlineColumns)}};
  double data[kOnlineParams * kOnlineColumns];
  online_estimate_data(s.online, data);
  std_msgs_msg_dds__Float64MultiArray_ m{};
  m.layout.dim._length = m.layout.dim._maximum = 2;
  m.layout.dim._buffer = dim;
  m.layout.dim._release = false;
  m.layout.data_offset = 0;
  m.data._length = m.data._maximum = uint32_t(kOnlineParams * kOnlineColumns);
  m.data._buffer = data;
  m.data._release = false;
  write(online_w_, &m, "Float64MultiArray");
}

}  // namespace

bool available() { return true; }

std::unique_ptr<Bridge> make_bridge(const Settings& s) {
  check_settings(s);
  return std::make_unique<CycloneBridge>(s);
}

}  // namespace auger::ros2
