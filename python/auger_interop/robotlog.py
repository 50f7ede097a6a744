"""Writes a robot log v1 (docs/log-format.md) whole or not at all.

The rows go to a temporary file beside the output, renamed over it only when complete, so an
error (or a kill) never leaves a partial log. Numbers in their shortest round-trip form, an
empty field where there is no value, integers for status words.
"""

from __future__ import annotations

import math
import os
import tempfile

import numpy as np

from . import InputError
from .mapping import INTEGERS


def format_t0(start_ns: int) -> str:
    s = "%d.%09d" % divmod(start_ns, 1_000_000_000)
    return s.rstrip("0").rstrip(".") if "." in s else s


def _field(name, v):
    if math.isnan(v):
        return ""
    if name in INTEGERS and v == int(v):
        return str(int(v))
    r = repr(float(v))
    return r[:-2] if r.endswith(".0") else r


def write_log(path: str, metadata: dict[str, str], columns: list[str], t_s: np.ndarray,
              data: dict[str, np.ndarray]) -> None:
    """metadata in order (format first), then the header t_s + columns, then one row per t_s."""
    d = os.path.dirname(os.path.abspath(path))
    try:
        fd, tmp = tempfile.mkstemp(prefix=".auger-import-", suffix=".csv", dir=d)
    except OSError as e:
        raise InputError("%s: cannot write here: %s" % (path, e.strerror or e)) from None
    try:
        with os.fdopen(fd, "w", newline="\n", encoding="utf-8") as f:
            f.write("# format: auger-robot-log v1\n")
            for k, v in metadata.items():
                if k != "format":
                    f.write("# %s: %s\n" % (k, v))
            f.write(",".join(["t_s"] + columns) + "\n")
            cols = [data[c] for c in columns]
            for r in range(len(t_s)):
                f.write(_field("t_s", t_s[r]))
                for name, col in zip(columns, cols):
                    f.write(",")
                    f.write(_field(name, col[r]))
                f.write("\n")
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException as e:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(e, OSError):
            raise InputError("%s: writing failed: %s" % (path, e.strerror or e)) from None
        raise
