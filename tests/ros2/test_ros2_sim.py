"""augerd's ROS 2 interface seen from an independent DDS participant (Cyclone DDS's Python
binding, its own build of the C library; types from ros2_msgs.py, names from ros2_names.py),
against augerd driving the simulated robot in real time (tests/ros2/ros2_sim.sh starts both).
Run in order, one robot: names and QoS on the wire, the outputs at rest (values, rates), a Twist
driving the robot and the 0.5 s dead-man stopping it, then the pose and IMU inputs and their
refusals, then the arbitration between local commands and the network's cmd_vel. Loopback only, on the domain id the script chose."""
import math
import os
import threading
import time

import pytest
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader, InvalidSample
from cyclonedds.topic import Topic
from cyclonedds.util import duration

import ros2_msgs as m
from augerd_cmd import command, events, logged, status
from ros2_names import dds_topic_name, dds_type_name, is_valid_fully_qualified

ENV = os.environ
NS = ENV["ROS2_NS"]
TOPICS = {  # ROS name -> ROS type, as ros2_sim.sh configured augerd
    "out": {
        ENV["ROS2_ODOM"]: "nav_msgs/msg/Odometry",
        ENV["ROS2_JOINTS"]: "sensor_msgs/msg/JointState",
        "/diagnostics": "diagnostic_msgs/msg/DiagnosticArray",
        "/tf": "tf2_msgs/msg/TFMessage",
        ENV["ROS2_ONLINE"]: "std_msgs/msg/Float64MultiArray",  # [online] enabled by ros2_sim.sh
    },
    "in": {
        ENV["ROS2_CMD_VEL"]: "geometry_msgs/msg/Twist",
        ENV["ROS2_CMD_VEL_STAMPED"]: "geometry_msgs/msg/TwistStamped",
        ENV["ROS2_POSE"]: "geometry_msgs/msg/PoseStamped",
        ENV["ROS2_POSE_COV"]: "geometry_msgs/msg/PoseWithCovarianceStamped",
        ENV["ROS2_IMU"]: "sensor_msgs/msg/Imu",
    },
}
RPM_TO_RADPS = 2 * math.pi / 60

# ROS 2's QoS profiles (rmw qos_profiles.h), as a ROS 2 node would create its endpoints.
DEFAULT = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.Durability.Volatile,
              Policy.History.KeepLast(10), Policy.DataRepresentation(use_cdrv0_representation=True))
SENSOR_DATA = Qos(Policy.Reliability.BestEffort, Policy.Durability.Volatile, Policy.History.KeepLast(5),
                  Policy.DataRepresentation(use_cdrv0_representation=True))


def stamp_s(h):
    return h.stamp.sec + 1e-9 * h.stamp.nanosec


# A camera's frame arrives some time after it was taken; augerd's estimator compares it with
# its prediction for that time (a frame stamped after augerd's previous cycle is not used).
CAMERA_LATENCY_S = 0.03


def stamp_now(offset_s=0.0):
    t = time.time() + offset_s
    return m.Header(stamp=m.Time(sec=int(t), nanosec=int((t - int(t)) * 1e9)), frame_id="world")


def yaw(q):
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


def quat(psi):
    return m.Quaternion(x=0.0, y=0.0, z=math.sin(psi / 2), w=math.cos(psi / 2))


class Collector:
    """Takes every sample of augerd's outputs in a background thread: (receive time, sample)."""

    def __init__(self, dp):
        self.readers = {}
        for name, ros_type in TOPICS["out"].items():
            cls = getattr(m, ros_type.split("/")[-1])
            qos = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.Durability.Volatile,
                      Policy.History.KeepLast(100 if name == "/tf" else 10))
            self.readers[ros_type.split("/")[-1]] = DataReader(dp, Topic(dp, dds_topic_name(name, NS), cls), qos=qos)
        self.got = {k: [] for k in self.readers}
        self.lock = threading.Lock()
        self.stop = False
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self):
        while not self.stop:
            now = time.time()
            for k, r in self.readers.items():
                for s in r.take(N=200):
                    if isinstance(s, InvalidSample):  # a writer gone (augerd stopped): no data in it
                        continue
                    with self.lock:
                        self.got[k].append((now, s))
            time.sleep(0.004)

    def since(self, kind, t0):
        with self.lock:
            return [s for (t, s) in self.got[kind] if stamp_s(self.header(kind, s)) >= t0]

    @staticmethod
    def header(kind, s):
        return s.transforms[0].header if kind == "TFMessage" else s.header

    def latest(self, kind, timeout=3.0):
        end = time.time() + timeout
        with self.lock:
            n = len(self.got[kind])
        while time.time() < end:
            with self.lock:
                if len(self.got[kind]) > n:
                    return self.got[kind][-1][1]
            time.sleep(0.01)
        raise AssertionError(f"no {kind} within {timeout} s")


@pytest.fixture(scope="module")
def dds():
    dp = DomainParticipant(int(ENV["ROS2_DOMAIN"]))
    col = Collector(dp)
    writers = {}
    for name, ros_type in TOPICS["in"].items():
        cls = getattr(m, ros_type.split("/")[-1])
        qos = DEFAULT if "Twist" in ros_type else SENSOR_DATA
        writers[ros_type.split("/")[-1]] = DataWriter(dp, Topic(dp, dds_topic_name(name, NS), cls), qos=qos)
    yield dp, col, writers
    col.stop = True
    col.thread.join()


def augerd_endpoints(col, writers, timeout=5.0):
    """augerd's writers matched by our readers and its readers matched by our writers, from DDS
    discovery: {(topic, type): qos} per direction. A match needs the same topic and type name
    and compatible QoS, so every ROS 2 name of ours that augerd also uses shows up here."""
    found = {"out": {}, "in": {}}
    end = time.time() + timeout
    while time.time() < end:
        for kind, ents, matched, data in (
                ("out", col.readers.values(), "get_matched_publications", "get_matched_publication_data"),
                ("in", writers.values(), "get_matched_subscriptions", "get_matched_subscription_data")):
            for ent in ents:
                for h in getattr(ent, matched)():
                    e = getattr(ent, data)(h)
                    found[kind][(e.topic_name, e.type_name)] = e.qos
        if all(len(found[k]) == len(TOPICS[k]) for k in found):
            break
        time.sleep(0.05)
    want = {k: {(dds_topic_name(n, NS), dds_type_name(t)) for n, t in v.items()} for k, v in TOPICS.items()}
    return found, want


def test_names_and_qos_on_the_wire(dds):
    _, col, writers = dds
    found, want = augerd_endpoints(col, writers)
    for kind in ("out", "in"):
        assert want[kind] <= set(found[kind]), f"augerd's {kind} endpoints {sorted(found[kind])} lack {want[kind] - set(found[kind])}"
        for (topic, typ) in found[kind]:
            # Every name augerd announces follows ROS 2's mapping: rt/ + a valid fully qualified
            # name; pkg::msg::dds_::Type_.
            assert topic.startswith("rt/") and is_valid_fully_qualified(topic[2:]), topic
            pkg, msg, dds_, t = typ.split("::")
            assert msg == "msg" and dds_ == "dds_" and t.endswith("_"), typ
    rel = lambda q: q[Policy.Reliability]
    for (topic, typ), q in found["out"].items():
        assert isinstance(rel(q), Policy.Reliability.Reliable), (topic, q)
        assert q[Policy.Durability] == Policy.Durability.Volatile, (topic, q)
        assert q[Policy.History] == Policy.History.KeepLast(100 if topic == "rt/tf" else 10), (topic, q)
    for (topic, typ), q in found["in"].items():
        if "Twist" in typ:
            assert isinstance(rel(q), Policy.Reliability.Reliable) and q[Policy.History] == Policy.History.KeepLast(10), (topic, q)
        else:  # the sensor data profile: best effort, keep last 5
            assert rel(q) == Policy.Reliability.BestEffort and q[Policy.History] == Policy.History.KeepLast(5), (topic, q)


def test_outputs_at_rest(dds):
    _, col, _ = dds
    t0 = time.time()
    time.sleep(3.3)
    odom, joints, diag, tf = (col.since(k, t0 + 0.1) for k in ("Odometry", "JointState", "DiagnosticArray", "TFMessage"))
    st = status()

    def rate(samples, kind):
        ts = [stamp_s(Collector.header(kind, s)) for s in samples]
        assert all(b > a for a, b in zip(ts, ts[1:])), f"{kind} stamps not increasing"
        return (len(ts) - 1) / (ts[-1] - ts[0])

    # Stated rates: Odometry, /tf and JointState 50 Hz, diagnostics 1 Hz (docs/ros2.md).
    assert 45 <= rate(odom, "Odometry") <= 55
    assert 45 <= rate(tf, "TFMessage") <= 55
    assert 45 <= rate(joints, "JointState") <= 55
    assert len(diag) >= 3 and 0.95 <= rate(diag, "DiagnosticArray") <= 1.05
    # Stamped with augerd's wall clock, delivered within 50 ms.
    lag = [t - stamp_s(s.header) for (t, s) in col.got["Odometry"][-50:]]
    assert max(lag) < 0.05 and min(lag) > -0.01, lag

    o = odom[-1]
    assert (o.header.frame_id, o.child_frame_id) == ("odom", "base_link")
    q = o.pose.pose.orientation
    assert abs(q.x ** 2 + q.y ** 2 + q.z ** 2 + q.w ** 2 - 1) < 1e-12 and q.x == q.y == 0
    # The estimate is augerd's own (status), at rest.
    assert abs(o.pose.pose.position.x - float(st["x_m"])) < 0.002
    assert abs(o.pose.pose.position.y - float(st["y_m"])) < 0.002
    assert abs(yaw(q) - float(st["psi_rad"])) < 0.002
    assert abs(o.twist.twist.linear.x) < 0.01 and abs(o.twist.twist.angular.z) < 0.02
    for cov in (o.pose.covariance, o.twist.covariance):
        # Symmetric, positive variances for x, y, yaw; z, roll, pitch "not estimated" (1e6).
        assert all(abs(cov[6 * i + j] - cov[6 * j + i]) < 1e-15 for i in range(6) for j in range(6))
        assert all(cov[7 * i] > 0 for i in (0, 1, 5)) and all(cov[7 * i] == 1e6 for i in (2, 3, 4))
        assert all(cov[6 * i + j] ** 2 <= cov[7 * i] * cov[7 * j] * (1 + 1e-9) for i in range(6) for j in range(6))
    t = tf[-1].transforms[0]
    assert (t.header.frame_id, t.child_frame_id) == ("odom", "base_link")

    j = joints[-1]
    assert j.name == [f"screw_{i}_joint" for i in range(4)] and j.position == []
    assert len(j.velocity) == len(j.effort) == 4
    assert all(abs(v) < 0.1 for v in j.velocity), j.velocity  # at rest, rad/s
    assert all(math.isfinite(e) and abs(e) < 5 for e in j.effort), j.effort  # motor current, A

    d = diag[-1]
    names = [s.name for s in d.status]
    assert names == [f"augerd: module {i} ({w})" for i, w in enumerate(["front-right", "rear-right", "rear-left", "front-left"])] + ["augerd: controller", "augerd: online estimator"]
    for i, s in enumerate(d.status[:4]):
        kv = {x.key: x.value for x in s.values}
        assert f"module{i}" in s.hardware_id and "firmware" in s.hardware_id
        assert s.level in (0, 1), (s.level, s.message)  # OK, or WARN: stopped the robot at start-up
        assert abs(float(kv["voltage_v"]) - float(st[f"m{i}_voltage_v"])) < 0.5
        assert kv["faults"] == "none" and int(kv["host_crc_errors"]) == 0


def send(writer, sample, hz, seconds):
    """Writes sample at hz for seconds; returns the time just before the last write (a
    process descheduled after it would otherwise report a later time than augerd got it)."""
    end = time.time() + seconds
    while True:
        last = time.time()
        writer.write(sample)
        if last + 1 / hz > end:
            return last
        time.sleep(1 / hz)


def last_refusal(col):
    """The last refused ROS 2 input, as the first diagnostics published from now on name it."""
    t = time.time()
    while True:
        d = col.latest("DiagnosticArray")
        if stamp_s(d.header) > t:
            break
    kv = {x.key: x.value for x in d.status[4].values}
    return kv["ros2_last_refusal"]


def test_twist_refused_until_enabled(dds):
    _, _, w = dds
    before = int(status()["ros2_refused"])
    send(w["Twist"], m.Twist(linear=m.Vector3(x=0.05)), 20, 0.3)
    st = status()
    assert st["mode"] == "stopped" and int(st["ros2_refused"]) > before


def test_twist_drives_and_dead_man_stops(dds):
    _, col, w = dds
    command("enable")
    start = time.time()
    odom0 = col.latest("Odometry")
    last = send(w["Twist"], m.Twist(linear=m.Vector3(x=0.05)), 20, 3.0)
    assert status()["mode"] == "vel"
    time.sleep(1.2)
    odom = col.since("Odometry", start)
    joints = col.since("JointState", start)
    diag = [d for d in col.since("DiagnosticArray", start) if stamp_s(d.header) <= last][-1]
    # Driving: augerd's commanded screw speeds for +u (eq. (3): -, -, +, +) and the speeds
    # JointState reports, over the last second of the drive.
    cmd_rpm = [float({x.key: x.value for x in s.values}["cmd_rpm"]) for s in diag.status[:4]]
    assert [math.copysign(1, c) for c in cmd_rpm] == [-1, -1, 1, 1] and min(map(abs, cmd_rpm)) > 5, cmd_rpm
    steady = [j for j in joints if last - 1.0 <= stamp_s(j.header) <= last]
    for i in range(4):
        mean = sum(j.velocity[i] for j in steady) / len(steady)
        assert abs(mean - cmd_rpm[i] * RPM_TO_RADPS) < 0.15 * abs(cmd_rpm[i] * RPM_TO_RADPS), (i, mean, cmd_rpm[i])
    u = [o.twist.twist.linear.x for o in odom if last - 1.0 <= stamp_s(o.header) <= last]
    assert 0.025 < sum(u) / len(u) < 0.075, sum(u) / len(u)
    at_last = min(odom, key=lambda o: abs(stamp_s(o.header) - last))
    dx = at_last.pose.pose.position.x - odom0.pose.pose.position.x
    assert 0.05 < dx < 0.2, dx
    # The dead-man: still turning 0.4 s after the last Twist, stopped by 1.0 s (0.5 s expiry,
    # then the modules' speed loop brings the screws to rest).
    def turning(j):
        return max(abs(v) for v in j.velocity) > 0.3

    after = [j for j in joints if stamp_s(j.header) > last]
    assert any(turning(j) for j in after if stamp_s(j.header) >= last + 0.4), "stopped before the 0.5 s dead-man"
    stopped_at = next(stamp_s(j.header) for j in after if not any(turning(k) for k in after if stamp_s(k.header) >= stamp_s(j.header)))
    assert 0.45 <= stopped_at - last <= 1.0, stopped_at - last
    assert status()["mode"] == "idle"
    print(f"dead-man: screws below 0.3 rad/s {stopped_at - last:.3f} s after the last Twist")


def test_twist_stamped(dds):
    _, col, w = dds
    start = time.time()
    ts = m.TwistStamped(header=stamp_now(), twist=m.Twist(linear=m.Vector3(y=0.05)))
    last = send(w["TwistStamped"], ts, 20, 1.0)
    assert status()["mode"] == "vel"
    time.sleep(0.1)
    v = [o.twist.twist.linear.y for o in col.since("Odometry", start) if stamp_s(o.header) > last - 0.3]
    assert sum(v) / len(v) > 0.01, v  # moving to the left
    time.sleep(0.6)
    assert status()["mode"] == "idle"


def test_twist_outside_the_bounds_refused(dds):
    # Enabled, a Twist of 1e308 m/s (once a NaN setpoint) goes through `vel`'s bounds
    # (auger/input_limits.hpp): refused, the robot does not move.
    _, col, w = dds
    command("enable")
    before = int(status()["ros2_refused"])
    send(w["Twist"], m.Twist(linear=m.Vector3(x=1e308)), 20, 0.2)
    st = status()
    assert st["mode"] == "idle" and int(st["ros2_refused"]) > before, st
    assert "u_mps = 1e+308 m/s is outside -10..10 m/s" in last_refusal(col)


def test_pose_and_imu_inputs(dds):
    _, col, w = dds
    command("stop")
    time.sleep(0.3)
    o = col.latest("Odometry")
    x0, y0, psi0 = o.pose.pose.position.x, o.pose.pose.position.y, yaw(o.pose.pose.orientation)
    st0 = status()
    applied0, refused0 = int(st0["ros2_applied"]), int(st0["ros2_refused"])
    # A camera 5 cm ahead of the estimate (PoseStamped, the configured 3 mm / 5 mrad): the
    # estimate follows it, and status shows it as the camera pose.
    for _ in range(10):
        w["PoseStamped"].write(m.PoseStamped(header=stamp_now(-CAMERA_LATENCY_S), pose=m.Pose(position=m.Point(x=x0 + 0.05, y=y0), orientation=quat(psi0))))
        time.sleep(0.05)
    time.sleep(0.1)
    st = status()
    assert abs(float(st["cam_x_m"]) - (x0 + 0.05)) < 1e-4 and float(st["pose_age_s"]) < 0.5
    # Best effort: most, at least.
    assert int(st["ros2_applied"]) >= applied0 + 5 and int(st["ros2_refused"]) == refused0
    assert col.latest("Odometry").pose.pose.position.x > x0 + 0.03
    # A burst of frames within one cycle: every one reaches the estimator (one per cycle), none
    # is superseded by the next (before: the newest of a cycle only).
    applied1 = int(status()["ros2_applied"])
    for k in range(5):
        w["PoseStamped"].write(m.PoseStamped(header=stamp_now(-CAMERA_LATENCY_S - 0.01 * (5 - k)), pose=m.Pose(position=m.Point(x=x0 + 0.05, y=y0), orientation=quat(psi0))))
    time.sleep(0.2)
    assert int(status()["ros2_applied"]) == applied1 + 5

    def refused(writer, sample, why):
        before = status()
        writer.write(sample)
        time.sleep(0.15)
        after = status()
        assert int(after["ros2_refused"]) == int(before["ros2_refused"]) + 1, why
        assert after["cam_x_m"] == before["cam_x_m"] and after["imu_psi_rad"] == before["imu_psi_rad"], why

    good = m.Pose(position=m.Point(x=x0 + 1.0, y=y0), orientation=quat(psi0))
    # The sensors socket's checks: a pose taken 5 s ago is refused ...
    refused(w["PoseStamped"], m.PoseStamped(header=stamp_now(-5.0), pose=good), "stale pose")
    # ... and so are non-finite standard deviations (a negative variance).
    cov = [0.0] * 36
    cov[0], cov[7], cov[35] = -1e-6, 1e-6, 1e-6
    refused(w["PoseWithCovarianceStamped"], m.PoseWithCovarianceStamped(header=stamp_now(), pose=m.PoseWithCovariance(pose=good, covariance=cov)), "negative variance")
    # ... and values outside the bounds of auger/input_limits.hpp, which once made the estimate
    # NaN for good: a standard deviation of 1e100 m, a position of 1e300 m.
    cov[0] = 1e200
    refused(w["PoseWithCovarianceStamped"], m.PoseWithCovarianceStamped(header=stamp_now(), pose=m.PoseWithCovariance(pose=good, covariance=cov)), "sd 1e100 m")
    refused(w["PoseStamped"], m.PoseStamped(header=stamp_now(), pose=m.Pose(position=m.Point(x=1e300, y=y0), orientation=quat(psi0))), "x 1e300 m")
    # The bridge's own: an orientation that is not a rotation (a message never filled in).
    refused(w["PoseStamped"], m.PoseStamped(header=stamp_now(), pose=m.Pose(orientation=m.Quaternion(w=0.0))), "zero quaternion")
    # A valid PoseWithCovarianceStamped is taken, with its standard deviations.
    cov[0] = 4e-6
    w["PoseWithCovarianceStamped"].write(m.PoseWithCovarianceStamped(header=stamp_now(-CAMERA_LATENCY_S), pose=m.PoseWithCovariance(pose=m.Pose(position=m.Point(x=x0 + 0.04, y=y0), orientation=quat(psi0)), covariance=cov)))
    time.sleep(0.15)
    assert abs(float(status()["cam_x_m"]) - (x0 + 0.04)) < 1e-4
    # IMU: heading from the orientation, yaw rate from angular_velocity.z.
    imu = m.Imu(header=stamp_now(), orientation=quat(0.3), angular_velocity=m.Vector3(z=0.01))
    w["Imu"].write(imu)
    time.sleep(0.15)
    st = status()
    assert abs(float(st["imu_psi_rad"]) - 0.3) < 1e-4 and abs(float(st["imu_r_radps"]) - 0.01) < 1e-4
    # Its linear_acceleration's x, y reach augerd unless its covariance[0] is -1 (REP 145: absent)
    # or all three are 0 (never filled in: an accelerometer reads gravity), as in the message above.
    assert st["imu_ax_mps2"] == "nan"
    w["Imu"].write(m.Imu(header=stamp_now(), orientation=quat(0.3), angular_velocity=m.Vector3(z=0.01),
                         linear_acceleration=m.Vector3(x=0.25, y=-0.125, z=9.81)))
    time.sleep(0.15)
    st = status()
    assert abs(float(st["imu_ax_mps2"]) - 0.25) < 1e-4 and abs(float(st["imu_ay_mps2"]) + 0.125) < 1e-4
    w["Imu"].write(m.Imu(header=stamp_now(), orientation=quat(0.3), angular_velocity=m.Vector3(z=0.01),
                         linear_acceleration=m.Vector3(x=0.25), linear_acceleration_covariance=[-1.0] + [0.0] * 8))
    time.sleep(0.15)
    assert status()["imu_ax_mps2"] == "nan"
    # A yaw rate of 1e100 rad/s (beyond any gyro's full scale) is refused, and the diagnostics say why.
    refused(w["Imu"], m.Imu(header=stamp_now(), orientation=quat(0.3), angular_velocity=m.Vector3(z=1e100)), "imu rate 1e100")
    assert "r_radps = 1e+100 rad/s is outside -35..35 rad/s" in last_refusal(col)
    # An IMU without an orientation estimate (covariance[0] = -1) is refused: augerd needs it.
    no_orientation = m.Imu(header=stamp_now(), orientation=quat(0.5), orientation_covariance=[-1.0] + [0.0] * 8)
    refused(w["Imu"], no_orientation, "imu without orientation")
    # The diagnostics name the last refusal.
    assert "no orientation" in last_refusal(col)



def test_local_commands_before_network_cmd_vel(dds):
    """docs/ros2.md "Arbitration": a network cmd_vel never overrides a local goto, stop or vel;
    it may drive local_priority_s (1 s here) after the last local motion ended; every change of
    source and every run of refusals is an event in augerd's event log."""
    _, _, w = dds
    priority_s = float(ENV["ROS2_LOCAL_PRIORITY_S"])
    _, col, _ = dds
    turn = m.Twist(angular=m.Vector3(z=0.2))
    network = "motion commands from network cmd_vel (ROS 2)"
    n0 = events().count(network)  # the earlier tests' Twists
    # A local goto runs: the network's Twists are refused, counted and logged once.
    command("enable", "goto 0.3 0 0")
    before = int(status()["ros2_refused"])
    send(w["Twist"], turn, 20, 0.5)
    st = status()
    assert st["mode"] == "goto" and int(st["ros2_refused"]) >= before + 5, st
    ev = events("event=network-refused")
    assert ev.count("event=network-refused") == 1, ev
    assert 'event=network-refused action="cmd_vel (ROS 2) not obeyed: a goto is running (local goto by pid' in ev
    # A local stop: nothing moves until a local enable; then the network may drive (the enable
    # is the operator's go-ahead), and the change of source is an event.
    command("stop")
    send(w["Twist"], turn, 20, 0.3)
    assert status()["mode"] == "stopped"
    command("enable")
    send(w["Twist"], turn, 20, 0.3)
    assert status()["mode"] == "vel"
    assert logged('event=source action="motion commands from network cmd_vel (ROS 2) (was local stop by pid')
    # A local vel takes over at once; the network waits for its 0.5 s dead-man plus priority_s.
    t_local = time.time()
    command("vel 0 0 -0.1")
    assert logged('event=source action="motion commands from local vel by pid')
    before = int(status()["ros2_refused"])
    send(w["Twist"], turn, 20, 0.5 + priority_s - 0.3)
    st = status()
    assert st["mode"] == "idle" and int(st["ros2_refused"]) >= before + 10, st  # expired, not taken over
    assert logged("a vel is running (local vel by pid")  # the run of refusals' event
    assert "ended" in last_refusal(col) and "network cmd_vel may drive 1.00 s after it" in last_refusal(col)
    time.sleep(max(0.0, t_local + 0.5 + priority_s + 0.2 - time.time()))
    send(w["Twist"], turn, 20, 0.3)
    assert status()["mode"] == "vel"
    assert events().count(network) == n0 + 2
    command("stop")


def test_online_estimator_visible(dds):
    """docs/ros2.md "Online estimate": with [online] enabled, /diagnostics carries the online
    estimator's state (OK, the believed terrain, the estimate with SDs and units, the detector)
    and online_estimate (std_msgs/Float64MultiArray, 10 Hz) the five parameters' values and SDs
    in its documented layout; both say what augerd's `status all` says, at rest (the estimate
    then does not move: standing still informs nothing)."""
    _, col, _ = dds
    command("stop")
    time.sleep(1.5)
    t = time.time()
    while True:
        d = col.latest("DiagnosticArray")
        if stamp_s(d.header) > t:
            break
    n0 = len(col.got["Float64MultiArray"])
    time.sleep(2.0)
    arrays = col.got["Float64MultiArray"][n0:]
    st = status()
    e = d.status[5]
    assert e.name == "augerd: online estimator" and e.hardware_id == "augerd"
    assert e.level == 0 and st["on_fallback"] == "0", (e.level, e.message)
    kv = {x.key: x.value for x in e.values}
    assert e.message == "ground believed: " + kv["believed_terrain"]
    assert kv["believed_terrain"].split(",")[0] == st["online_terrain"], (kv, st["online_terrain"])
    assert kv["believed_by"] == "sigma, D"  # the drag estimated too (drag_prior_rel_sd default)
    assert kv["fallback"] == "none" and int(kv["changes"]) == int(st["on_changes"])
    names = ["sigma_long", "sigma_lat", "D_x", "D_y", "D_psi"]
    units = ["N/rpm", "N/rpm", "N/(m/s)", "N/(m/s)", "N m/(rad/s)"]
    for k, u in zip(names, units):
        value, unit = kv[k].split(" ", 1)
        sd, sd_unit = kv[k + "_sd"].split(" ", 1)
        assert unit == sd_unit == u, (k, kv[k], kv[k + "_sd"])
        assert math.isclose(float(value), float(st["on_" + k]), rel_tol=2e-3), (k, value, st["on_" + k])
        assert math.isclose(float(sd), float(st["on_sd_" + k]), rel_tol=0.06), (k, sd, st["on_sd_" + k])

    # The topic: about 10 Hz, 5 x (value, SD) row-major, as the layout says.
    assert 15 <= len(arrays) <= 25, len(arrays)
    a = arrays[-1][1]
    dims = [(x.label, x.size, x.stride) for x in a.layout.dim]
    assert dims == [("parameter", 5, 10), ("value_sd", 2, 2)] and a.layout.data_offset == 0, dims
    assert len(a.data) == 10
    for i, k in enumerate(names):
        assert math.isclose(a.data[2 * i], float(st["on_" + k]), rel_tol=1e-3), (k, a.data[2 * i], st["on_" + k])
        assert math.isclose(a.data[2 * i + 1], float(st["on_sd_" + k]), rel_tol=0.06), (k, a.data[2 * i + 1])
        assert a.data[2 * i + 1] > 0
