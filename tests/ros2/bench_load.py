"""Load on augerd's ROS 2 inputs and outputs for scripts/bench-ros2.sh: bench_load.py DOMAIN
SECONDS publishes a Twist at 1 kHz and a PoseStamped and an Imu at 500 Hz each (ten to fifty
times what a teleop, a camera or an IMU sends) in the namespace-less default topics, while
reading Odometry, JointState and the diagnostics; prints what it sent and received."""
import sys
import time

from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

import ros2_msgs as m

RELIABLE = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.Durability.Volatile,
               Policy.History.KeepLast(10))
BEST_EFFORT = Qos(Policy.Reliability.BestEffort, Policy.Durability.Volatile, Policy.History.KeepLast(5))


def main():
    domain, seconds = int(sys.argv[1]), float(sys.argv[2])
    dp = DomainParticipant(domain)
    tw = DataWriter(dp, Topic(dp, "rt/cmd_vel", m.Twist), qos=RELIABLE)
    pw = DataWriter(dp, Topic(dp, "rt/camera/pose", m.PoseStamped), qos=BEST_EFFORT)
    iw = DataWriter(dp, Topic(dp, "rt/imu", m.Imu), qos=BEST_EFFORT)
    readers = {name: DataReader(dp, Topic(dp, topic, cls), qos=RELIABLE)
               for name, topic, cls in (("Odometry", "rt/odom", m.Odometry), ("JointState", "rt/joint_states", m.JointState),
                                        ("DiagnosticArray", "rt/diagnostics", m.DiagnosticArray))}
    got = {k: 0 for k in readers}
    sent = 0
    start = time.time()
    k = 0
    while time.time() - start < seconds:
        now = time.time() - 0.03
        hdr = m.Header(stamp=m.Time(sec=int(now), nanosec=int((now - int(now)) * 1e9)))
        tw.write(m.Twist())
        sent += 1
        if k % 2 == 0:
            pw.write(m.PoseStamped(header=hdr))
            iw.write(m.Imu(header=hdr))
            sent += 2
        if k % 20 == 0:
            for name, r in readers.items():
                got[name] += len(r.take(N=1000))
        k += 1
        time.sleep(0.001)
    elapsed = time.time() - start
    print(f"bench_load: sent {sent} messages in {elapsed:.1f} s ({sent / elapsed:.0f} per s); received "
          + ", ".join(f"{n} {v / elapsed:.1f} Hz" for n, v in got.items()))


if __name__ == "__main__":
    main()
