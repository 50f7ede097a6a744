"""ROS 2 bags (rosbag2: a folder with metadata.yaml, or one .db3 / .mcap file) into time series.

Read with the `rosbags` library (pure Python, no ROS). Types: the definitions the bag embeds
win; what it lacks comes from ROS 2 Humble's standard set and robominer_msgs (robominer.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from rosbags.interfaces import MessageDefinitionFormat, Nodetype
from rosbags.rosbag2 import Reader, ReaderError
from rosbags.typesys import get_types_from_idl, get_types_from_msg, get_typestore, Stores
from rosbags.typesys.base import TypesysError

from . import InputError
from .mapping import ColumnSpec, Map
from .robominer import default_fielddefs

QUATERNION = "geometry_msgs/msg/Quaternion"
SCREW_NAMES = ("front-right", "rear-right", "rear-left", "front-left")  # docs/model.md
NUMERIC = {"bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64",
           "uint64", "float32", "float64"}


@dataclass
class Series:
    """One log column's samples: times in ns (the map's clock) and values."""
    spec: ColumnSpec
    t_ns: np.ndarray
    values: np.ndarray


def yaw_of(x: float, y: float, z: float, w: float) -> float:
    """Heading psi of a unit quaternion (rotation about z after the ZYX convention), rad."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _typestore(path, connections):
    defs = {}
    for c in connections:
        try:
            if c.msgdef.format == MessageDefinitionFormat.MSG:
                defs.update(get_types_from_msg(c.msgdef.data, c.msgtype))
            elif c.msgdef.format == MessageDefinitionFormat.IDL:
                # one IDL, or several each after a line of 80 '=' and "IDL: name"
                sep = "=" * 80 + "\n"
                parts = c.msgdef.data.split(sep)[1:] if c.msgdef.data.startswith(sep) else [c.msgdef.data]
                for part in parts:
                    defs.update(get_types_from_idl(part.split("\n", 1)[1] if part.startswith("IDL: ") else part))
        except (TypesysError, IndexError) as e:
            raise InputError("%s: topic %s: its type %s has a definition the reader cannot parse: %s"
                             % (path, c.topic, c.msgtype, e)) from None
    merged = default_fielddefs()
    merged.update(defs)  # the bag's own definitions win
    store = get_typestore(Stores.EMPTY)
    store.register(merged)
    return store


class _Accessor:
    """A field path resolved against a message type once: how to get the value, and its kind."""

    def __init__(self, path, store, msgtype, spec: ColumnSpec, topic):
        self.steps = []
        typ = msgtype
        kind = None
        where = "%s: column %s: %s (%s)" % (path, spec.name, topic, msgtype)
        for part in spec.field.split("."):
            index = None
            if part.endswith("]") and "[" in part:
                part, idx = part[:-1].split("[", 1)
                if not idx.isdigit():
                    raise InputError("%s: field '%s': '[%s]' is not an index" % (where, spec.field, idx))
                index = int(idx)
            if typ is None:
                raise InputError("%s: field '%s': '%s' is not a message, it has no fields" % (where, spec.field, part))
            fields = dict(store.fielddefs[typ][1])
            if part not in fields:
                raise InputError("%s has no field '%s' (in '%s'; it has: %s)"
                                 % (where, part, spec.field, ", ".join(fields)))
            node, arg = fields[part]
            if index is not None:
                if node not in (Nodetype.ARRAY, Nodetype.SEQUENCE):
                    raise InputError("%s: field '%s': %s is not an array" % (where, spec.field, part))
                node, arg = arg[0]
            elif node in (Nodetype.ARRAY, Nodetype.SEQUENCE):
                raise InputError("%s: field '%s': %s is an array; name an element, e.g. %s[0]"
                                 % (where, spec.field, part, part))
            self.steps.append((part, index))
            if node == Nodetype.NAME:
                typ, kind = arg, "message"
            else:
                typ, kind = None, arg[0]
        if kind == "message" and typ == QUATERNION:
            self.kind = "quaternion"
        elif kind in NUMERIC:
            self.kind = kind
        elif kind == "string":
            self.kind = "string"
        else:
            raise InputError("%s: field '%s' is a %s, not a number or a quaternion"
                             % (where, spec.field, typ or kind))

    def get(self, msg):
        v = msg
        for name, index in self.steps:
            v = getattr(v, name)
            if index is not None:
                v = v[index]
        if self.kind == "quaternion":
            return yaw_of(v.x, v.y, v.z, v.w)
        if self.kind == "string":
            return float(v)  # a number sent as text (ValueError is reported by the caller)
        if self.kind == "float32":
            # the float32's shortest decimal (10.7, not 10.699999809265137): what was meant
            return float(str(np.float32(v)))
        return float(v)


def _match_value(msg, field):
    v = msg
    for part in field.split("."):
        v = getattr(v, part)
    return str(v)


def list_topics(path: str) -> list[tuple[str, str, int]]:
    """(topic, type, message count) of every topic in the bag."""
    with _open(path) as reader:
        return sorted((name, info.msgtype or "(several types)", info.msgcount) for name, info in reader.topics.items())


def _open(path):
    p = Path(path)
    if p.is_dir() and not (p / "metadata.yaml").exists():
        raise InputError("%s: not a rosbag2 folder (no metadata.yaml); give the bag's folder or its .db3 "
                         "or .mcap file" % path)
    try:
        reader = Reader(p)
        reader.open()
    except FileNotFoundError as e:
        raise InputError("%s: %s" % (path, e)) from None
    except (ReaderError, KeyError, ValueError, OSError) as e:
        raise InputError("%s: not a readable ROS 2 bag: %s" % (path, e)) from None

    class _Closing:
        def __enter__(self):
            return reader

        def __exit__(self, *exc):
            reader.close()
            return False

    return _Closing()


def read_bag(path: str, cmap: Map, warn) -> tuple[dict[str, Series], list[str]]:
    """The map's columns as time series, and notes for the user (e.g. motor ids that differ
    from the position a topic stands for)."""
    notes: list[str] = []
    with _open(path) as reader:
        topics = reader.topics
        specs_by_topic: dict[str, list[ColumnSpec]] = {}
        for spec in cmap.columns:
            if spec.topic is None:
                raise InputError("%s: column %s: a bag needs a topic and a field (it has %s)"
                                 % (cmap.path, spec.name, spec.where()))
            if spec.topic not in topics or topics[spec.topic].msgcount == 0:
                what = "is not in the bag" if spec.topic not in topics else "has no messages"
                if spec.required:
                    raise InputError("%s: topic %s %s (column %s needs it; `auger import %s --list-topics` "
                                     "lists what it has)" % (path, spec.topic, what, spec.name, path))
                warn("%s: topic %s %s: column %s left empty" % (path, spec.topic, what, spec.name))
                continue
            specs_by_topic.setdefault(spec.topic, []).append(spec)
        conns = [c for c in reader.connections if c.topic in specs_by_topic]
        store = _typestore(path, conns)
        accessors = {}
        for c in conns:
            if c.msgtype not in store.fielddefs:
                raise InputError("%s: topic %s: type %s is neither defined in the bag nor a standard ROS 2 "
                                 "or robominer_msgs type" % (path, c.topic, c.msgtype))
            for spec in specs_by_topic[c.topic]:
                accessors[(c.id, spec.name)] = _Accessor(path, store, c.msgtype, spec, c.topic)
                for k in spec.match:
                    if k not in dict(store.fielddefs[c.msgtype][1]) and "." not in k:
                        raise InputError("%s: column %s: match: %s (%s) has no field '%s'"
                                         % (cmap.path, spec.name, c.topic, c.msgtype, k))
        samples: dict[str, tuple[list, list]] = {s.name: ([], []) for specs in specs_by_topic.values() for s in specs}
        counts: dict[str, int] = {}
        motor_ids: dict[str, set[str]] = {}
        for conn, t_ns, raw in reader.messages(connections=conns):
            n = counts[conn.topic] = counts.get(conn.topic, 0) + 1
            try:
                msg = store.deserialize_cdr(raw, conn.msgtype)
            except Exception as e:  # rosbags raises several kinds on a truncated or foreign message
                raise InputError("%s: topic %s: message %d (%s, at %d ns) cannot be decoded: %s"
                                 % (path, conn.topic, n, conn.msgtype, t_ns, e)) from None
            if conn.msgtype == "robominer_msgs/msg/MotorModuleFeedback":
                motor_ids.setdefault(conn.topic, set()).add(str(msg.motor_id))
            if cmap.clock == "header":
                try:
                    st = msg.header.stamp
                except AttributeError:
                    raise InputError("%s: topic %s (%s) has no header; the map's clock = \"header\" needs one"
                                     % (path, conn.topic, conn.msgtype)) from None
                t_ns = st.sec * 1_000_000_000 + st.nanosec
            for spec in specs_by_topic[conn.topic]:
                try:
                    if spec.match and any(_match_value(msg, k) != v for k, v in spec.match.items()):
                        continue
                    v = accessors[(conn.id, spec.name)].get(msg)
                except ValueError:
                    raise InputError("%s: topic %s: message %d: field %s is not a number"
                                     % (path, conn.topic, n, spec.field)) from None
                except AttributeError as e:  # a match key the message does not have
                    raise InputError("%s: column %s: match on %s (%s): %s"
                                     % (cmap.path, spec.name, conn.topic, conn.msgtype, e)) from None
                ts, vs = samples[spec.name]
                ts.append(t_ns)
                vs.append(v * spec.scale + spec.offset)
        # The group's motor modules report their own id; the topic (the position) decides the
        # screw index, and a module whose id differs is worth a word.
        for topic, ids in motor_ids.items():
            for spec in specs_by_topic[topic]:
                if spec.name.startswith("omega_rpm_") and not spec.match and ids != {spec.name[-1]}:
                    notes.append("%s carries motor_id %s; mapped by its topic to screw %s (%s)"
                                 % (topic, ", ".join(sorted(ids)), spec.name[-1], SCREW_NAMES[int(spec.name[-1])]))
    series = {}
    for specs in specs_by_topic.values():
        for spec in specs:
            ts, vs = samples[spec.name]
            if not ts:
                if spec.required:
                    raise InputError("%s: topic %s: no message matches %s (column %s)"
                                     % (path, spec.topic, spec.where(), spec.name))
                warn("%s: no message for column %s (%s): left empty" % (path, spec.name, spec.where()))
                continue
            t = np.asarray(ts, dtype=np.int64)
            order = np.argsort(t, kind="stable")
            series[spec.name] = Series(spec, t[order], np.asarray(vs, dtype=float)[order])
    return series, notes
