"""ROS 2's name rules and their DDS mapping, as published in the design article "Topic and
Service name mapping to DDS" (design.ros2.org): written here from that text, independently of
augerd's own name rules (fully_qualified_name and dds_topic_name, auger/ros2_settings.hpp), to
check what augerd announces on the wire.

- A ROS topic `/a/b` is the DDS topic `rt/a/b` (services: rq/.../...Request, rr/...Reply).
- A message type `pkg/msg/Type` is the DDS type `pkg::msg::dds_::Type_`.
- Names: not empty; only alphanumerics, '_' and '/' (plus '~' and '{}' substitutions, which a
  fully qualified name no longer has); no token starting with a digit; no trailing '/'; no
  repeated '/' or '_'; a relative name is put under the node's namespace."""
import re

_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


def is_valid_fully_qualified(name):
    if not name.startswith("/") or name == "/" or name.endswith("/"):
        return False
    if "//" in name or "__" in name:
        return False
    return all(_TOKEN.match(t) for t in name[1:].split("/"))


def fully_qualified(name, namespace=""):
    if name.startswith("/"):
        full = name
    else:
        ns = namespace.rstrip("/")
        if ns and not ns.startswith("/"):
            ns = "/" + ns
        full = ns + "/" + name
    if not is_valid_fully_qualified(full):
        raise ValueError(f"not a valid ROS 2 topic name: {name!r} in namespace {namespace!r}")
    return full


def dds_topic_name(name, namespace=""):
    return "rt" + fully_qualified(name, namespace)


def dds_type_name(ros_type):
    pkg, kind, typ = ros_type.split("/")
    return f"{pkg}::{kind}::dds_::{typ}_"
