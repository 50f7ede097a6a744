"""Samples onto the log's uniform grid (100 Hz by default), row by row as they arrive.

The grid starts at the first instant every required column (the four screw speeds) has a
sample and ends at the last such instant. Per column (mapping.default_resample):
  sparse  each sample on its nearest row, unchanged (moved by at most half a period, 5 ms at
          100 Hz); the rows between stay empty: "not measured at this sample" (docs/log-format.md),
          so a 5 Hz motor feedback or a 50 Hz IMU is marked as what it is, and the workbench's
          noise floor sees measured samples only. Two samples nearest to one row: the nearer is
          kept (counted). The one exception: row 0 carries each required column's last sample
          before it when none falls on it (the log starts where all four screw speeds are known);
  hold    the last sample at or before the row (setpoints, references, status words: what was
          in force), empty after max_gap_s without one;
  linear  interpolated between the samples around a row (headings along the shorter arc), empty
          across a gap longer than max_gap_s; only where a map asks for it.
Samples arrive in recording order, which is time order up to the recorder's small reorderings;
a row is written once no later sample can reach it (slack_ns behind the newest stamp), so memory
stays a few hundred rows whatever the log's length.
"""

from __future__ import annotations

import bisect
import math

from . import InputError
from .mapping import HEADINGS


def wrap(a: float) -> float:
    """An angle to (-pi, pi]."""
    w = math.fmod(a + math.pi, 2 * math.pi)
    w = w + 2 * math.pi if w < 0 else w
    w -= math.pi
    return math.pi if w == -math.pi else w


class GridBuilder:
    def __init__(self, columns: list[str], modes: dict[str, str], required: list[str], rate_hz: float,
                 max_gap_s: float, start_lb_ns: int, end_ub_ns: int, max_rows: int, slack_ns: int, sink, where: str):
        self.columns, self.modes, self.required = columns, modes, required
        self.col = {c: i for i, c in enumerate(columns)}
        self.headings = [i for i, c in enumerate(columns) if c in HEADINGS]
        self.period = 1e9 / rate_hz
        self.gap_ns = max_gap_s * 1e9
        self.start_lb, self.end_ub, self.max_rows = start_lb_ns, end_ub_ns, max_rows
        self.slack = slack_ns
        self.sink, self.where = sink, where
        self.start: int | None = None
        self.first: dict[str, int] = {}        # required column -> first stamp
        self.last: dict[str, int] = {}         # required column -> last stamp
        self.pre: dict[str, tuple[int, float]] = {}  # column -> its latest sample before the grid
        self.waiting: list[tuple[str, int, float]] = []  # samples until the start is known
        self.rows: dict[int, list] = {}        # row -> [values, distances] not yet written
        self.next_row = 0                      # the first row not yet written
        self.last_row = -1                     # the last row the grid may have (end_ub)
        self.hold: dict[str, list] = {c: [] for c, m in modes.items() if m == "hold"}
        self.held: dict[str, tuple[int, float]] = {}
        self.lin: dict[str, list] = {c: [] for c, m in modes.items() if m == "linear"}
        self.newest = -(1 << 62)
        self._due = math.inf
        self.measured = {c: 0 for c in columns}   # rows with a value written
        self.shared = {c: 0 for c in columns}     # samples that lost their row to a nearer one
        self.late = {c: 0 for c in columns}       # samples whose row was written already
        self.offsets: list[tuple[int, int, list]] = []  # (row, file offset, columns with a value)
        #                                           of the rows that may lie past the grid's end

    # -- input
    def add(self, column: str, t_ns: int, v: float) -> None:
        if column in self.required:
            self.first[column] = min(self.first.get(column, t_ns), t_ns)
            self.last[column] = max(self.last.get(column, t_ns), t_ns)
        self.newest = max(self.newest, t_ns)
        if self.start is None:
            if t_ns < self.start_lb - self.period - self.slack:
                self._pre(column, t_ns, v)
            else:
                self.waiting.append((column, t_ns, v))
            self._try_start()
        else:
            self._place(column, t_ns, v)
            if self.newest >= self._due:
                self._flush(final=False)

    def _pre(self, column, t_ns, v):
        p = self.pre.get(column)
        if p is None or t_ns >= p[0]:
            self.pre[column] = (t_ns, v)

    def _try_start(self):
        if len(self.first) < len(self.required):
            return
        start = max(self.first.values())
        if self.newest < start + self.slack:
            return  # an earlier first sample may still come
        self._begin(start)

    def _begin(self, start):
        self.start = start
        span = self.end_ub - start
        self.last_row = int(round(span / self.period)) if span >= 0 else -1
        if self.last_row + 1 > self.max_rows:
            raise InputError("%s: %d rows at %g Hz (%.1f s), more than max_rows %d" % (
                self.where, self.last_row + 1, 1e9 / self.period, span / 1e9, self.max_rows))
        self.sink.begin(start)
        waiting, self.waiting = self.waiting, []
        for c, t, v in waiting:
            self._place(c, t, v)
        # row 0: each required column's last earlier sample, when none falls on it
        for c in self.required:
            if c in self.pre and self.modes[c] == "sparse":
                t, v = self.pre[c]
                self._put(0, c, v, start - t, count=False)
        for c in self.hold:
            if c in self.pre:
                self.hold[c].insert(0, self.pre[c])
        for c in self.lin:
            if c in self.pre:
                self.lin[c].insert(0, self.pre[c])
        self._flush(final=False)

    def _row_t(self, k: int) -> int:
        return self.start + int(round(k * self.period))

    def _place(self, column, t_ns, v):
        mode = self.modes[column]
        if mode == "sparse":
            k = int(round((t_ns - self.start) / self.period))
            if k < 0:
                self._pre(column, t_ns, v)
            elif k > self.last_row:
                return
            elif k < self.next_row:
                self.late[column] += 1
            else:
                self._put(k, column, v, abs(t_ns - self.start - int(round(k * self.period))))
        elif mode == "hold":
            bisect.insort(self.hold[column], (t_ns, v))
        else:
            bisect.insort(self.lin[column], (t_ns, v))

    def _put(self, k, column, v, dist, count=True):
        row = self.rows.get(k)
        if row is None:
            n = len(self.columns)
            row = self.rows[k] = [[math.nan] * n, [math.inf] * n]
        i = self.col[column]
        if dist < row[1][i]:
            if count and row[1][i] != math.inf and row[1][i] <= self.period / 2:
                self.shared[column] += 1
            row[0][i], row[1][i] = v, dist
        elif count:
            self.shared[column] += 1

    # -- output
    def _ready(self, k: int, final: bool) -> bool:
        if k > self.last_row:
            return False
        if final:
            return True
        rt = self._row_t(k)
        if self.newest < rt + self.period / 2 + self.slack:
            return False
        for samples in self.lin.values():
            if not (samples and samples[-1][0] > rt) and self.newest < rt + self.gap_ns + self.slack:
                return False
        return True

    def _flush(self, final: bool):
        if self.start is None:
            return
        certain_end = min(self.last.values()) if len(self.last) == len(self.required) else -math.inf
        while self._ready(self.next_row, final):
            k = self.next_row
            rt = self._row_t(k)
            values, _ = self.rows.pop(k, (None, None))
            if values is None:
                values = [math.nan] * len(self.columns)
            for c, samples in self.hold.items():
                while samples and samples[0][0] <= rt:
                    self.held[c] = samples.pop(0)
                h = self.held.get(c)
                if h is not None and rt - h[0] <= self.gap_ns:
                    values[self.col[c]] = h[1]
            for c, samples in self.lin.items():
                values[self.col[c]] = self._interp(c, samples, rt)
            for i in self.headings:
                if not math.isnan(values[i]):
                    values[i] = wrap(values[i])
            have = [c for c, v in zip(self.columns, values) if not math.isnan(v)]
            for c in have:
                self.measured[c] += 1
            offset = self.sink.write_row((rt - self.start) / 1e9, values)
            if rt > certain_end:
                self.offsets.append((k, offset, have))
            elif self.offsets:
                self.offsets.clear()
            self.next_row += 1
        self._due = self._row_t(self.next_row) + self.period / 2 + self.slack  # when the next may go

    def _interp(self, c, samples, rt):
        while len(samples) >= 2 and samples[1][0] <= rt:
            samples.pop(0)
        if not samples or samples[0][0] > rt:
            return math.nan
        ta, va = samples[0]
        if ta == rt:
            return va
        if len(samples) < 2 or samples[1][0] - ta > self.gap_ns:
            return math.nan
        tb, vb = samples[1]
        d = vb - va
        if c in HEADINGS:
            d = math.remainder(d, 2 * math.pi)
        return va + (rt - ta) / (tb - ta) * d

    def finish(self) -> int:
        """Writes the rest; the number of rows (0: all four screw speeds never had a sample together)."""
        if self.start is None:
            if len(self.first) < len(self.required):
                return 0
            self._begin(max(self.first.values()))
        end = min(self.last.values())
        end_row = int(round((end - self.start) / self.period))
        self.last_row = min(self.last_row, end_row)
        self._flush(final=True)
        # rows written past the true end (a required column stopped before the pass-one bound)
        cut = [(k, offset, have) for k, offset, have in self.offsets if k > self.last_row]
        if cut:
            self.sink.truncate(cut[0][1])
            for _, _, have in cut:
                for c in have:
                    self.measured[c] -= 1
        return min(self.next_row, self.last_row + 1)
