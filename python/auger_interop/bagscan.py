"""Opening a bag, and its messages in the order they were recorded.

The `rosbags` reader gives a bag's messages sorted by time stamp, which hides a clock that
stepped back (two stretches of time come out interleaved). Here the messages come in the order
the recorder wrote them: sqlite3's row ids, the MCAP file's own order (rosbags' storage objects,
pinned in python/requirements.txt; the tests write both storages). The first pass over them
(scan) reads only time stamps and keeps a fixed amount per topic, so that clock steps, the
grid's size and the types are settled before anything is decoded or written.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

from rosbags.rosbag2 import Reader
from rosbags.rosbag2.storage_sqlite3 import Sqlite3Reader

from . import InputError

if sys.version_info >= (3, 14):
    from compression import zstd
else:
    from backports import zstd

BACK_STEP_NS = 100_000_000    # a stamp this much before its topic's latest: the clock went back
TYPE_SAMPLES = 20             # messages per connection a type is tried on (bagtypes.py)
MAX_BACKS = 1000              # steps back of one topic's stamps: more is no clock at all


def open_bag(path: str):
    """An opened rosbags Reader (close it), or InputError naming the file and what is wrong."""
    p = Path(path)
    if p.is_dir() and not (p / "metadata.yaml").exists():
        raise InputError("%s: not a rosbag2 folder (no metadata.yaml); give the bag's folder or its .db3 "
                         "or .mcap file" % path)
    if not p.is_dir() and not p.is_file():
        raise InputError("%s: not a regular file (a bag is a folder, a .db3 or an .mcap file)" % path)
    try:
        reader = Reader(p)
        reader.open()
    except FileNotFoundError as e:
        raise InputError("%s: %s" % (path, e)) from None
    except Exception as e:  # rosbags raises several kinds on a file that is cut short or not a bag
        files = sorted(p.glob("*.mcap")) if p.is_dir() else [p] if p.suffix == ".mcap" else []
        why = next((w for w in map(_mcap_problem, files) if w), None)
        raise InputError("%s: not a readable ROS 2 bag: %s" % (path, why or _reason(e))) from None
    return reader


MCAP_MAGIC = b"\x89MCAP0\r\n"


def _mcap_problem(f: Path) -> str | None:
    """What is wrong with an MCAP file's frame (None: nothing seen here)."""
    try:
        size = f.stat().st_size
        with open(f, "rb") as fh:
            head = fh.read(8)
            fh.seek(max(size - 8, 0))
            tail = fh.read(8)
    except OSError as e:
        return "%s: %s" % (f, e.strerror or e)
    if head != MCAP_MAGIC:
        return "%s does not start with the MCAP magic bytes: not an MCAP file" % f.name
    if size < 8 + 9 + 37 or tail != MCAP_MAGIC:
        return ("%s (%d bytes) ends without the MCAP footer: the file is cut short (a recorder killed, a full "
                "disk, a copy not finished); the messages before the cut are not read" % (f.name, size))
    return None


def _reason(e: Exception) -> str:
    return str(e) or type(e).__name__


def list_topics(path: str) -> list[tuple[str, str, int]]:
    """(topic, type, message count) of every topic in the bag."""
    reader = open_bag(path)
    try:
        return sorted((name, info.msgtype or "(several types)", info.msgcount) for name, info in reader.topics.items())
    finally:
        reader.close()


def in_record_order(reader, conns, path: str):
    """(connection, receive stamp in ns, raw CDR bytes) of the connections' messages, in the
    order they were recorded (file by file for a split bag)."""
    storage = reader.storage
    storages = getattr(storage, "storages", [storage])
    compressed = getattr(storage, "metadata", None) is not None and storage.metadata.compression_mode == "message"
    try:
        for st in storages:
            connmap = {}
            for x in st.connections:
                for c in conns:
                    if c.topic == x.topic and c.msgtype == x.msgtype:
                        connmap[x.id] = c
            if not connmap:
                continue
            if isinstance(st, Sqlite3Reader):
                ids = sorted(connmap)
                rows = st.dbconn.execute(
                    "SELECT topic_id, timestamp, data FROM messages WHERE topic_id IN (%s) ORDER BY id"
                    % ",".join("?" * len(ids)), ids)
                for cid, t, data in rows:
                    yield connmap[cid], t, zstd.decompress(data) if compressed else data
            else:
                mine = [x for x in st.connections if x.id in connmap]
                for x, t, data in st.messages_scan(mine):
                    yield connmap[x.id], t, zstd.decompress(data) if compressed else data
    except InputError:
        raise
    except Exception as e:  # a storage file that is corrupt past its index
        raise InputError("%s: reading the messages failed: %s" % (path, _reason(e))) from None


def header_stamp(raw) -> int | None:
    """header.stamp in ns of a message whose first field is a std_msgs/Header (checked by the
    caller against the type): the first 8 bytes after the CDR encapsulation."""
    if len(raw) < 12:
        return None
    order = "little" if raw[1] else "big"
    sec = int.from_bytes(raw[4:8], order, signed=True)
    nsec = int.from_bytes(raw[8:12], order)
    return sec * 1_000_000_000 + nsec


@dataclass
class Run:
    """A stretch of a topic's messages between two steps back of its clock."""
    first_idx: int        # record index of its first message
    first_t: int
    last_t: int
    count: int = 1


@dataclass
class TopicScan:
    """What the first pass keeps of one topic: O(runs + gaps), not O(messages)."""
    topic: str
    count: int = 0
    first_idx: int = -1
    last_idx: int = -1
    runs: list[Run] = field(default_factory=list)
    gaps: list[tuple[int, int, int]] = field(default_factory=list)   # (t_a, t_b, run) silences > max_gap
    backs: list[tuple[int, int, int]] = field(default_factory=list)  # (record index, t before, t after)
    samples: dict[int, list[bytes]] = field(default_factory=dict)    # connection id -> first messages
    intervals: dict[int, int] = field(default_factory=dict)          # log2-binned histogram of intervals
    stampless: int = 0                                               # messages too short for a header

    def add(self, idx: int, t: int, max_gap_ns: int) -> int:
        """One stamp (record index idx); the number of silences it ends (0 or 1).
        OverflowError after MAX_BACKS steps back."""
        self.count += 1
        self.last_idx = idx
        if not self.runs:
            self.first_idx = idx
            self.runs.append(Run(idx, t, t))
            return 0
        run = self.runs[-1]
        if t < run.last_t - BACK_STEP_NS:
            self.backs.append((idx, run.last_t, t))
            self.runs.append(Run(idx, t, t))
            if len(self.backs) > MAX_BACKS:
                raise OverflowError
            return 0
        dt = t - run.last_t
        if dt > 0:
            b = int(math.log2(dt) * 8)
            self.intervals[b] = self.intervals.get(b, 0) + 1
        gap = dt > max_gap_ns
        if gap:
            self.gaps.append((run.last_t, t, len(self.runs) - 1))
        run.last_t = max(run.last_t, t)
        run.count += 1
        return int(gap)

    def rate_hz(self) -> float | None:
        """Messages per second while the topic is not silent (its runs less its gaps)."""
        busy = sum(r.last_t - r.first_t for r in self.runs) - sum(b - a for a, b, _ in self.gaps)
        n = self.count - len(self.runs) - len(self.gaps)
        return n / (busy / 1e9) if busy > 0 and n > 0 else None

    def median_interval_ns(self) -> float:
        """The topic's typical interval (from the histogram: within 9 %), NaN with < 2 messages."""
        n = sum(self.intervals.values())
        if n == 0:
            return math.nan
        acc = 0
        for b in sorted(self.intervals):
            acc += self.intervals[b]
            if 2 * acc >= n:
                return 2.0 ** ((b + 0.5) / 8)
        return math.nan


def scan(reader, conns, path: str, clock: str, max_gap_ns: int, max_gaps: int) -> dict[str, TopicScan]:
    """The first pass: per topic, its runs (split where its clock steps back), its silences longer
    than max_gap_ns, and the first messages of each connection."""
    scans: dict[str, TopicScan] = {}
    gaps = 0
    for idx, (conn, t_rx, raw) in enumerate(in_record_order(reader, conns, path)):
        s = scans.get(conn.topic)
        if s is None:
            s = scans[conn.topic] = TopicScan(conn.topic)
        smp = s.samples.setdefault(conn.id, [])
        if len(smp) < TYPE_SAMPLES:
            smp.append(bytes(raw))
        if clock == "header":
            t = header_stamp(raw)
            if t is None:
                s.stampless += 1
                continue
        else:
            t = t_rx
        try:
            gaps += s.add(idx, t, max_gap_ns)
        except OverflowError:
            raise InputError("%s: topic %s: its time stamps go back more than %d times; not a clock that "
                             "stepped but a source without one clock" % (path, conn.topic, MAX_BACKS)) from None
        if gaps > max_gaps:
            raise InputError("%s: more than %d silences longer than max_gap_s in the mapped topics: "
                             "not a log of one run" % (path, max_gaps))
    return scans
