"""The import map: which topic field (bag) or column (CSV) becomes which log column, and how.

A map is a small TOML file (docs/formats.md); maps/robominer.toml is the default for bags.
Every key is checked: an unknown key, a wrong type or a column the log format does not know
is an error naming the file and the key. The file is read with a size limit (limits.py).
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, field as dc_field
from pathlib import Path

from . import InputError
from .limits import MAX_ROWS, read_text_file

DEFAULT_MAP = Path(__file__).parent / "maps" / "robominer.toml"

# The robot log's columns (docs/log-format.md), in the order the import writes them.
LOG_COLUMNS = (
    ["omega_rpm_%d" % i for i in range(4)]
    + ["cmd_rpm_%d" % i for i in range(4)]
    + ["current_a_%d" % i for i in range(4)]
    + ["voltage_v_%d" % i for i in range(4)]
    + ["x_m", "y_m", "psi_rad", "imu_psi_rad", "imu_r_radps", "xd_m", "yd_m", "psid_rad"]
    + ["pwm_%d" % i for i in range(4)]
    + ["status_%d" % i for i in range(4)]
    + ["seq_ack_%d" % i for i in range(4)]
    + ["loop_dt_s", "imu_ax_mps2", "imu_ay_mps2"]
)
REQUIRED_COLUMNS = ["omega_rpm_%d" % i for i in range(4)] + ["x_m", "y_m", "psi_rad"]
HEADINGS = {"psi_rad", "imu_psi_rad", "psid_rad"}  # wrapped to (-pi, pi] (docs/model.md)
INTEGERS = {"status_%d" % i for i in range(4)} | {"seq_ack_%d" % i for i in range(4)}

# How a column is put on the grid (grid.py): a measurement stays sparse (each sample on its
# nearest row, the rows between empty: "not measured", so the noise floor sees only measured
# samples); a setpoint, a reference or a status word is in force until the next, so it is held;
# linear interpolation only where a map asks for it.
RESAMPLE_MODES = ("sparse", "hold", "linear")


def default_resample(name: str) -> str:
    if name.startswith(("cmd_rpm_", "status_", "seq_ack_")) or name in ("xd_m", "yd_m", "psid_rad"):
        return "hold"
    return "sparse"


@dataclass
class ColumnSpec:
    name: str                      # the log column
    topic: str | None = None       # bag: the topic ...
    fields: list[str] = dc_field(default_factory=list)  # ... and the field path in its message
    #                                ("pose.position.x"); several: the first the type has
    column: str | None = None      # CSV: the source column
    quaternion: list[str] | None = None  # CSV: four columns x, y, z, w whose yaw is the value
    match: dict[str, str] = dc_field(default_factory=dict)  # bag: only messages with these field values
    scale: float = 1.0             # value = source * scale + offset
    offset: float = 0.0
    resample: str = "linear"
    required: bool = True

    @property
    def field(self) -> str | None:
        return " or ".join(self.fields) if self.fields else None

    def where(self) -> str:
        """Where the values come from, for messages."""
        if self.topic is not None:
            m = "".join(" with %s == %r" % kv for kv in self.match.items())
            return "%s field %s%s" % (self.topic, self.field, m)
        if self.quaternion:
            return "the yaw of columns %s" % ", ".join(self.quaternion)
        return "column %s" % self.column


@dataclass
class Map:
    path: str
    rate_hz: float = 100.0
    clock: str = "receive"          # bag: "receive" (the bag's time stamps) or "header" (header.stamp)
    max_gap_s: float = 1.0          # a longer silence of every source splits the log (timeline.py)
    max_rows: int = MAX_ROWS        # the most rows one log may have
    msg: dict[str, str] = dc_field(default_factory=dict)  # bag: .msg text of types the bag lacks
    metadata: dict[str, str] = dc_field(default_factory=dict)
    columns: list[ColumnSpec] = dc_field(default_factory=list)
    # CSV only: the time column, its scale to seconds, and whether it is Unix time
    time_column: str | None = None
    time_scale: float = 1.0
    time_unix: bool = False
    delimiter: str = ","

    def column(self, name: str) -> ColumnSpec | None:
        return next((c for c in self.columns if c.name == name), None)


_NAME = re.compile(r"^[a-z][a-z0-9_]*$")


def _fail(path, where, msg):
    raise InputError("%s: %s: %s" % (path, where, msg))


def _number(path, where, v):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        _fail(path, where, "%r is not a finite number" % (v,))
    return float(v)


def _string(path, where, v):
    if not isinstance(v, str) or not v:
        _fail(path, where, "%r is not a non-empty string" % (v,))
    return v


def _keys(path, where, table, allowed):
    for k in table:
        if k not in allowed:
            _fail(path, where, "unknown key '%s' (known: %s)" % (k, ", ".join(sorted(allowed))))


_TYPE = re.compile(r"^[A-Za-z][A-Za-z0-9_]*/(msg/)?[A-Za-z][A-Za-z0-9_]*$")


def _type_name(path, where, v):
    """A ROS 2 message type name, "pkg/msg/Type" (also "pkg/Type")."""
    if not isinstance(v, str) or not _TYPE.match(v):
        _fail(path, where, "%r is not a message type name like robominer_msgs/msg/MotorModuleFeedback" % (v,))
    return v if "/msg/" in v else v.replace("/", "/msg/", 1)


def load_map(path: str | Path | None = None) -> Map:
    """Reads and checks a map file (the default map when path is None)."""
    p = Path(path) if path is not None else DEFAULT_MAP
    name = str(p)
    text = read_text_file(name, "map")
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise InputError("%s: not valid TOML: %s" % (name, e)) from None

    _keys(name, "top level", doc, {"schema", "rate_hz", "clock", "max_gap_s", "max_rows", "metadata", "columns",
                                   "time", "csv", "msg"})
    if doc.get("schema") != 1:
        _fail(name, "schema", "must be 1 (got %r)" % (doc.get("schema"),))
    m = Map(path=name)
    if "rate_hz" in doc:
        m.rate_hz = _number(name, "rate_hz", doc["rate_hz"])
        if not 1 <= m.rate_hz <= 10000:
            _fail(name, "rate_hz", "%g is outside 1..10000 Hz" % m.rate_hz)
    if "clock" in doc:
        m.clock = _string(name, "clock", doc["clock"])
        if m.clock not in ("receive", "header"):
            _fail(name, "clock", "'%s' is not 'receive' or 'header'" % m.clock)
    if "max_gap_s" in doc:
        m.max_gap_s = _number(name, "max_gap_s", doc["max_gap_s"])
        if not 0 < m.max_gap_s <= 3600:
            _fail(name, "max_gap_s", "%g is outside (0, 3600] s" % m.max_gap_s)
    if "max_rows" in doc:
        v = doc["max_rows"]
        if isinstance(v, bool) or not isinstance(v, int) or not 3 <= v <= 10 * MAX_ROWS:
            _fail(name, "max_rows", "%r is not a whole number in 3..%d" % (v, 10 * MAX_ROWS))
        m.max_rows = v
    msg = doc.get("msg", {})
    if not isinstance(msg, dict):
        _fail(name, "msg", "must be a table of \"pkg/msg/Type\" = \"\"\"its .msg text\"\"\"")
    for k, v in msg.items():
        m.msg[_type_name(name, "msg." + k, k)] = _string(name, "msg." + k, v)
    meta = doc.get("metadata", {})
    if not isinstance(meta, dict):
        _fail(name, "metadata", "must be a table")
    for k, v in meta.items():
        if not _NAME.match(k) or k in ("format", "t0_unix_s"):
            _fail(name, "metadata." + k, "not a metadata key the map may set")
        m.metadata[k] = _string(name, "metadata." + k, v)
        if "\n" in v:
            _fail(name, "metadata." + k, "a value must be one line")

    t = doc.get("time", {})
    if not isinstance(t, dict):
        _fail(name, "time", "must be a table")
    _keys(name, "[time]", t, {"column", "scale", "unix"})
    if "column" in t:
        m.time_column = _string(name, "time.column", t["column"])
    if "scale" in t:
        m.time_scale = _number(name, "time.scale", t["scale"])
        if m.time_scale <= 0:
            _fail(name, "time.scale", "must be positive")
    if "unix" in t:
        if not isinstance(t["unix"], bool):
            _fail(name, "time.unix", "must be true or false")
        m.time_unix = t["unix"]
    c = doc.get("csv", {})
    if not isinstance(c, dict):
        _fail(name, "csv", "must be a table")
    _keys(name, "[csv]", c, {"delimiter"})
    if "delimiter" in c:
        m.delimiter = _string(name, "csv.delimiter", c["delimiter"])
        if len(m.delimiter) != 1:
            _fail(name, "csv.delimiter", "must be one character")

    cols = doc.get("columns")
    if not isinstance(cols, dict) or not cols:
        _fail(name, "[columns]", "missing or empty: the map must say where each log column comes from")
    for col, spec in cols.items():
        where = "columns." + col
        if col == "t_s":
            _fail(name, where, "t_s is made by the import (the grid); name the time source in [time]")
        if not _NAME.match(col):
            _fail(name, where, "not a valid column name (lower case, digits, _)")
        if not isinstance(spec, dict):
            _fail(name, where, "must be a table, e.g. { topic = \"/x\", field = \"y\" }")
        _keys(name, where, spec, {"topic", "field", "column", "quaternion", "match", "scale", "offset",
                                  "resample", "required"})
        cs = ColumnSpec(name=col, resample=default_resample(col))
        if "topic" in spec or "field" in spec:
            cs.topic = _string(name, where + ".topic", spec.get("topic"))
            f = spec.get("field")
            alternatives = f if isinstance(f, list) and f else [f]
            cs.fields = [_string(name, where + ".field", x) for x in alternatives]
        if "column" in spec:
            cs.column = _string(name, where + ".column", spec["column"])
        if "quaternion" in spec:
            q = spec["quaternion"]
            if not isinstance(q, list) or len(q) != 4 or not all(isinstance(x, str) and x for x in q):
                _fail(name, where + ".quaternion", "must list four columns: x, y, z, w")
            cs.quaternion = q
        sources = sum(x is not None for x in (cs.topic, cs.column, cs.quaternion))
        if sources != 1:
            _fail(name, where, "needs exactly one source: topic + field (bags), column or quaternion (CSV)")
        if "match" in spec:
            if cs.topic is None or not isinstance(spec["match"], dict):
                _fail(name, where + ".match", "a table of field = value, for a topic source")
            cs.match = {k: str(v) for k, v in spec["match"].items()}
        if "scale" in spec:
            cs.scale = _number(name, where + ".scale", spec["scale"])
        if "offset" in spec:
            cs.offset = _number(name, where + ".offset", spec["offset"])
        if "resample" in spec:
            cs.resample = _string(name, where + ".resample", spec["resample"])
            if cs.resample not in RESAMPLE_MODES:
                _fail(name, where + ".resample", "'%s' is not one of %s" % (cs.resample, ", ".join(RESAMPLE_MODES)))
        if "required" in spec:
            if not isinstance(spec["required"], bool):
                _fail(name, where + ".required", "must be true or false")
            cs.required = spec["required"]
        m.columns.append(cs)
    for req in ("omega_rpm_%d" % i for i in range(4)):
        if m.column(req) is None:
            _fail(name, "[columns]", "%s is not mapped (the log needs the four screw speeds)" % req)
    return m
