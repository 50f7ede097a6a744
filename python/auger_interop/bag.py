"""ROS 2 bags (rosbag2: a folder with metadata.yaml, or one .db3 / .mcap file) into a robot log.

Two passes over the messages in recording order (bagscan.py): the first reads stamps only
(clock steps and silences: timeline.py; the grid's size; samples for the types: bagtypes.py),
the second decodes and puts each value on the grid as it comes (grid.py). Each value is checked
where it enters: a quaternion that is no orientation, a number outside its column's bounds, a
message that does not decode; what is dropped is counted and said, naming topic and message.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from rosbags.interfaces import Nodetype

from . import InputError
from .bagscan import header_stamp, in_record_order, open_bag, scan
from .bagtypes import Decoder, TypeBook
from .limits import MAX_GAPS, value_problem
from .mapping import INTEGERS, ColumnSpec, Map
from .robominer import FEEDBACK

QUATERNION = "geometry_msgs/msg/Quaternion"
SCREW_NAMES = ("front-right", "rear-right", "rear-left", "front-left")  # docs/model.md
NUMERIC = {"bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64",
           "uint64", "float32", "float64"}
UNIT_TOLERANCE = 0.01  # |norm - 1| of a quaternion that is an orientation (float32 sensors: 1e-4)


def yaw_of(x: float, y: float, z: float, w: float) -> float:
    """Heading psi of a unit quaternion (rotation about z after the ZYX convention), rad."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def quaternion_problem(x, y, z, w) -> tuple[str, str] | None:
    """(kind, the value) when (x, y, z, w) is no orientation."""
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if not math.isfinite(n) or abs(n - 1.0) > UNIT_TOLERANCE:
        return "not a unit quaternion", "(%g, %g, %g, %g), norm %.3g" % (x, y, z, w, n)
    return None


def absent_by_covariance(parent, name: str) -> tuple[str, str] | None:
    """(kind, the value) when sensor_msgs/Imu's field `name` of `parent` carries no measurement:
    its covariance's first element is -1 (REP 145), or it is a linear acceleration of exactly
    0, 0, 0 (an accelerometer always reads gravity: the field was never filled in, as augerd's
    ROS 2 input takes it, docs/ros2.md)."""
    cov = getattr(parent, name + "_covariance")
    if len(cov) and cov[0] == -1:
        return ("no %s: %s_covariance[0] = -1, the sensor_msgs/Imu convention for a sensor without one"
                % (name.replace("_", " "), name), "-1")
    if name == "linear_acceleration":
        a = getattr(parent, name)
        if a.x == 0 and a.y == 0 and a.z == 0:
            return "no linear acceleration: 0, 0, 0 (an accelerometer always reads gravity)", "0 0 0"
    return None


class Accessor:
    """A field path resolved against a message type once: how to get the value, and its kind."""

    def __init__(self, dec: Decoder, spec: ColumnSpec):
        """LookupError (why, for every field of the spec) when the type has none of them."""
        errors = []
        for path in spec.fields:
            try:
                self._resolve(dec, path)
                self.path = path
                return
            except LookupError as e:
                errors.append(str(e))
        raise LookupError("; ".join(errors))

    def _resolve(self, dec, path):
        self.steps, self.covariance = [], None
        typ, kind = dec.msgtype, None
        parts = path.split(".")
        for n, part in enumerate(parts):
            index = None
            if part.endswith("]") and "[" in part:
                part, idx = part[:-1].split("[", 1)
                if not idx.isdigit():
                    raise LookupError("field '%s': '[%s]' is not an index" % (path, idx))
                index = int(idx)
            if typ is None:
                raise LookupError("field '%s': '%s' is not a message, it has no fields" % (path, part))
            fields = dec.fields(typ)
            if part not in fields:
                raise LookupError("has no field '%s'%s (it has: %s)" % (
                    part, "" if part == path else " (in '%s')" % path, ", ".join(fields)))
            node, arg = fields[part]
            if index is not None:
                if node not in (Nodetype.ARRAY, Nodetype.SEQUENCE):
                    raise LookupError("field '%s': %s is not an array" % (path, part))
                node, arg = arg[0]
            elif node in (Nodetype.ARRAY, Nodetype.SEQUENCE):
                raise LookupError("field '%s': %s is an array; name an element, e.g. %s[0]" % (path, part, part))
            if index is None and part + "_covariance" in fields:
                # sensor_msgs/Imu (REP 145): orientation_covariance[0] = -1 says "no orientation
                # estimate", and so for angular_velocity and linear_acceleration and their parts
                self.covariance = (n, part)
            self.steps.append((part, index))
            if node == Nodetype.NAME:
                typ, kind = arg, "message"
            else:
                typ, kind = None, arg[0]
        if kind == "message" and typ == QUATERNION:
            self.kind = "quaternion"
        elif kind in NUMERIC or kind == "string":
            self.kind = kind
        else:
            raise LookupError("field '%s' is a %s, not a number or a quaternion" % (path, typ or kind))

    def get(self, msg) -> tuple[float, tuple[str, str] | None]:
        """(value, (kind, the value) when it is no value) of one message."""
        v = msg
        for n, (name, index) in enumerate(self.steps):
            if self.covariance is not None and self.covariance[0] == n:
                p = absent_by_covariance(v, name)
                if p:
                    return math.nan, p
            v = getattr(v, name)
            if index is not None:
                v = v[index]
        if self.kind == "quaternion":
            p = quaternion_problem(v.x, v.y, v.z, v.w)
            return (math.nan, p) if p else (yaw_of(v.x, v.y, v.z, v.w), None)
        if self.kind == "string":
            try:
                return float(v), None  # a number sent as text
            except ValueError:
                return math.nan, ("not a number", repr(v[:40]))
        if self.kind == "float32":
            # the float32's shortest decimal (10.7, not 10.699999809265137): what was meant
            return float(str(np.float32(v))), None
        return float(v), None


def _match_value(msg, field):
    v = msg
    for part in field.split("."):
        v = getattr(v, part)
    return str(v)


@dataclass
class Problems:
    """Values left out, per column and reason: counted, the first one named."""
    seen: dict[str, int] = field(default_factory=dict)
    dropped: dict[tuple[str, str], list] = field(default_factory=dict)

    def add(self, column, kind, first_text):
        d = self.dropped.setdefault((column, kind), [0, first_text])
        d[0] += 1

    def warnings(self, where_of) -> list[str]:
        return ["column %s (%s): %d of %d samples left empty, %s (the first: %s)"
                % (c, where_of(c), n, self.seen.get(c, n), kind, first) for (c, kind), (n, first) in self.dropped.items()]


@dataclass
class BagPlan:
    """What the first pass settled, for the second (read_values)."""
    reader: object
    conns: list
    specs_by_topic: dict[str, list[ColumnSpec]]
    decoders: dict[int, Decoder]
    accessors: dict[tuple[int, str], Accessor]
    scans: dict
    notes: list[str]


def plan_bag(path: str, cmap: Map, user_msgs: dict, warn) -> BagPlan:
    """Opens the bag and does everything before decoding: topics, first pass, types, fields."""
    reader = open_bag(path)
    try:
        return _plan(reader, path, cmap, user_msgs, warn)
    except BaseException:
        reader.close()
        raise


def _plan(reader, path, cmap, user_msgs, warn):
    topics = reader.topics
    specs_by_topic: dict[str, list[ColumnSpec]] = {}
    absent: dict[str, list[str]] = {}
    for spec in cmap.columns:
        if spec.topic is None:
            raise InputError("%s: column %s: a bag needs a topic and a field (it has %s)"
                             % (cmap.path, spec.name, spec.where()))
        if spec.topic not in topics or topics[spec.topic].msgcount == 0:
            what = "is not in the bag" if spec.topic not in topics else "has no messages"
            if spec.required:
                raise InputError("%s: topic %s %s (column %s needs it; `auger import %s --list-topics` "
                                 "lists what it has)" % (path, spec.topic, what, spec.name, path))
            absent.setdefault("%s %s" % (spec.topic, what), []).append(spec.name)
            continue
        specs_by_topic.setdefault(spec.topic, []).append(spec)
    for what, cols in absent.items():
        warn("%s: topic %s: column%s %s left empty" % (path, what, "s" if len(cols) > 1 else "", ", ".join(cols)))
    conns = [c for c in reader.connections if c.topic in specs_by_topic]
    scans = scan(reader, conns, path, cmap.clock, int(cmap.max_gap_s * 1e9), MAX_GAPS)
    book = TypeBook(path, conns, user_msgs, warn)
    fitted: dict[str, list[str]] = {}     # decoded as (an older version): topics
    optional: dict[tuple, list[str]] = {}  # (type, its source, why): optional columns without a field
    decoders: dict[int, Decoder] = {}
    accessors: dict[tuple[int, str], Accessor] = {}
    for c in conns:
        specs = specs_by_topic.get(c.topic)
        if not specs:
            continue
        needed = [s.name for s in specs if s.required]
        samples = scans[c.topic].samples.get(c.id, []) if c.topic in scans else []
        if not samples:  # the bag's index counted messages its storage does not have
            if needed:
                raise InputError("%s: topic %s has no messages in its storage (columns %s need them)"
                                 % (path, c.topic, ", ".join(needed)))
            continue
        dec, why, note = book.choose(c.topic, c.msgtype, samples)
        if dec is None:
            if needed:
                raise InputError("%s: topic %s (columns %s): %s" % (path, c.topic, ", ".join(needed), why))
            warn("%s: topic %s: %s: dropped, columns %s left empty" % (path, c.topic, why,
                                                                       ", ".join(s.name for s in specs)))
            _drop_topic(c.topic, specs_by_topic, scans)
            continue
        if note and note.startswith("decoded as"):
            fitted.setdefault(note, []).append(c.topic)
        elif note:
            warn("%s: %s: %s" % (path, c.topic, note))
        if cmap.clock == "header" and not dec.has_header():
            raise InputError("%s: topic %s (%s) has no header; the map's clock = \"header\" needs one"
                             % (path, c.topic, c.msgtype))
        decoders[c.id] = dec
        for spec in list(specs):
            try:
                accessors[(c.id, spec.name)] = Accessor(dec, spec)
            except LookupError as e:
                if spec.required:
                    raise InputError("%s: column %s: %s (%s) %s%s"
                                     % (path, spec.name, c.topic, c.msgtype, e, _pose_hint(spec))) from None
                optional.setdefault((c.msgtype, dec.source, str(e)), []).append("%s (%s)" % (spec.name, c.topic))
                continue
            for k in spec.match:
                if k.split(".")[0] not in dec.fields():
                    raise InputError("%s: column %s: match: %s (%s) has no field '%s'"
                                     % (cmap.path, spec.name, c.topic, c.msgtype, k))
    for (typ, source, why), cols in optional.items():
        warn("%s: %s (as %s) %s: left empty, as the map allows: %s" % (path, typ, source, why, ", ".join(cols)))
    notes = ["%s (the definition their bytes fit): %s" % (note, ", ".join(topics)) for note, topics in fitted.items()]
    conns = [c for c in conns if c.id in decoders]
    if cmap.clock == "header":
        for topic, s in scans.items():
            if s.stampless:
                raise InputError("%s: topic %s: %d messages too short for a header" % (path, topic, s.stampless))
    return BagPlan(reader, conns, specs_by_topic, decoders, accessors, scans, notes)


def _drop_topic(topic, specs_by_topic, scans):
    specs_by_topic.pop(topic, None)
    scans.pop(topic, None)


def _pose_hint(spec: ColumnSpec) -> str:
    if spec.name in ("x_m", "y_m", "psi_rad"):
        return ("; the default map reads PoseStamped, PoseWithCovarianceStamped, Odometry and TransformStamped "
                "there: for another type give a map (--map FILE, docs/formats.md) whose %s names its field"
                % spec.name)
    return "; a map (--map FILE, docs/formats.md) names another field"


def read_values(plan: BagPlan, path: str, cmap: Map, route, problems: Problems, t_ref_ns: int):
    """The second pass: every mapped value, decoded and checked, to route(topic, idx, t, column, v)."""
    specs_by_topic = plan.specs_by_topic
    counts: dict[int, int] = {}
    undecoded: dict[str, list] = {}
    motor_ids: dict[str, set[str]] = {}
    for idx, (conn, t_rx, raw) in enumerate(in_record_order(plan.reader, plan.conns, path)):
        dec = plan.decoders[conn.id]
        n = counts[conn.id] = counts.get(conn.id, 0) + 1
        t_ns = header_stamp(raw) if cmap.clock == "header" else t_rx
        specs = specs_by_topic[conn.topic]
        try:
            msg = dec.decode(raw)
        except Exception as e:  # rosbags raises several kinds on a truncated or foreign message
            if any(s.required for s in specs):
                raise InputError("%s: topic %s: message %d (%s as %s, at %d ns) cannot be decoded: %s"
                                 % (path, conn.topic, n, conn.msgtype, dec.source, t_ns, e)) from None
            u = undecoded.setdefault(conn.topic, [0, n, t_ns, str(e)])
            u[0] += 1
            continue
        if conn.msgtype == FEEDBACK:
            motor_ids.setdefault(conn.topic, set()).add(str(getattr(msg, "motor_id", "?")))
        for spec in specs:
            acc = plan.accessors.get((conn.id, spec.name))
            if acc is None:
                continue
            try:
                if spec.match and any(_match_value(msg, k) != v for k, v in spec.match.items()):
                    continue
            except AttributeError as e:
                raise InputError("%s: column %s: match on %s (%s): %s"
                                 % (cmap.path, spec.name, conn.topic, conn.msgtype, e)) from None
            problems.seen[spec.name] = problems.seen.get(spec.name, 0) + 1
            v, why = acc.get(msg)
            if why is None:
                v = v * spec.scale + spec.offset
                why = value_problem(spec.name, v, spec.name in INTEGERS)
            if why is not None:
                problems.add(spec.name, why[0], "message %d at t = %.3f s, %s" % (n, (t_ns - t_ref_ns) / 1e9, why[1]))
                continue
            route(conn.topic, idx, t_ns, spec.name, v)
    notes = []
    for topic, (k, n, t_ns, e) in undecoded.items():
        notes.append("%s: topic %s: %d messages cannot be decoded (the first: message %d at t = %.3f s: %s): "
                     "left out" % (path, topic, k, n, (t_ns - t_ref_ns) / 1e9, e))
    ids_notes = []
    # The group's motor modules report their own id; the topic (the position) decides the
    # screw index, and a module whose id differs is worth a word.
    for topic, ids in motor_ids.items():
        for spec in specs_by_topic[topic]:
            if spec.name.startswith("omega_rpm_") and not spec.match and ids != {spec.name[-1]}:
                ids_notes.append("%s carries motor_id %s; mapped by its topic to screw %s (%s)"
                                 % (topic, ", ".join(sorted(ids)), spec.name[-1], SCREW_NAMES[int(spec.name[-1])]))
    return notes, ids_notes
