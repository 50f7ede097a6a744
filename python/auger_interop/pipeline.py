"""One import from source to log(s): first pass, the timeline's verdict, second pass, commit.

Nothing is written until the first pass has settled that the source makes a log (or, with
--split, which logs); every output is written to a temporary file and renamed only when all
of them are complete.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from . import InputError
from .bag import Problems, plan_bag, read_values as bag_values
from .bagscan import BACK_STEP_NS
from .csvsrc import TOPIC, check_map, read_values as csv_values, scan_csv
from .grid import GridBuilder
from .mapping import LOG_COLUMNS, REQUIRED_COLUMNS, Map
from .robotlog import LogWriter, format_t0
from .timeline import analyse

SCREWS = ["omega_rpm_%d" % i for i in range(4)]


@dataclass
class Output:
    path: str
    rows: int = 0
    duration_s: float = 0.0
    measured: dict[str, int] = field(default_factory=dict)   # column -> rows with a value


@dataclass
class Result:
    outputs: list[Output]
    sources: list[dict]          # per topic (bag) or the CSV: samples, rate, columns, modes
    notes: list[str]
    steps: list[str]             # the clock steps and silences --split cut at
    terrain: str | None


def is_bag(path: Path) -> bool:
    return path.is_dir() or path.suffix in (".db3", ".mcap")


def split_name(out: str, k: int) -> str:
    p = Path(out)
    return str(p.with_name("%s-%d%s" % (p.stem, k, p.suffix)))


class _Sink:
    """The grid's rows into one LogWriter; the header when the grid's start (t0) is known."""

    def __init__(self, writer: LogWriter, meta: dict, columns: list[str], unix_time: bool):
        self.writer, self.meta, self.columns, self.unix_time = writer, meta, columns, unix_time

    def begin(self, start_ns: int):
        meta = dict(self.meta)
        if self.unix_time:
            meta["t0_unix_s"] = format_t0(start_ns)
        self.writer.header(meta, self.columns)

    def write_row(self, t_s, values):
        return self.writer.write_row(t_s, values)

    def truncate(self, offset):
        self.writer.truncate(offset)


def _span(where, rows, rate_hz, span_ns, cmap):
    return ("%s: the four screw speeds span %.1f s (%.1f h): %d rows at %g Hz, more than max_rows %d (a map's "
            "max_rows raises it)" % (where, span_ns / 1e9, span_ns / 3.6e12, rows, rate_hz, cmap.max_rows))


def run_import(src: Path, out: str, cmap: Map, terrain: str | None, split: bool, user_msgs: dict, warn) -> Result:
    bag = is_bag(src)
    notes: list[str] = []
    plan = None
    if bag:
        plan = plan_bag(str(src), cmap, user_msgs, warn)
        scans = plan.scans
        notes += plan.notes
    else:
        check_map(cmap)
        scans = scan_csv(str(src), cmap, warn)
    try:
        return _run(src, out, cmap, terrain, split, warn, bag, plan, scans, notes)
    finally:
        if plan is not None:
            plan.reader.close()


def _run(src, out, cmap, terrain, split, warn, bag, plan, scans, notes):
    where = str(src)
    max_gap_ns = int(cmap.max_gap_s * 1e9)
    tl = analyse(scans, max_gap_ns, where)
    mapped = {c.name: (c.topic if bag else TOPIC) for c in cmap.columns}
    if bag:
        mapped = {c: t for c, t in mapped.items() if t in plan.specs_by_topic}
    req_topics = {mapped[c] for c in SCREWS if c in mapped}
    period = 1e9 / cmap.rate_hz
    usable = []   # (segment index, start bound, end bound)
    skipped = []
    for i, seg in enumerate(tl.segments):
        if not all(t in seg.first for t in req_topics):
            why = "has no message of " + ", ".join(sorted(t for t in req_topics if t not in seg.first))
        elif min(seg.last[t] for t in req_topics) <= max(seg.first[t] for t in req_topics):
            why = "the screw speeds never overlap in it"
        else:
            usable.append((i, max(seg.first[t] for t in req_topics), min(seg.last[t] for t in req_topics)))
            continue
        a, b = min(seg.first.values()), max(seg.last.values())
        skipped.append("from t = %.3f s to %.3f s: %s" % ((a - tl.t_ref_ns) / 1e9, (b - tl.t_ref_ns) / 1e9, why))
    if split and skipped:
        warn("%s: %d stretch%s not written, without all four screw speeds (%s%s)" % (
            where, len(skipped), "es" if len(skipped) > 1 else "", "; ".join(skipped[:3]),
            "; ..." if len(skipped) > 3 else ""))
    # A screw speed silent while other sources go on: the workbench holds the last one through it.
    holes = [h for hs in tl.holes for h in hs]
    for t in sorted(req_topics):
        quiet = [(a, b) for a, b, _ in scans[t].gaps if not any(a <= ha and hb <= b for ha, hb in holes)]
        if quiet:
            a, b = max(quiet, key=lambda g: g[1] - g[0])
            warn("%s: topic %s is silent %d times for longer than max_gap_s while other topics go on (the longest "
                 "%.3f s, from t = %.3f s); the workbench holds the last screw speed through such a gap"
                 % (where, t, len(quiet), (b - a) / 1e9, (a - tl.t_ref_ns) / 1e9))
    steps = [s.describe(tl.t_ref_ns) for s in tl.steps]
    if len(tl.segments) > 1 and not split:
        first = min(s.runs[0].first_t for s in scans.values())
        last = max(r.last_t for s in scans.values() for r in s.runs)
        rows = int(round((last - first) / period)) + 1
        span = ("its mapped topics span %.1f s (%.1f h: %d rows at %g Hz%s), and " % (
            (last - first) / 1e9, (last - first) / 3.6e12, rows, cmap.rate_hz, ", more than max_rows %d"
            % cmap.max_rows if rows > cmap.max_rows else "")) if rows > cmap.max_rows or len(steps) > 3 else ""
        shown = steps
        if len(steps) > 3:
            backs = [st for st in tl.steps if st.kind == "back"]
            quiet = [st for st in tl.steps if st.kind == "silence"]
            longest = max(quiet, key=lambda st: st.t_to_ns - st.t_from_ns, default=None)
            shown = (["the clock steps back %d times (the first: %s)" % (len(backs), backs[0].describe(tl.t_ref_ns))]
                     if backs else []) + (["every mapped topic falls silent %d times for longer than max_gap_s = "
                                           "%g s (the longest: %s)" % (len(quiet), cmap.max_gap_s,
                                                                       longest.describe(tl.t_ref_ns))] if quiet else [])
        raise InputError("%s: cannot be one log: %s%s (times in s after the first mapped message). Nothing is "
                         "filled in or interleaved: --split writes each stretch between them as a log of its own "
                         "(%s, %s, ...)" % (where, span, "; ".join(shown), split_name(out, 1), split_name(out, 2)))
    if not usable:
        if len(tl.segments) == 1 and tl.segments[0].first and all(t in tl.segments[0].first for t in req_topics):
            seg = tl.segments[0]
            raise InputError("%s: the screw speeds never overlap in time (%s)" % (where, "; ".join(
                "%s %.3f..%.3f s" % (t, (seg.first[t] - tl.t_ref_ns) / 1e9, (seg.last[t] - tl.t_ref_ns) / 1e9)
                for t in sorted(req_topics))))
        raise InputError("%s: no stretch has all four screw speeds" % where)
    for i, start, end in usable:
        rows = int(round((end - start) / period)) + 1
        if rows > cmap.max_rows:
            raise InputError(_span(where if len(usable) == 1 else "%s (stretch %d)" % (where, i + 1),
                                   rows, cmap.rate_hz, end - start, cmap))

    # The log's columns: every mapped one and the format's required ones, in the format's order.
    names = [c.name for c in cmap.columns]
    columns = [c for c in LOG_COLUMNS if c in names or c in REQUIRED_COLUMNS] + [c for c in names if c not in LOG_COLUMNS]
    modes = {c: "sparse" for c in columns}
    modes.update({c.name: c.resample for c in cmap.columns})
    meta: dict[str, str] = {}
    if terrain:
        meta["terrain"] = terrain
    for k, v in cmap.metadata.items():
        meta.setdefault(k, v)
    multi = len(usable) > 1
    builders, outputs, writers = {}, [], []
    slack = max(BACK_STEP_NS, max_gap_ns)
    try:
        for n, (i, start, end) in enumerate(usable, 1):
            path = split_name(out, n) if multi else out
            m = dict(meta)
            m["source"] = "auger import of %s%s" % (src.name, " (stretch %d of %d, --split)" % (n, len(usable))
                                                     if multi else "")
            w = LogWriter(path)
            writers.append(w)
            outputs.append(Output(path))
            builders[i] = GridBuilder(columns, modes, SCREWS, cmap.rate_hz, cmap.max_gap_s, start, end, cmap.max_rows,
                                      slack, _Sink(w, m, columns, bag or cmap.time_unix), path)

        def route(topic, idx, t_ns, column, v):
            b = builders.get(tl.segment_of(topic, idx, t_ns))
            if b is not None:
                b.add(column, t_ns, v)

        if len(tl.segments) == 1:  # one log: every value goes to it
            only = builders[usable[0][0]]

            def route(topic, idx, t_ns, column, v):  # noqa: F811
                only.add(column, t_ns, v)

        problems = Problems()
        if bag:
            undecoded, ids_notes = bag_values(plan, where, cmap, route, problems, tl.t_ref_ns)
            for u in undecoded:
                warn(u)
            notes += ids_notes
        else:
            csv_values(where, cmap, warn, route, problems, tl.t_ref_ns)
        spec_of = {c.name: c for c in cmap.columns}
        for w in problems.warnings(lambda c: spec_of[c].where()):
            warn("%s: %s" % (where, w))
        for (i, _, _), o in zip(usable, outputs):
            b = builders[i]
            rows = b.finish()
            if rows < 3:
                missing = [spec_of[c] for c in SCREWS if c not in b.first]
                raise InputError("%s: %s" % (o.path if multi else where, "; ".join(
                    ("no message matches %s (column %s)" if c.match else "no value at %s (column %s)")
                    % (c.where(), c.name) for c in missing) if missing else
                    "the four screw speeds have fewer than 3 rows together"))
            o.rows, o.duration_s = rows, (rows - 1) / cmap.rate_hz
            o.measured = {c: n for c, n in b.measured.items()}
            for c in columns:
                if b.late[c]:
                    warn("%s: column %s: %d samples came more than %.1f s after newer ones: left out"
                         % (where, c, b.late[c], slack / 1e9))
            shared = {c: k for c, k in b.shared.items() if k}
            if shared:
                notes.append("%s: samples sharing a row with a nearer one (one value per row): %s" % (
                    o.path, ", ".join("%s %d" % kv for kv in shared.items())))
        for spec in cmap.columns:
            if spec.required and not any(o.measured.get(spec.name) for o in outputs):
                raise InputError("%s: no value for column %s (%s)" % (where, spec.name, spec.where()))
        for w in writers:
            w.commit()
    except BaseException:
        for w in writers:
            w.abort()
        raise
    sources = []
    by_topic: dict[str, list[str]] = {}
    for c in cmap.columns:
        if c.name in mapped:
            by_topic.setdefault(mapped[c.name], []).append(c.name)
    for topic, cols in by_topic.items():
        s = scans.get(topic)
        if s is None:
            continue
        sources.append({"source": topic if bag else "%s (the CSV rows)" % src.name, "samples": s.count,
                        "rate_hz": s.rate_hz(), "columns": cols,
                        "modes": sorted({modes[c] for c in cols})})
    return Result(outputs, sources, notes, steps if multi else [], meta.get("terrain"))
