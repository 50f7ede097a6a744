"""The research group's own message types (robominer_msgs), registered from their .msg text.

Bags recorded with ROS 2 Humble's sqlite3 storage carry only type names, no definitions, so
the reader needs these. The text is the field list of Centre-for-Biorobotics/rm3_ros_packages,
robominer_msgs/msg/MotorModuleFeedback.msg (motor_voltage_v since June 2021) and
MotorModuleCommand.msg. A bag that embeds its own definitions (MCAP, Iron and later) is decoded
with those instead (bag.py).
"""

from rosbags.typesys import Stores, get_types_from_msg, get_typestore

MOTOR_MODULE_FEEDBACK = """\
std_msgs/Header header
string motor_id
float32 motor_rpm
float32 motor_current_ma
float32 motor_voltage_v
"""

MOTOR_MODULE_COMMAND = """\
std_msgs/Header header
string motor_id
int8 motor_rpm_goal
"""

TYPES = {
    "robominer_msgs/msg/MotorModuleFeedback": MOTOR_MODULE_FEEDBACK,
    "robominer_msgs/msg/MotorModuleCommand": MOTOR_MODULE_COMMAND,
}


def default_fielddefs():
    """ROS 2 Humble's standard types and robominer_msgs, as rosbags' parse trees."""
    defs = dict(get_typestore(Stores.ROS2_HUMBLE).fielddefs)
    for name, text in TYPES.items():
        defs.update(get_types_from_msg(text, name))
    return defs


def typestore_with_group_types():
    """A typestore with the standard types and robominer_msgs (for writing bags in tests)."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    for name, text in TYPES.items():
        store.register(get_types_from_msg(text, name))
    return store
