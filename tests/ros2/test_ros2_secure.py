"""Who may command the robot over DDS (docs/ros2.md, issue 28): augerd with the keystore that
ros2_sim.sh made with `auger ros2-keys` (augerd's enclave, an operator's, a read-only viewer's,
and a second keystore whose CA augerd does not trust). A participant without DDS Security (the
Python binding, which has no security plugins) and one with a certificate of the other CA
(ros2_secure_peer, on Debian's Cyclone DDS and its plugins) send cmd_vel and camera poses: both
ignored, neither sees augerd's odometry. The viewer may read the odometry, and its own access
control refuses it a cmd_vel writer. The operator is obeyed: its Twist drives the robot, its
pose is fused, and augerd's odometry crosses the wire encrypted. In this order, against one
augerd."""
import os
import socket
import subprocess
import threading
import time

import pytest

from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

import ros2_msgs as m
from augerd_cmd import command, status
from ros2_names import dds_topic_name

ENV = os.environ
NS = ENV["ROS2_NS"]
CMD_VEL, POSE, ODOM = (dds_topic_name(ENV[k], NS) for k in ("ROS2_CMD_VEL", "ROS2_POSE", "ROS2_ODOM"))
KEYS, ROGUE = ENV["ROS2_KEYSTORE"], ENV["ROS2_ROGUE"]
DEFAULT = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(10),
              Policy.DataRepresentation(use_cdrv0_representation=True))


def peer(enclave, *args):
    """ros2_secure_peer with that enclave ("none": no security); its one line of output."""
    r = subprocess.run([ENV["ROS2_PEER"], ENV["ROS2_DOMAIN"], enclave, ENV["ROS2_DDS_CONFIG"], *map(str, args)],
                       capture_output=True, text=True, timeout=30)
    assert r.returncode == 0, r.stderr
    return r.stdout.strip()


def unmoved(before, after):
    return (after["mode"] == "idle" and after["ros2_applied"] == before["ros2_applied"]
            and after["cam_x_m"] == before["cam_x_m"] and after["x_m"] == before["x_m"])


def stamp_now(offset_s=-0.03):
    t = time.time() + offset_s
    return m.Header(stamp=m.Time(sec=int(t), nanosec=int((t - int(t)) * 1e9)), frame_id="world")


def test_unauthenticated_participant_is_ignored():
    command("enable")
    before = status()
    assert before["cam_x_m"] == "nan"  # no pose yet in this run
    dp = DomainParticipant(int(ENV["ROS2_DOMAIN"]))
    twist = DataWriter(dp, Topic(dp, CMD_VEL, m.Twist), qos=DEFAULT)
    pose = DataWriter(dp, Topic(dp, POSE, m.PoseStamped), qos=DEFAULT)
    odom = DataReader(dp, Topic(dp, ODOM, m.Odometry), qos=DEFAULT)
    got = 0
    end = time.time() + 1.5
    while time.time() < end:
        twist.write(m.Twist(linear=m.Vector3(x=0.05)))
        pose.write(m.PoseStamped(header=stamp_now(), pose=m.Pose(position=m.Point(x=5.0))))
        got += len(odom.take(N=100))
        time.sleep(0.05)
    assert twist.get_matched_subscriptions() == [] and pose.get_matched_subscriptions() == []
    assert got == 0, "augerd's odometry reached a participant without a certificate"
    after = status()
    assert unmoved(before, after), (before, after)


def test_participant_of_another_ca_is_ignored():
    before = status()
    enclave = f"{ROGUE}/enclaves/operator"
    assert peer(enclave, "twist", CMD_VEL, 0.05, 0, 0, 1.5) == "matched 0"
    assert peer(enclave, "pose", POSE, 5.0, 0, 0, 1.0) == "matched 0"
    assert peer(enclave, "odom", ODOM, 1.0) == "received 0"
    assert unmoved(before, status())


def test_read_only_peer_reads_and_cannot_command():
    before = status()
    enclave = f"{KEYS}/enclaves/viewer"
    assert int(peer(enclave, "odom", ODOM, 1.5).split()[1]) > 20  # 50 Hz once matched
    assert peer(enclave, "twist", CMD_VEL, 0.05, 0, 0, 0.5) == "refused Not Allowed By Security"
    assert unmoved(before, status())


def test_authorized_operator_is_obeyed():
    before = status()
    enclave = f"{KEYS}/enclaves/operator"
    assert int(peer(enclave, "odom", ODOM, 1.5).split()[1]) > 20
    # Its camera pose is fused (status shows it as the camera's) ...
    assert peer(enclave, "pose", POSE, 0.02, 0, 0, 1.0) == "matched 1"
    assert abs(float(status()["cam_x_m"]) - 0.02) < 1e-9
    # ... and its Twist drives the robot: 0.05 m/s for 2 s.
    assert peer(enclave, "twist", CMD_VEL, 0.05, 0, 0, 2.0) == "matched 1"
    after = status()
    assert int(after["ros2_applied"]) > int(before["ros2_applied"]) + 30, (before, after)
    assert float(after["x_m"]) > float(before["x_m"]) + 0.04, (before, after)
    command("stop")


def test_odometry_encrypted_on_the_wire():
    """The governance encrypts topic data: while the operator reads augerd's odometry, no RTPS
    packet on loopback carries its frame id "base_link" in clear (without DDS Security about half
    of them do). Capturing needs a raw socket (root); skipped without."""
    try:
        sniffer = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.ntohs(3))
    except PermissionError:
        pytest.skip("capturing loopback needs root (a raw socket)")
    sniffer.bind(("lo", 0))
    sniffer.settimeout(0.2)
    counts = {"rtps": 0, "clear": 0}

    def capture(seconds):
        end = time.time() + seconds
        while time.time() < end:
            try:
                p = sniffer.recv(65535)
            except socket.timeout:
                continue
            counts["rtps"] += b"RTPS" in p
            counts["clear"] += b"base_link" in p

    t = threading.Thread(target=capture, args=(1.5,))
    t.start()
    received = int(peer(f"{KEYS}/enclaves/operator", "odom", ODOM, 2.0).split()[1])
    t.join()
    print(f"\non the wire: {counts['rtps']} RTPS packets, {counts['clear']} with 'base_link' in clear; "
          f"the operator took {received} Odometry samples")
    assert received > 20 and counts["rtps"] > 50 and counts["clear"] == 0, (received, counts)
