"""Robot logs (docs/log-format.md) into ROS 2 bags as the research group records them, with
rosbags' own writer: the tests' way to make real bags from simulated drives.

Topics and types of model_identification_record.launch.py (Centre-for-Biorobotics/
rm3_ros_packages): one robominer_msgs/MotorModuleFeedback topic per screw position, the
MotorModuleCommand setpoints on /motorN/motor_rpm_setpoint, the pose as PoseStamped on
/robot_pose, the BNO080 as sensor_msgs/Imu, plus topics the import must skip.
"""

from __future__ import annotations

import csv
import math
import sqlite3
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer

from auger_interop.robominer import typestore_with_group_types

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


def log_to_bag(log_path, bag_path, storage="sqlite3", t0_ns=1_767_225_600_123_000_000,
               feedback_every=1, motor_ids=("0", "1", "2", "3")):
    """Writes the log's rows as messages stamped t0_ns + t_s (receive time and header alike).
    feedback_every: write the motor feedback only every n-th row (the group's modules: 5 Hz)."""
    store = typestore_with_group_types()
    T = store.types
    _, c = read_log(log_path)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    n = len(c["t_s"])

    def stamp(ns):
        return T["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def header(ns, frame):
        return T["std_msgs/msg/Header"](stamp=stamp(ns), frame_id=frame)

    def val(name, k, default=0.0):
        v = c.get(name, np.full(n, np.nan))[k]
        return default if math.isnan(v) else float(v)

    with Writer(bag_path, version=9, storage_plugin=plugin) as w:
        fb = [w.add_connection("/%s/motor_module" % p, "robominer_msgs/msg/MotorModuleFeedback", typestore=store)
              for p in POSITIONS]
        cmd = [w.add_connection("/motor%d/motor_rpm_setpoint" % i, "robominer_msgs/msg/MotorModuleCommand",
                                typestore=store) for i in range(4)]
        pose = w.add_connection("/robot_pose", "geometry_msgs/msg/PoseStamped", typestore=store)
        imu = w.add_connection("/bno080_imu", "sensor_msgs/msg/Imu", typestore=store)
        kb = w.add_connection("/cmd_vel_keyboard", "geometry_msgs/msg/Twist", typestore=store)
        V3, Q = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
        for k in range(n):
            ns = t0_ns + int(round(c["t_s"][k] * 1e9))
            for i in range(4):
                if k % feedback_every == 0:
                    m = T["robominer_msgs/msg/MotorModuleFeedback"](
                        header=header(ns, POSITIONS[i]), motor_id=motor_ids[i],
                        motor_rpm=val("omega_rpm_%d" % i, k), motor_current_ma=val("current_a_%d" % i, k) * 1000,
                        motor_voltage_v=val("voltage_v_%d" % i, k))
                    w.write(fb[i], ns, store.serialize_cdr(m, m.__msgtype__))
                if "cmd_rpm_%d" % i in c and k % 10 == 0:
                    m = T["robominer_msgs/msg/MotorModuleCommand"](
                        header=header(ns, POSITIONS[i]), motor_id=str(i),
                        motor_rpm_goal=int(max(-128, min(127, round(val("cmd_rpm_%d" % i, k))))))
                    w.write(cmd[i], ns, store.serialize_cdr(m, m.__msgtype__))
            if not math.isnan(c["x_m"][k]):
                m = T["geometry_msgs/msg/PoseStamped"](
                    header=header(ns, "world"),
                    pose=T["geometry_msgs/msg/Pose"](
                        position=T["geometry_msgs/msg/Point"](x=c["x_m"][k], y=c["y_m"][k], z=0.0),
                        orientation=Q(*quat(c["psi_rad"][k]))))
                w.write(pose, ns, store.serialize_cdr(m, m.__msgtype__))
            if "imu_psi_rad" in c and not math.isnan(c["imu_psi_rad"][k]):
                m = T["sensor_msgs/msg/Imu"](
                    header=header(ns, "bno_imu_frame"), orientation=Q(*quat(c["imu_psi_rad"][k])),
                    orientation_covariance=np.zeros(9), angular_velocity=V3(x=0.0, y=0.0, z=val("imu_r_radps", k)),
                    angular_velocity_covariance=np.zeros(9), linear_acceleration=V3(x=0.0, y=0.0, z=9.81),
                    linear_acceleration_covariance=np.zeros(9))
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
