#!/usr/bin/env python3
"""make demo's field part (scripts/demo.sh): for each run of augerd across a field, the true
changes of the ground under the screws (the simulator's truth log), when augerd's [online]
detector flagged a change (its log's on_change column) and the delay, and what augerd believed
the ground was (its event log's terrain-believed events, once a second).

  scripts/demo-field.py RUN_DIR...

A RUN_DIR holds sim.out (the simulator's start in Unix time), truth.csv (the truth log with the
ground columns), logs/augerd-*.csv and logs/*-events.log (augerd's). Standard library only.
"""
import csv
import glob
import os
import re
import sys


def fail(msg):
    sys.exit(f"demo-field: {msg}")


def read_csv(path):
    """Metadata (# key: value) and rows (dicts of str) of a CSV log."""
    meta, lines = {}, []
    with open(path, newline="") as f:
        for line in f:
            if line.startswith("#"):
                k, _, v = line[1:].partition(":")
                meta[k.strip()] = v.strip()
            else:
                lines.append(line)
    return meta, list(csv.DictReader(lines))


def sim_t0(run):
    path = os.path.join(run, "sim.out")
    with open(path) as f:
        for line in f:
            m = re.search(r"simulated t = 0 s at unix time ([0-9.]+) s", line)
            if m:
                return float(m.group(1))
    fail(f"{path}: no 'simulated t = 0 s at unix time' line (auger-sim-robot too old?)")


def true_changes(run, shift_s):
    """(t_s on augerd's clock, contacts on each terrain) at each change of the ground under the
    four screws' contacts; a pair of contacts crossing an edge together (within 0.5 s) is one
    change, at the first of them, with the ground after the last."""
    path = os.path.join(run, "truth.csv")
    meta, rows = read_csv(path)
    if not rows or "terrain_id_0" not in rows[0]:
        fail(f"{path}: no terrain_id_0..3 columns (the simulator was not given a field)")
    names = dict(p.split("=", 1) for p in meta.get("terrain_ids", "").split())
    out, prev = [], None
    for r in rows:
        ids = tuple(int(float(r[f"terrain_id_{k}"])) for k in range(4))
        if prev is not None and ids != prev:
            counts = {}
            for i in ids:
                counts[names.get(str(i), str(i))] = counts.get(names.get(str(i), str(i)), 0) + 1
            what = ", ".join(f"{n} {c} of 4" for n, c in sorted(counts.items()))
            t = float(r["t_s"]) + shift_s
            if out and t - out[-1][2] < 0.5:
                out[-1] = (out[-1][0], what, t)
            else:
                out.append((t, what, t))
        prev = ids
    return [(t, what) for t, what, _ in out]


def main(runs):
    if not runs:
        fail("usage: scripts/demo-field.py RUN_DIR...")
    for run in runs:
        logs = sorted(glob.glob(os.path.join(run, "logs", "augerd-*.csv")))
        events = glob.glob(os.path.join(run, "logs", "*-events.log"))
        if not logs or not events:
            fail(f"{run}: no augerd log or event log under {run}/logs")
        meta, rows = read_csv(logs[0])
        for extra in logs[1:]:  # rotated files continue the same clock
            rows += read_csv(extra)[1]
        if "on_change" not in rows[0]:
            fail(f"{logs[0]}: no on_change column ([online] not enabled?)")
        shift_s = sim_t0(run) - float(meta["t0_unix_s"])
        changes = true_changes(run, shift_s)
        alarms = [float(r["t_s"]) for r in rows if r["on_change"] == "1"]
        believed = []
        with open(events[0]) as f:
            for line in f:
                m = re.search(r't_s=([0-9.]+) .*event=terrain-believed action="the estimate is closest to ([^"]*)"', line)
                if m:
                    believed.append((float(m.group(1)), m.group(2).split(",")[0]))
        end_s = float(rows[-1]["t_s"])
        print(f"{os.path.basename(run)}: {len(changes)} changes of the ground under the screws, "
              f"{len(alarms)} alarms of augerd's detector in {end_s:.0f} s")
        print("  | true change (augerd's clock) | ground now | first alarm before the next change | delay "
              "| believed before the next change |")
        print("  |---|---|---|---|---|")
        matched = set()
        for i, (t, what) in enumerate(changes):
            t_next = changes[i + 1][0] if i + 1 < len(changes) else end_s
            hit = next((a for a in alarms if t <= a < t_next), None)
            if hit is not None:
                matched.add(hit)
            det = f"{hit:.2f} s" if hit is not None else "not detected"
            delay = f"{hit - t:.2f} s" if hit is not None else "-"
            said = [b for tb, b in believed if tb <= t_next]
            print(f"  | {t:.2f} s | {what} | {det} | {delay} | {said[-1] if said else '-'} |")
        before = [a for a in alarms if not changes or a < changes[0][0]]
        other = len(alarms) - len(matched)
        print(f"  alarms that were not the first after a true change: {other} "
              f"({len(before)} before the robot reached the band)")


if __name__ == "__main__":
    main(sys.argv[1:])
