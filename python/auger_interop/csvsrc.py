"""A CSV file of another program into time series, by the map's [time] and [columns].

One header row (lines starting with '#' before or after it are skipped), then one row per
sample; an empty field, 'nan' or 'NaN' is "not measured". Errors name file, line and column.
"""

from __future__ import annotations

import csv
import math

import numpy as np

from . import InputError
from .bag import Series, yaw_of
from .mapping import Map


def _num(path, line, col, text):
    t = text.strip()
    if t == "" or t.lower() == "nan":
        return math.nan
    try:
        v = float(t)
    except ValueError:
        raise InputError("%s:%d: column %s: '%s' is not a number" % (path, line, col, text)) from None
    if not math.isfinite(v):
        raise InputError("%s:%d: column %s: '%s' is not a finite number" % (path, line, col, text))
    return v


def read_csv(path: str, cmap: Map, warn) -> tuple[dict[str, Series], bool]:
    """The map's columns as series (times in ns from the time column), and whether that time
    is Unix time (then it also gives the log's t0_unix_s)."""
    if cmap.time_column is None:
        raise InputError("%s: [time] column is missing: a CSV import needs the name of its time column"
                         % cmap.path)
    for spec in cmap.columns:
        if spec.topic is not None:
            raise InputError("%s: column %s: a CSV needs `column` or `quaternion`, not a topic (%s)"
                             % (cmap.path, spec.name, spec.where()))
    try:
        f = open(path, newline="", encoding="utf-8-sig")
    except OSError as e:
        raise InputError("%s: cannot read: %s" % (path, e.strerror or e)) from None
    with f:
        rows = csv.reader(f, delimiter=cmap.delimiter)
        header = None
        times: list[float] = []
        values: dict[str, list[float]] = {s.name: [] for s in cmap.columns}
        idx: dict[str, list[int]] = {}
        t_idx = 0
        try:
            for row in rows:
                line = rows.line_num
                if not row or (row[0].lstrip().startswith("#")) or all(not x.strip() for x in row):
                    continue
                if header is None:
                    header = [h.strip() for h in row]
                    missing = []
                    for spec in cmap.columns:
                        names = spec.quaternion if spec.quaternion else [spec.column]
                        for n in names:
                            if n not in header:
                                missing.append((spec, n))
                        idx[spec.name] = [header.index(n) if n in header else -1 for n in names]
                    if cmap.time_column not in header:
                        raise InputError("%s:%d: no time column '%s' in the header (it has: %s)"
                                         % (path, line, cmap.time_column, ", ".join(header)))
                    t_idx = header.index(cmap.time_column)
                    for spec, n in missing:
                        if spec.required:
                            raise InputError("%s:%d: no column '%s' in the header (the map's %s needs it; "
                                             "the header has: %s)" % (path, line, n, spec.name, ", ".join(header)))
                        warn("%s: no column '%s': %s left empty" % (path, n, spec.name))
                    continue
                if len(row) != len(header):
                    raise InputError("%s:%d: %d fields, the header has %d" % (path, line, len(row), len(header)))
                t = _num(path, line, cmap.time_column, row[t_idx])
                if math.isnan(t):
                    raise InputError("%s:%d: column %s: the time is empty" % (path, line, cmap.time_column))
                t *= cmap.time_scale
                if times and t <= times[-1]:
                    raise InputError("%s:%d: column %s: time %r s is not after the previous row's %r s"
                                     % (path, line, cmap.time_column, t, times[-1]))
                times.append(t)
                for spec in cmap.columns:
                    ix = idx[spec.name]
                    if any(i < 0 for i in ix):
                        values[spec.name].append(math.nan)
                        continue
                    xs = [_num(path, line, header[i], row[i]) for i in ix]
                    if any(math.isnan(x) for x in xs):
                        v = math.nan
                    elif spec.quaternion:
                        v = yaw_of(*xs)
                    else:
                        v = xs[0]
                    values[spec.name].append(v * spec.scale + spec.offset)
        except csv.Error as e:
            raise InputError("%s:%d: %s" % (path, rows.line_num, e)) from None
        except UnicodeDecodeError as e:
            raise InputError("%s: not UTF-8 text (byte %d)" % (path, e.start)) from None
    if header is None:
        raise InputError("%s: no header row" % path)
    if not times:
        raise InputError("%s: no data rows after the header" % path)
    t_s = np.asarray(times)
    # Relative times keep their precision in ns; Unix times too (int64 ns reaches year 2262).
    t_ns = np.round(t_s * 1e9).astype(np.int64)
    series = {}
    for spec in cmap.columns:
        v = np.asarray(values[spec.name])
        keep = ~np.isnan(v)
        if not keep.any():
            if spec.required and all(i >= 0 for i in idx[spec.name]):
                raise InputError("%s: column %s (for %s) has no value in any row" % (path, spec.where(), spec.name))
            continue
        series[spec.name] = Series(spec, t_ns[keep], v[keep])
    return series, cmap.time_unix
