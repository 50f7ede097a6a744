"""The research group's own message types (robominer_msgs), every version their bags may hold.

Bags recorded with ROS 2 Foxy, Galactic or Humble in sqlite3 storage carry only type names, no
definitions, so the reader needs these. The field lists are those of
Centre-for-Biorobotics/rm3_ros_packages, robominer_msgs/msg/MotorModuleFeedback.msg and
MotorModuleCommand.msg, through their history; which one a bag holds is decided by which its
bytes fit (bagtypes.py). Newest first: that is the one tests write and, when two fit equally,
the one taken.
"""

from rosbags.typesys import Stores, get_types_from_msg, get_typestore

FEEDBACK = "robominer_msgs/msg/MotorModuleFeedback"
COMMAND = "robominer_msgs/msg/MotorModuleCommand"

# (label for messages, .msg text)
VERSIONS = {
    FEEDBACK: [
        ("with motor_voltage_v (since June 2021)",
         "std_msgs/Header header\nstring motor_id\nfloat32 motor_rpm\nfloat32 motor_current_ma\n"
         "float32 motor_voltage_v\n"),
        ("without motor_voltage_v (April-June 2021)",
         "std_msgs/Header header\nstring motor_id\nfloat32 motor_rpm\nfloat32 motor_current_ma\n"),
        ("without header (before April 2021)",
         "string motor_id\nfloat32 motor_rpm\nfloat32 motor_current_ma\n"),
    ],
    COMMAND: [
        ("int8 motor_rpm_goal", "std_msgs/Header header\nstring motor_id\nint8 motor_rpm_goal\n"),
        ("int32 motor_rpm_goal (January-February 2023)",
         "std_msgs/Header header\nstring motor_id\nint32 motor_rpm_goal\n"),
        ("int8 motor_rpm_goal without header (March-April 2021)", "string motor_id\nint8 motor_rpm_goal\n"),
        ("float32 motor_rpm_goal without header (before March 2021)", "string motor_id\nfloat32 motor_rpm_goal\n"),
    ],
}


def typestore_with_group_types(version: dict[str, int] | None = None):
    """A typestore with ROS 2 Humble's standard types and robominer_msgs, each in its current
    version or the one `version` names by index into VERSIONS (the tests write bags with it)."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    for name, versions in VERSIONS.items():
        store.register(get_types_from_msg(versions[(version or {}).get(name, 0)][1], name))
    return store
