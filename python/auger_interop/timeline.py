"""Where a recording cannot be one log: the clock stepped, or every source fell silent.

A clock that steps back (an NTP correction on the robot) makes every topic's stamps go back
together, by the same amount, at the same point of the recording: the stretch after it repeats
times of the stretch before, and sorted by time the two would interleave. A clock that steps
forward, or a recording that stopped, leaves every topic silent at once; on the grid that would
be rows the workbench fills by holding the screw speeds. Neither is ever filled: the import
refuses such a recording with the times, or (--split) writes each stretch as its own log.
A silence of one source only (an IMU dropout) is no step: its rows stay empty.

The input is the first pass's TopicScans (bagscan.py; a CSV is one "topic"); the result is the
list of steps and the segments between them, with each topic's first and last stamp in each.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

from . import InputError
from .bagscan import BACK_STEP_NS, TopicScan


@dataclass
class Step:
    kind: str             # "back" or "silence"
    t_from_ns: int        # back: the latest stamp before it; silence: the last stamp before
    t_to_ns: int          # back: the first stamp after it; silence: the first stamp after
    topics: int = 0       # back: how many topics stepped together
    depth_ns: int = 0     # back: by how much (the fastest topic's drop plus its interval)

    def describe(self, t_ref_ns: int) -> str:
        a, b = (self.t_from_ns - t_ref_ns) / 1e9, (self.t_to_ns - t_ref_ns) / 1e9
        if self.kind == "back":
            return ("the clock steps back by %.2f s at t = %.3f s (%d topics together: stamps %.3f..%.3f s "
                    "come twice)" % (self.depth_ns / 1e9, a, self.topics, b, a))
        return ("every mapped topic is silent for %.3f s, from t = %.3f s to %.3f s (a clock step forward or a "
                "stopped recording)" % (b - a, a, b))


@dataclass
class Segment:
    epoch: int
    lo_ns: float          # stamps in (lo, hi) belong to it
    hi_ns: float
    first: dict[str, int] = field(default_factory=dict)   # topic -> first stamp in it
    last: dict[str, int] = field(default_factory=dict)


@dataclass
class Timeline:
    steps: list[Step]
    segments: list[Segment]
    t_ref_ns: int                                          # the earliest stamp: times in messages count from it
    changes: dict[str, list[int]] = field(default_factory=dict)   # topic -> record index of each epoch change
    holes: list[list[tuple[int, int]]] = field(default_factory=list)  # per epoch: the silences

    def segment_of(self, topic: str, idx: int, t_ns: int) -> int | None:
        """The segment of a message (record index idx, stamp t_ns): its epoch by its place in the
        recording, then the silences before its stamp (None: a stretch nobody writes)."""
        epoch = bisect.bisect_right(self.changes.get(topic, []), idx)
        j = bisect.bisect_left(self._hole_starts[epoch], t_ns)  # silences that start before t
        return self._index.get((epoch, j))

    def __post_init__(self):
        self._index: dict[tuple[int, int], int] = {}
        self._hole_starts: list[list[int]] = []


def _depth(cluster, scans) -> int:
    """A step's size: a topic's last stamp before it is up to one interval early, its first after it
    up to one late; the fastest topic's drop plus its interval is nearest."""
    best = None
    for topic in cluster["events"]:
        m = scans[topic].median_interval_ns()
        if not math.isnan(m) and (best is None or m < best[0]):
            best = (m, topic)
    if best is None:
        return cluster["tb"] - cluster["ta"]
    idx, tb, ta = next(e for e in scans[best[1]].backs if e[0] == cluster["events"][best[1]])
    return int(tb - ta + best[0])


def _pieces(s: TopicScan, runs: list[int]) -> list[tuple[int, int]]:
    """[first, last] stretches of the topic's given runs without a silence longer than max_gap."""
    out = []
    for r in runs:
        run = s.runs[r]
        start = run.first_t
        for a, b, rr in s.gaps:
            if rr == r:
                out.append((start, a))
                start = b
        out.append((start, run.last_t))
    return out


def analyse(scans: dict[str, TopicScan], max_gap_ns: int, where: str) -> Timeline:
    """Clock steps back (clustered across topics), common silences, and the segments."""
    scans = {k: s for k, s in scans.items() if s.runs}
    t_ref = min(s.runs[0].first_t for s in scans.values()) if scans else 0
    # Steps back: one per topic, matched across topics by their stamps before and after.
    events = sorted((idx, topic, tb, ta) for topic, s in scans.items() for idx, tb, ta in s.backs)
    clusters: list[dict] = []
    for idx, topic, tb, ta in events:
        m = scans[topic].median_interval_ns()
        tol = max_gap_ns + (0 if math.isnan(m) else m)
        for c in clusters:
            if topic not in c["events"] and abs(tb - c["tb"]) <= tol and abs(ta - c["ta"]) <= tol:
                c["events"][topic] = idx
                break
        else:
            clusters.append({"pos": idx, "tb": tb, "ta": ta, "events": {topic: idx}})
    steps = []
    for c in clusters:
        depth = c["tb"] - c["ta"]
        for topic, s in scans.items():
            if topic in c["events"] or not s.first_idx < c["pos"] < s.last_idx:
                continue
            m = s.median_interval_ns()
            if not math.isnan(m) and 3 * m < depth - BACK_STEP_NS:
                other = next(iter(c["events"]))
                raise InputError(
                    "%s: topic %s's stamps go back by %.3f s at t = %.3f s, but topic %s's do not: they do not "
                    "share one clock (with clock = \"header\", each source stamps its own; clock = \"receive\" uses "
                    "the recorder's, or leave one of them out of the map)"
                    % (where, other, depth / 1e9, (c["tb"] - t_ref) / 1e9, topic))
        steps.append(Step("back", c["tb"], c["ta"], len(c["events"]), _depth(c, scans)))
    changes = {topic: [c["events"].get(topic, c["pos"]) for c in clusters] for topic in scans}
    # Per epoch: every topic's presence; the holes in their union longer than max_gap are silences.
    n_epochs = len(clusters) + 1
    presence: list[dict[str, list[tuple[int, int]]]] = [dict() for _ in range(n_epochs)]
    for topic, s in scans.items():
        by_epoch: dict[int, list[int]] = {}
        for r, run in enumerate(s.runs):
            by_epoch.setdefault(bisect.bisect_right(changes[topic], run.first_idx), []).append(r)
        for e, runs in by_epoch.items():
            presence[e][topic] = _pieces(s, runs)
    tl = Timeline(steps, [], t_ref, changes)
    for e in range(n_epochs):
        allp = sorted(p for ps in presence[e].values() for p in ps)
        holes = []
        if allp:
            end = allp[0][1]
            for a, b in allp[1:]:
                if a - end > max_gap_ns:
                    holes.append((end, a))
                    steps.append(Step("silence", end, a))
                end = max(end, b)
        tl.holes.append(holes)
        tl._hole_starts.append([a for a, _ in holes])
        bounds = [-math.inf] + [x for h in holes for x in h] + [math.inf]
        for j in range(len(holes) + 1):
            lo, hi = bounds[2 * j], bounds[2 * j + 1]
            seg = Segment(e, lo, hi)
            for topic, ps in presence[e].items():
                inside = [p for p in ps if lo <= p[0] and p[1] <= hi]
                if inside:
                    seg.first[topic] = min(p[0] for p in inside)
                    seg.last[topic] = max(p[1] for p in inside)
            if seg.first:
                tl._index[(e, j)] = len(tl.segments)
                tl.segments.append(seg)
    steps.sort(key=lambda st: st.t_from_ns)
    return tl
