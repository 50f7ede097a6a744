"""Writes a robot log v1 (docs/log-format.md) whole or not at all, row by row.

The rows go to a temporary file beside the output, renamed over it only when complete (commit),
so an error (or a kill) never leaves a partial log. Numbers in their shortest round-trip form, an
empty field where there is no value, integers for status words.
"""

from __future__ import annotations

import os
import tempfile

from . import InputError
from .mapping import INTEGERS


def format_t0(start_ns: int) -> str:
    s = "%d.%09d" % divmod(start_ns, 1_000_000_000)
    return s.rstrip("0").rstrip(".") if "." in s else s


def _number(v):
    r = repr(float(v))
    return r[:-2] if r[-2:] == ".0" else r


def _integer(v):
    return str(int(v)) if v == int(v) else _number(v)



class LogWriter:
    """One log being written: header() once (it may be rewritten until the first row), then
    write_row() per row, then commit() or abort()."""

    def __init__(self, path: str):
        self.path = path
        d = os.path.dirname(os.path.abspath(path))
        try:
            fd, self.tmp = tempfile.mkstemp(prefix=".auger-import-", suffix=".csv", dir=d)
        except OSError as e:
            raise InputError("%s: cannot write here: %s" % (path, e.strerror or e)) from None
        self.f = os.fdopen(fd, "wb")
        self.columns: list[str] = []
        self.offset = 0  # bytes written

    def header(self, metadata: dict[str, str], columns: list[str]) -> None:
        """metadata in order (format first), then the header t_s + columns."""
        self._guard(self._header, metadata, columns)

    def _header(self, metadata, columns):
        self.f.seek(0)
        self.f.truncate()
        text = "# format: auger-robot-log v1\n"
        for k, v in metadata.items():
            if k != "format":
                text += "# %s: %s\n" % (k, v)
        data = (text + ",".join(["t_s"] + columns) + "\n").encode("utf-8")
        self.f.write(data)
        self.offset = len(data)
        self.columns = columns
        self._formats = [_integer if c in INTEGERS else _number for c in columns]

    def write_row(self, t_s: float, values: list[float]) -> int:
        """Writes one row; returns the file offset it starts at (for truncate)."""
        offset = self.offset
        line = (_number(t_s) + "," + ",".join(["" if v != v else f(v) for f, v in zip(self._formats, values)])
                + "\n").encode()
        try:
            self.f.write(line)
        except OSError as e:
            self.abort()
            raise InputError("%s: writing failed: %s" % (self.path, e.strerror or e)) from None
        self.offset += len(line)
        return offset

    def truncate(self, offset: int) -> None:
        """Drops every row from the one that started at offset."""
        self._guard(self._truncate, offset)

    def _truncate(self, offset):
        self.f.flush()
        self.f.seek(offset)
        self.f.truncate()
        self.offset = offset

    def _guard(self, fn, *args):
        try:
            return fn(*args)
        except OSError as e:
            self.abort()
            raise InputError("%s: writing failed: %s" % (self.path, e.strerror or e)) from None

    def commit(self) -> None:
        self._guard(self._commit)

    def _commit(self):
        self.f.close()
        os.chmod(self.tmp, 0o644)
        os.replace(self.tmp, self.path)

    def abort(self) -> None:
        try:
            self.f.close()
        except OSError:
            pass
        try:
            os.unlink(self.tmp)
        except OSError:
            pass
