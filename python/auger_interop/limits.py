"""The import's bounds: files it reads (a map, a .msg), the log it writes, the values it puts in.

A value outside its column's physical bound would make the written log unreadable by every
auger tool (the C++ reader refuses it, docs/log-format.md); the bounds are those of
host/include/auger/input_limits.hpp, column by column as the reader applies them
(host/src/log.cpp, robot_bound).
"""

from __future__ import annotations

import math
import os
import stat

from . import InputError

MAX_TEXT_FILE_BYTES = 1 << 20     # a map or a .msg file: a few kB in practice
MAX_ROWS = 8_640_000              # one log: 24 h at 100 Hz (about 2 GB of CSV); max_rows in a map
MAX_SEGMENTS = 100                # stretches between clock steps that --split writes
MAX_GAPS = 1_000_000              # silences longer than max_gap_s remembered over the whole bag

_SCREW_RPM = 327.67               # the setpoint frame's int16 in 0.01 rpm
_POSITION_M = 1e7                 # UTM northings
_HEADING_RAD = 1000.0             # an unwrapped yaw after 159 turns
_YAW_RATE_RADPS = 35.0            # a MEMS gyro's 2000 deg/s
_ACCELERATION_MPS2 = 157.0        # a MEMS accelerometer's 16 g


def value_bound(column: str) -> float | None:
    """The largest magnitude a column's value may have (None: any finite number)."""
    if column.startswith(("omega_rpm_", "cmd_rpm_")):
        return _SCREW_RPM
    if column in ("x_m", "y_m", "xd_m", "yd_m"):
        return _POSITION_M
    if column in ("psi_rad", "imu_psi_rad", "psid_rad"):
        return _HEADING_RAD
    if column == "imu_r_radps":
        return _YAW_RATE_RADPS
    if column in ("imu_ax_mps2", "imu_ay_mps2"):
        return _ACCELERATION_MPS2
    return None


def value_problem(column: str, v: float, integer: bool) -> tuple[str, str] | None:
    """(kind, the value) when v cannot go into the column; None when it can."""
    if not math.isfinite(v):
        return "not a finite number", repr(v)
    b = value_bound(column)
    if b is not None and abs(v) > b:
        return "outside +-%g, the log format's bound (docs/log-format.md)" % b, "%.6g" % v
    if integer and v != int(v):
        return "not an integer", "%.6g" % v
    return None


def read_text_file(path: str, what: str, max_bytes: int = MAX_TEXT_FILE_BYTES) -> str:
    """A small text file (a map, a .msg) read whole: refused at once if it is not a regular file
    (a device such as /dev/zero, a FIFO, a directory) or larger than max_bytes."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except OSError as e:
        raise InputError("%s: cannot read the %s: %s" % (path, what, e.strerror or e)) from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            kind = "a directory" if stat.S_ISDIR(st.st_mode) else "not a regular file (a device or a pipe)"
            raise InputError("%s: the %s is %s" % (path, what, kind))
        if st.st_size > max_bytes:
            raise InputError("%s: the %s is %d bytes, more than the %d a %s may have"
                             % (path, what, st.st_size, max_bytes, what))
        chunks, size = [], 0
        while size <= max_bytes:
            b = os.read(fd, max_bytes + 1 - size)
            if not b:
                break
            chunks.append(b)
            size += len(b)
        data = b"".join(chunks)
        if len(data) > max_bytes:  # grew since fstat
            raise InputError("%s: the %s is more than %d bytes" % (path, what, max_bytes))
    except OSError as e:
        raise InputError("%s: cannot read the %s: %s" % (path, what, e.strerror or e)) from None
    finally:
        os.close(fd)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise InputError("%s: the %s is not UTF-8 text (byte %d)" % (path, what, e.start)) from None
