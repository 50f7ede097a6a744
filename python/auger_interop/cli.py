"""`auger import` (the C++ front runs `python -m auger_interop import ...` in the project's venv).

Exit codes as every auger subcommand: 0 done, 2 bad usage or bad input (message on stderr).
--json: one JSON object on stdout (warnings also in it, and on stderr as always).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from . import InputError
from .mapping import load_map
from .pipeline import Result, is_bag, run_import

USAGE = ("auger import SOURCE --out LOG.csv [--map FILE] [--terrain NAME] [--msg TYPE=FILE]... [--split] [--json]\n"
         "       auger import BAG --list-topics [--json]")
DESCRIPTION = """\
A ROS 2 bag (a rosbag2 folder, or one .db3 or .mcap file) or another program's CSV into a
robot log (docs/log-format.md) on the 100 Hz grid: each measured sample on its nearest row, the
rows between empty ("not measured"). Bags: by default the research group's topics and types
(Centre-for-Biorobotics/rm3_ros_packages; the map python/auger_interop/maps/robominer.toml);
--map FILE for other robots. CSV: --map FILE names the time column and maps, renames and scales
the columns. A source whose clock steps, or whose every topic falls silent, is refused with the
times (--split: one log per stretch). docs/formats.md explains the map and every case.
"""


def _next(result: Result) -> str:
    o = result.outputs[0]
    more = (" (each stretch is a log of its own: %s)" % ", ".join(x.path for x in result.outputs)
            if len(result.outputs) > 1 else "")
    if all(x.measured.get("x_m", 0) >= 10 or x.measured.get("y_m", 0) >= 10 for x in result.outputs):
        return "auger compare %s%s" % (o.path, more)
    return ("auger merge %s CAMERA_LOG --out merged.csv (the log has no pose, which compare, diagnose and explain "
            "need: a pose log recorded elsewhere brings it, docs/workbench-tools.md), or auger export %s --mcap "
            "%s (its channels in Foxglove or PlotJuggler)%s" % (o.path, o.path, Path(o.path).with_suffix(".mcap"), more))


def _text(src, result: Result, rate_hz: float, warnings: list[str]):
    for o in result.outputs:
        print("auger import: %s -> %s: %d rows at %g Hz (%.2f s), %d of them with a pose"
              % (src, o.path, o.rows, rate_hz, o.duration_s, o.measured.get("x_m", 0)))
    for s in result.sources:
        rate = "%.1f Hz" % s["rate_hz"] if s["rate_hz"] else "1 sample"
        print("  %s: %d samples (%s) -> %s (%s)" % (s["source"], s["samples"], rate, ", ".join(s["columns"]),
                                                   ", ".join(s["modes"])))
    for st in result.steps:
        print("  split where " + st)
    for n in result.notes:
        print("  note: " + n)
    if result.terrain is None:
        print("  terrain: not known (no --terrain, none in the source): no `# terrain:` line written")
    print("next: " + _next(result))


def _json(src, result: Result, rate_hz: float, warnings: list[str]):
    doc = {
        "command": "import", "source": str(src),
        "outputs": [{"out": o.path, "rows": o.rows, "rate_hz": rate_hz, "duration_s": o.duration_s,
                     "rows_with_pose": o.measured.get("x_m", 0), "rows_measured": o.measured} for o in result.outputs],
        "terrain": result.terrain, "sources": result.sources, "split_at": result.steps, "notes": result.notes,
        "warnings": warnings, "next": _next(result),
    }
    print(json.dumps(doc))


def run(args, warn, warnings) -> int:
    src = Path(args.source)
    if not src.exists():
        raise InputError("%s: no such file or folder" % src)
    if args.list_topics:
        from .bagscan import list_topics
        if not is_bag(src):
            raise InputError("%s: --list-topics is for bags (a folder, .db3 or .mcap)" % src)
        topics = list_topics(str(src))
        if args.json:
            print(json.dumps({"command": "import", "source": str(src), "topics": [
                {"topic": t, "type": ty, "messages": n} for t, ty, n in topics]}))
        else:
            for topic, typ, count in topics:
                print("%-40s %-45s %8d messages" % (topic, typ, count))
        return 0
    if not args.out:
        raise InputError("--out LOG.csv is required")
    if not is_bag(src) and args.map is None:
        raise InputError("%s: a CSV import needs --map FILE (its time column and what each column "
                         "becomes; docs/formats.md)" % src)
    cmap = load_map(args.map)
    user_msgs = {k: ("%s [msg]" % cmap.path, v) for k, v in cmap.msg.items()}
    if args.msg:
        from .bagtypes import parse_msg_option
        for m in args.msg:
            typ, text = parse_msg_option(m)
            user_msgs[typ] = ("--msg %s" % m, text)
    terrain = args.terrain or cmap.metadata.get("terrain")
    result = run_import(src, args.out, cmap, terrain, args.split, user_msgs, warn)
    if terrain is None:
        warn("%s: no terrain given, and the source records none: the log says nothing of it, and the workbench "
             "analyses it with the paper's parameters for sand until told; --terrain NAME (sand, frozen_grass, "
             "gravel, ...) when you know it" % src)
    (_json if args.json else _text)(src, result, cmap.rate_hz, warnings)
    return 0


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] != "import":
        print("usage: " + USAGE, file=sys.stderr)
        return 2
    p = argparse.ArgumentParser(prog="auger import", usage=USAGE, description=DESCRIPTION,
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog="Exit 0: written; 2: bad usage or input (nothing written, an existing "
                                       "output kept).")
    p.add_argument("source", help="bag folder, .db3 or .mcap file, or CSV file")
    p.add_argument("--out", help="the robot log to write (replaced only when complete)")
    p.add_argument("--map", help="map file (TOML); default for bags: the group's topics")
    p.add_argument("--terrain", help="the log's terrain metadata (sand, frozen_grass, gravel, ...); without it "
                                     "the log names none")
    p.add_argument("--msg", action="append", metavar="TYPE=FILE",
                   help="the .msg definition of a type the bag does not carry (again for each type)")
    p.add_argument("--split", action="store_true",
                   help="where the clock steps or every topic falls silent, write each stretch as its own log "
                        "(OUT-1.csv, OUT-2.csv, ...)")
    p.add_argument("--list-topics", action="store_true", help="list the bag's topics, types and counts")
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    try:
        args = p.parse_args(argv[1:])
    except SystemExit as e:  # argparse: 0 for --help, 2 for bad usage
        return int(e.code or 0)
    if args.terrain is not None and ("\n" in args.terrain or not args.terrain.strip()):
        print("auger import: --terrain must be one non-empty line", file=sys.stderr)
        return 2
    warnings: list[str] = []

    def warn(msg):
        warnings.append(msg)
        print("auger import: warning: " + msg, file=sys.stderr)

    try:
        return run(args, warn, warnings)
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
