"""`auger import` (the C++ front runs `python -m auger_interop import ...` in the project's venv).

Exit codes as every auger subcommand: 0 done, 2 bad usage or bad input (message on stderr).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

from . import InputError
from .mapping import LOG_COLUMNS, REQUIRED_COLUMNS, load_map
from .resample import grid, resample
from .robotlog import format_t0, write_log

USAGE = "auger import SOURCE --out LOG.csv [--map FILE] [--terrain NAME] [--list-topics]"
DESCRIPTION = """\
A ROS 2 bag (a rosbag2 folder, or one .db3 or .mcap file) or another program's CSV into a
robot log (docs/log-format.md), resampled onto the 100 Hz grid. Bags: by default the research
group's topics and types (Centre-for-Biorobotics/rm3_ros_packages; the map
python/auger_interop/maps/robominer.toml); --map FILE for other robots. CSV: --map FILE names
the time column and maps, renames and scales the columns. docs/formats.md explains the map.
"""


def is_bag(path: Path) -> bool:
    return path.is_dir() or path.suffix in (".db3", ".mcap")


def run_import(args, warn) -> int:
    src = Path(args.source)
    if not src.exists():
        raise InputError("%s: no such file or folder" % src)
    if args.list_topics:
        from .bag import list_topics
        if not is_bag(src):
            raise InputError("%s: --list-topics is for bags (a folder, .db3 or .mcap)" % src)
        for topic, typ, count in list_topics(str(src)):
            print("%-40s %-45s %8d messages" % (topic, typ, count))
        return 0
    if not args.out:
        raise InputError("--out LOG.csv is required")
    if not is_bag(src) and args.map is None:
        raise InputError("%s: a CSV import needs --map FILE (its time column and what each column "
                         "becomes; docs/formats.md)" % src)
    cmap = load_map(args.map)
    notes: list[str] = []
    if is_bag(src):
        from .bag import read_bag
        series, notes = read_bag(str(src), cmap, warn)
        unix_time = True
    else:
        from .csvsrc import read_csv
        series, unix_time = read_csv(str(src), cmap, warn)
    required = ["omega_rpm_%d" % i for i in range(4)]
    rows_ns, start_ns = grid(series, required, cmap.rate_hz, str(src))
    t_s = (rows_ns - start_ns) / 1e9
    data = {}
    for name, s in series.items():
        data[name] = resample(s, rows_ns, cmap.max_gap_s)
    # every mapped column and the format's required ones, in the format's order, extras after
    mapped = [c.name for c in cmap.columns]
    columns = [c for c in LOG_COLUMNS if c in mapped or c in REQUIRED_COLUMNS]
    columns += [c for c in mapped if c not in LOG_COLUMNS]
    for c in columns:
        if c not in data:
            data[c] = np.full(len(rows_ns), np.nan)
    meta = {}
    if args.terrain:
        meta["terrain"] = args.terrain
    for k, v in cmap.metadata.items():
        meta.setdefault(k, v)
    if unix_time:
        meta["t0_unix_s"] = format_t0(start_ns)
    meta["source"] = "auger import of %s" % src.name
    write_log(args.out, meta, columns, t_s, data)

    pose_rows = int(np.sum(~np.isnan(data["x_m"])))
    print("auger import: %s -> %s: %d rows at %g Hz (%.2f s), %d of them with a pose"
          % (src, args.out, len(t_s), cmap.rate_hz, t_s[-1] if len(t_s) else 0.0, pose_rows))
    # one line per source: its rate and the columns it fed
    by_source: dict[str, list[str]] = {}
    for c in cmap.columns:
        if c.name in series:
            key = c.topic if c.topic is not None else c.where()
            by_source.setdefault(key, []).append(c.name)
    for key, names in by_source.items():
        s = series[names[0]]
        span_s = (s.t_ns[-1] - s.t_ns[0]) / 1e9
        rate = "%.1f Hz" % ((len(s.t_ns) - 1) / span_s) if span_s > 0 else "1 sample"
        modes = sorted({series[n].spec.resample for n in names})
        print("  %s: %d samples (%s) -> %s (%s)" % (key, len(s.t_ns), rate, ", ".join(names), ", ".join(modes)))
    for n in notes:
        print("  note: " + n)
    if "terrain" not in meta:
        print("  no terrain given: the workbench will assume sand (add --terrain NAME)")
    print("next: auger compare %s" % args.out)
    return 0


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] != "import":
        print("usage: " + USAGE, file=sys.stderr)
        return 2
    p = argparse.ArgumentParser(prog="auger import", usage=USAGE, description=DESCRIPTION,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("source", help="bag folder, .db3 or .mcap file, or CSV file")
    p.add_argument("--out", help="the robot log to write (replaced only when complete)")
    p.add_argument("--map", help="map file (TOML); default for bags: the group's topics")
    p.add_argument("--terrain", help="the log's terrain metadata (sand, frozen_grass, gravel, ...)")
    p.add_argument("--list-topics", action="store_true", help="list the bag's topics, types and counts")
    try:
        args = p.parse_args(argv[1:])
    except SystemExit as e:  # argparse: 0 for --help, 2 for bad usage
        return int(e.code or 0)
    if args.terrain is not None and ("\n" in args.terrain or not args.terrain.strip()):
        print("auger import: --terrain must be one non-empty line", file=sys.stderr)
        return 2

    def warn(msg):
        print("auger import: warning: " + msg, file=sys.stderr)

    try:
        return run_import(args, warn)
    except InputError as e:
        print("auger import: %s" % e, file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # the output piped into `head`
        sys.stderr.close()
        return 0


if __name__ == "__main__":
    sys.exit(main())
