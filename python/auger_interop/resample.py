"""Time series onto the log's uniform grid (100 Hz by default).

The grid starts at the first instant every required column has a sample and ends at the last
such instant, so every row has its screw speeds. Per column (mapping.default_resample):
  linear  interpolated between the samples around a row; headings through the shorter arc and
          wrapped to (-pi, pi]; a row in a gap longer than max_gap_s (a dropout) stays empty;
  hold    the last sample at or before the row (setpoints, status words), empty after a gap;
  sparse  each sample on its nearest row, unchanged (the external pose: rows without a camera
          frame stay empty; the time moves by at most half a period, 5 ms at 100 Hz).
"""

from __future__ import annotations

import math

import numpy as np

from . import InputError
from .bag import Series


def wrap(a):
    """Angles to (-pi, pi]."""
    w = np.mod(np.asarray(a) + math.pi, 2 * math.pi) - math.pi
    return np.where(w == -math.pi, math.pi, w)


def grid(series: dict[str, Series], required: list[str], rate_hz: float, source: str):
    """Row times in ns since the Unix epoch (or the source's zero), and the first one."""
    have = [series[n] for n in required if n in series]
    if not have:
        raise InputError("%s: none of %s has a sample" % (source, ", ".join(required)))
    start = max(int(s.t_ns[0]) for s in have)
    end = min(int(s.t_ns[-1]) for s in have)
    if end <= start:
        raise InputError("%s: the screw speeds never overlap in time (%s)" % (
            source, "; ".join("%s %.3f..%.3f s" % (s.spec.name, s.t_ns[0] / 1e9, s.t_ns[-1] / 1e9) for s in have)))
    period_ns = 1e9 / rate_hz
    n = int(math.floor((end - start) / period_ns + 1e-9)) + 1
    rows_ns = start + np.round(np.arange(n) * period_ns).astype(np.int64)
    return rows_ns, start


def resample(s: Series, rows_ns: np.ndarray, max_gap_s: float) -> np.ndarray:
    """The column's value at each row (NaN = empty)."""
    t, v = s.t_ns, s.values
    out = np.full(len(rows_ns), np.nan)
    if len(t) == 0:
        return out
    gap_ns = max_gap_s * 1e9
    mode = s.spec.resample
    if mode == "sparse":
        period = (rows_ns[-1] - rows_ns[0]) / max(len(rows_ns) - 1, 1) if len(rows_ns) > 1 else 1
        k = np.round((t - rows_ns[0]) / period).astype(np.int64)
        inside = (k >= 0) & (k < len(rows_ns))
        # several samples on one row: the one nearest to the row's time
        dist = np.abs(t - (rows_ns[0] + k * period))
        for kk, vv, dd in sorted(zip(k[inside], v[inside], dist[inside]), key=lambda x: -x[2]):
            out[kk] = vv
        return wrap(out) if s.spec.is_heading else out
    # index of the last sample at or before each row
    i = np.searchsorted(t, rows_ns, side="right") - 1
    if mode == "hold":
        ok = i >= 0
        ok[ok] = (rows_ns[ok] - t[i[ok]]) <= gap_ns
        out[ok] = v[i[ok]]
        return wrap(out) if s.spec.is_heading else out
    # linear
    if s.spec.is_heading:
        v = np.unwrap(v)
    exact = (i >= 0) & (t[np.clip(i, 0, None)] == rows_ns)
    out[exact] = v[i[exact]]
    between = (i >= 0) & (i + 1 < len(t)) & ~exact
    a, b = i[between], i[between] + 1
    ok = (t[b] - t[a]) <= gap_ns
    a, b = a[ok], b[ok]
    rows = np.flatnonzero(between)[ok]
    w = (rows_ns[rows] - t[a]) / (t[b] - t[a])
    out[rows] = v[a] + w * (v[b] - v[a])
    return wrap(out) if s.spec.is_heading else out
