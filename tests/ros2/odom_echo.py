"""A DDS subscriber to augerd's Odometry, as a ROS 2 node would see it (`make demo`):
odom_echo.py DOMAIN TOPIC SECONDS [EVERY_S]. Prints the pose, the velocity and their standard
deviations every EVERY_S seconds (default 4), then the count and the rate received. Uses the
test's message types (ros2_msgs.py, written from ROS 2's .msg files); CYCLONEDDS_URI picks the
network (the demo: loopback)."""
import math
import sys
import time

from cyclonedds.domain import DomainParticipant
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader, InvalidSample
from cyclonedds.topic import Topic
from cyclonedds.util import duration

import ros2_msgs as m


def main():
    domain, topic, seconds = int(sys.argv[1]), sys.argv[2], float(sys.argv[3])
    every = float(sys.argv[4]) if len(sys.argv) > 4 else 4.0
    dp = DomainParticipant(domain)
    qos = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.Durability.Volatile,
              Policy.History.KeepLast(10))
    reader = DataReader(dp, Topic(dp, topic, m.Odometry), qos=qos)
    start = time.time()
    end, next_print, n, first, last = start + seconds, start, 0, None, None
    while time.time() < end:
        for o in reader.take(N=100):
            if isinstance(o, InvalidSample):  # augerd's writer gone (it stopped): no data in it
                continue
            n += 1
            t = o.header.stamp.sec + 1e-9 * o.header.stamp.nanosec
            first = first if first is not None else t
            last = t
            if time.time() >= next_print:
                q, p, c = o.pose.pose.orientation, o.pose.pose.position, o.pose.covariance
                yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
                print(f"ros2 subscriber: {topic} {o.header.frame_id} -> {o.child_frame_id}: "
                      f"x {p.x:+.3f} m, y {p.y:+.3f} m, yaw {yaw:+.3f} rad "
                      f"(sd {math.sqrt(c[0]) * 1000:.1f} mm, {math.sqrt(c[7]) * 1000:.1f} mm, {math.sqrt(c[35]):.3f} rad); "
                      f"u {o.twist.twist.linear.x:+.3f} m/s, v {o.twist.twist.linear.y:+.3f} m/s", flush=True)
                next_print += every
        time.sleep(0.01)
    rate = (n - 1) / (last - first) if n > 1 and last > first else 0.0
    print(f"ros2 subscriber: {n} Odometry messages on {topic} in {seconds:.0f} s ({rate:.1f} Hz)", flush=True)
    return 0 if n > 0 else 1


if __name__ == "__main__":
    sys.exit(main())
