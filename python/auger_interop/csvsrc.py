"""A CSV file of another program into the log, by the map's [time] and [columns].

One header row (lines starting with '#' before or after it are skipped), then one row per
sample; an empty field, 'nan' or 'NaN' is "not measured". Errors name file, line and column.
The file is read twice, row by row (the times first: silences, the grid's size; then the
values), so its size does not bound what can be imported.
"""

from __future__ import annotations

import csv
import math

from . import InputError
from .bag import Problems, quaternion_problem, yaw_of
from .bagscan import TopicScan
from .limits import MAX_GAPS, value_problem
from .mapping import INTEGERS, Map

TOPIC = "the CSV rows"  # the one source of a CSV file, for the timeline


def _num(path, line, col, text):
    t = text.strip()
    if t == "" or t.lower() == "nan":
        return math.nan
    try:
        v = float(t)
    except ValueError:
        raise InputError("%s:%d: column %s: '%s' is not a number" % (path, line, col, text[:60])) from None
    if not math.isfinite(v):
        raise InputError("%s:%d: column %s: '%s' is not a finite number" % (path, line, col, text[:60]))
    return v


def check_map(cmap: Map):
    if cmap.time_column is None:
        raise InputError("%s: [time] column is missing: a CSV import needs the name of its time column"
                         % cmap.path)
    for spec in cmap.columns:
        if spec.topic is not None:
            raise InputError("%s: column %s: a CSV needs `column` or `quaternion`, not a topic (%s)"
                             % (cmap.path, spec.name, spec.where()))


def rows(path: str, cmap: Map, warn, values: bool):
    """(line, time in ns, {column: value or NaN}) per data row; the values only when asked."""
    try:
        f = open(path, newline="", encoding="utf-8-sig")
    except OSError as e:
        raise InputError("%s: cannot read: %s" % (path, e.strerror or e)) from None
    with f:
        reader = csv.reader(f, delimiter=cmap.delimiter)
        header = None
        idx: dict[str, list[int]] = {}
        t_idx = 0
        prev = None
        try:
            for row in reader:
                line = reader.line_num
                if not row or (row[0].lstrip().startswith("#")) or all(not x.strip() for x in row):
                    continue
                if header is None:
                    header = [h.strip() for h in row]
                    if cmap.time_column not in header:
                        raise InputError("%s:%d: no time column '%s' in the header (it has: %s)"
                                         % (path, line, cmap.time_column, ", ".join(header)))
                    t_idx = header.index(cmap.time_column)
                    for spec in cmap.columns:
                        names = spec.quaternion if spec.quaternion else [spec.column]
                        for n in names:
                            if n not in header:
                                if spec.required:
                                    raise InputError("%s:%d: no column '%s' in the header (the map's %s needs it; "
                                                     "the header has: %s)" % (path, line, n, spec.name, ", ".join(header)))
                                if values:
                                    warn("%s: no column '%s': %s left empty" % (path, n, spec.name))
                        if all(n in header for n in names):
                            idx[spec.name] = [header.index(n) for n in names]
                    continue
                if len(row) != len(header):
                    raise InputError("%s:%d: %d fields, the header has %d" % (path, line, len(row), len(header)))
                t = _num(path, line, cmap.time_column, row[t_idx])
                if math.isnan(t):
                    raise InputError("%s:%d: column %s: the time is empty" % (path, line, cmap.time_column))
                t *= cmap.time_scale
                if prev is not None and t <= prev:
                    raise InputError("%s:%d: column %s: time %r s is not after the previous row's %r s"
                                     % (path, line, cmap.time_column, t, prev))
                prev = t
                # Relative times keep their precision in ns; Unix times too (int64 ns reaches 2262).
                t_ns = int(round(t * 1e9))
                vals = {}
                if values:
                    for spec in cmap.columns:
                        ix = idx.get(spec.name)
                        if ix is not None:
                            vals[spec.name] = [_num(path, line, header[i], row[i]) for i in ix]
                yield line, t_ns, vals
        except csv.Error as e:
            raise InputError("%s:%d: %s" % (path, reader.line_num, e)) from None
        except UnicodeDecodeError as e:
            raise InputError("%s: not UTF-8 text (byte %d)" % (path, e.start)) from None
        if header is None:
            raise InputError("%s: no header row" % path)
        if prev is None:
            raise InputError("%s: no data rows after the header" % path)


def scan_csv(path: str, cmap: Map, warn) -> dict[str, TopicScan]:
    """The first pass: the time column as one source's stamps (its silences)."""
    s = TopicScan(TOPIC)
    gap_ns = int(cmap.max_gap_s * 1e9)
    gaps = 0
    for k, (_, t, _) in enumerate(rows(path, cmap, warn, values=False)):
        gaps += s.add(k, t, gap_ns)   # the times increase (rows checks): no step back
        if gaps > MAX_GAPS:
            raise InputError("%s: more than %d silences longer than max_gap_s: not a log of one run" % (path, MAX_GAPS))
    return {TOPIC: s}


def read_values(path: str, cmap: Map, warn, route, problems: Problems, t_ref_ns: int) -> None:
    """The second pass: every mapped value, checked, to route(topic, idx, t, column, v)."""
    specs = cmap.columns
    for k, (line, t_ns, vals) in enumerate(rows(path, cmap, warn, values=True)):
        for spec in specs:
            xs = vals.get(spec.name)
            if xs is None or any(math.isnan(x) for x in xs):
                continue
            problems.seen[spec.name] = problems.seen.get(spec.name, 0) + 1
            why = None
            if spec.quaternion:
                why = quaternion_problem(*xs)
                v = math.nan if why else yaw_of(*xs)
            else:
                v = xs[0]
            if why is None:
                v = v * spec.scale + spec.offset
                why = value_problem(spec.name, v, spec.name in INTEGERS)
            if why is not None:
                problems.add(spec.name, why[0], "%s:%d, t = %.3f s, %s" % (path, line, (t_ns - t_ref_ns) / 1e9, why[1]))
                continue
            route(TOPIC, k, t_ns, spec.name, v)
