"""Robot logs (docs/log-format.md) into ROS 2 bags as the research group records them, with
rosbags' own writer: the tests' way to make real bags from simulated drives.

Topics and types of model_identification_record.launch.py (Centre-for-Biorobotics/
rm3_ros_packages): one robominer_msgs/MotorModuleFeedback topic per screw position, the
MotorModuleCommand setpoints on /motorN/motor_rpm_setpoint, the pose as PoseStamped on
/robot_pose, the BNO080 as sensor_msgs/Imu, plus topics the import must skip; and the ways real
bags differ from that (older message versions, rates, an IMU without orientation, a clock that
steps, no pose).
"""

from __future__ import annotations

import csv
import math
import sqlite3
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer

from auger_interop.robominer import COMMAND, FEEDBACK, typestore_with_group_types

POSITIONS = ("front_right", "rear_right", "rear_left", "front_left")


def read_log(path):
    """(metadata, {column: float array with NaN for empty}) of a robot log."""
    meta, header, rows = {}, None, []
    with open(path, newline="") as f:
        for row in csv.reader(f):
            if row and row[0].startswith("#"):
                k, _, v = ",".join(row)[1:].partition(":")
                meta[k.strip()] = v.strip()
            elif header is None:
                header = row
            else:
                rows.append([float(x) if x.strip() else math.nan for x in row])
    a = np.array(rows)
    return meta, {h: a[:, i] for i, h in enumerate(header)}


def quat(yaw):
    return 0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)


POSE_TYPES = ("geometry_msgs/msg/PoseStamped", "geometry_msgs/msg/PoseWithCovarianceStamped", "nav_msgs/msg/Odometry")


def log_to_bag(log_path, bag_path, storage="sqlite3", t0_ns=1_767_225_600_123_000_000,
               feedback_every=1, motor_ids=("0", "1", "2", "3"), feedback_phase=0, versions=None, imu_every=1,
               imu_orientation="fused", imu_acceleration="measured", pose_type=POSE_TYPES[0], clock=None):
    """Writes the log's rows as messages stamped t0_ns + t_s (receive time and header alike), in
    row order (the recording order).
    feedback_every: the motor feedback only every n-th row (the group's modules: 5 Hz), screw i's
      at rows with (k + i * feedback_phase) % feedback_every == 0;
    versions: {type: index into robominer.VERSIONS} to write an older robominer_msgs (its
      definition is the one the bag embeds);
    imu_every: the IMU every n-th row; imu_orientation: "fused" (the BNO080's), "none"
      (orientation_covariance[0] = -1, quaternion zero: sensor_msgs/Imu's "no orientation"),
      "zero" (quaternion 0, 0, 0, 0 without saying so); imu_acceleration: "measured" (the log's
      imu_ax_mps2, imu_ay_mps2, gravity in z), "none" (linear_acceleration_covariance[0] = -1),
      "zero" (0, 0, 0: a driver that never fills it in);
    pose_type: the type on /robot_pose (None: no pose topic);
    clock: stamp of row time t_ns (ns since t0) -> the recorder's stamp (a clock step)."""
    store = typestore_with_group_types(versions)
    T = store.types
    _, c = read_log(log_path)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    n = len(c["t_s"])
    fb_fields = {f for f, _ in store.fielddefs[FEEDBACK][1]}
    cmd_fields = dict(store.fielddefs[COMMAND][1])

    def stamp(ns):
        return T["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def header(ns, frame):
        return T["std_msgs/msg/Header"](stamp=stamp(ns), frame_id=frame)

    def val(name, k, default=0.0):
        v = c.get(name, np.full(n, np.nan))[k]
        return default if math.isnan(v) else float(v)

    def with_header(fields, ns, frame, **kw):
        return dict(kw, header=header(ns, frame)) if "header" in fields else kw

    with Writer(bag_path, version=9, storage_plugin=plugin) as w:
        fb = [w.add_connection("/%s/motor_module" % p, FEEDBACK, typestore=store) for p in POSITIONS]
        cmd = [w.add_connection("/motor%d/motor_rpm_setpoint" % i, COMMAND, typestore=store) for i in range(4)]
        pose = w.add_connection("/robot_pose", pose_type, typestore=store) if pose_type else None
        imu = w.add_connection("/bno080_imu", "sensor_msgs/msg/Imu", typestore=store)
        kb = w.add_connection("/cmd_vel_keyboard", "geometry_msgs/msg/Twist", typestore=store)
        V3, Q = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
        cmd_int = cmd_fields["motor_rpm_goal"][1][0] != "float32"
        for k in range(n):
            rel = int(round(c["t_s"][k] * 1e9))
            ns = t0_ns + (clock(rel) if clock else rel)
            for i in range(4):
                if (k + i * feedback_phase) % feedback_every == 0:
                    kw = dict(motor_id=motor_ids[i], motor_rpm=val("omega_rpm_%d" % i, k),
                              motor_current_ma=val("current_a_%d" % i, k) * 1000)
                    if "motor_voltage_v" in fb_fields:
                        kw["motor_voltage_v"] = val("voltage_v_%d" % i, k)
                    m = T[FEEDBACK](**with_header(fb_fields, ns, POSITIONS[i], **kw))
                    w.write(fb[i], ns, store.serialize_cdr(m, FEEDBACK))
                if "cmd_rpm_%d" % i in c and k % 10 == 0:
                    goal = val("cmd_rpm_%d" % i, k)
                    goal = int(max(-128, min(127, round(goal)))) if cmd_int else goal
                    m = T[COMMAND](**with_header(cmd_fields, ns, POSITIONS[i], motor_id=str(i), motor_rpm_goal=goal))
                    w.write(cmd[i], ns, store.serialize_cdr(m, COMMAND))
            if pose is not None and not math.isnan(c["x_m"][k]):
                p = T["geometry_msgs/msg/Pose"](
                    position=T["geometry_msgs/msg/Point"](x=c["x_m"][k], y=c["y_m"][k], z=0.0),
                    orientation=Q(*quat(c["psi_rad"][k])))
                if pose_type == POSE_TYPES[0]:
                    m = T[pose_type](header=header(ns, "world"), pose=p)
                else:
                    pc = T["geometry_msgs/msg/PoseWithCovariance"](pose=p, covariance=np.zeros(36))
                    if pose_type == POSE_TYPES[1]:
                        m = T[pose_type](header=header(ns, "world"), pose=pc)
                    else:
                        tw = T["geometry_msgs/msg/TwistWithCovariance"](
                            twist=T["geometry_msgs/msg/Twist"](linear=V3(x=0.0, y=0.0, z=0.0),
                                                               angular=V3(x=0.0, y=0.0, z=0.0)),
                            covariance=np.zeros(36))
                        m = T[pose_type](header=header(ns, "world"), child_frame_id="base_link", pose=pc, twist=tw)
                w.write(pose, ns, store.serialize_cdr(m, pose_type))
            if "imu_psi_rad" in c and not math.isnan(c["imu_psi_rad"][k]) and k % imu_every == 0:
                cov = np.zeros(9)
                q = Q(*quat(c["imu_psi_rad"][k]))
                if imu_orientation != "fused":
                    q = Q(x=0.0, y=0.0, z=0.0, w=0.0)
                    cov[0] = -1.0 if imu_orientation == "none" else 0.0
                acc, acc_cov = V3(x=val("imu_ax_mps2", k), y=val("imu_ay_mps2", k), z=9.81), np.zeros(9)
                if imu_acceleration != "measured":
                    acc = V3(x=0.0, y=0.0, z=0.0)
                    acc_cov[0] = -1.0 if imu_acceleration == "none" else 0.0
                m = T["sensor_msgs/msg/Imu"](
                    header=header(ns, "bno_imu_frame"), orientation=q,
                    orientation_covariance=cov, angular_velocity=V3(x=0.0, y=0.0, z=val("imu_r_radps", k)),
                    angular_velocity_covariance=np.zeros(9), linear_acceleration=acc,
                    linear_acceleration_covariance=acc_cov)
                w.write(imu, ns, store.serialize_cdr(m, m.__msgtype__))
            if k % 10 == 0:
                m = T["geometry_msgs/msg/Twist"](linear=V3(x=0.05, y=0.0, z=0.0), angular=V3(x=0.0, y=0.0, z=0.0))
                w.write(kb, ns, store.serialize_cdr(m, m.__msgtype__))
    return Path(bag_path)


def strip_definitions(bag_path, types=None):
    """Deletes message definitions from a sqlite3 bag (all, or those of `types`), as ROS 2
    Humble's recorder wrote none: the import must then know the types itself."""
    db = next(Path(bag_path).glob("*.db3"))
    con = sqlite3.connect(db)
    if types is None:
        con.execute("DELETE FROM message_definitions")
    else:
        con.executemany("DELETE FROM message_definitions WHERE topic_type = ?", [(t,) for t in types])
    con.commit()
    con.close()
