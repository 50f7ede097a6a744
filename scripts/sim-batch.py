#!/usr/bin/env python3
"""Batch driving for detector benchmarks (docs/robot-sim.md "Batch driving"): N logs of the
firmware-in-the-loop chain (auger-sim-drive, lock-step, not paced) on uniform terrain and across
a field, each with its truth log (the true pose and the ground under the robot every 10 ms).

  scripts/sim-batch.py --out DIR [--build build] [--runs N] [--seconds S]
                       [--field sim/fields/sand-grass.toml] [--course-m 1.5]
                       [--drives square,diagonal] [--uniform sand,frozen_grass]
                       [--screws fil|ideal] [--seed0 1] [--jobs 2] [--model FILE]

For each seed (seed0 .. seed0 + N - 1) and drive it writes DIR/field-DRIVE-SEED.csv (across the
field; the controller configured for the field's background terrain) and, for each --uniform
terrain, DIR/uniform-TERRAIN-DRIVE-SEED.csv, each with .truth.csv beside it. Then
DIR/manifest.csv (one row per log: kind, terrain, drive, seed, simulated and wall seconds,
changes of the terrain under the body's centre) and DIR/changes.csv (every row where the terrain
under the centre or under any contact changes: log, t_s, kind centre|contacts, the terrain ids
after it, as the truth log's `# terrain_ids:` names them). A run that fails is reported and the
others are kept; exit 1 if any failed. Python 3 stdlib only; arguments never pass through a shell.
"""

import argparse
import concurrent.futures
import csv
import os
import re
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NAME = re.compile(r"^[A-Za-z0-9_]+$")


def names(text, what):
    out = [t for t in text.split(",") if t]
    for t in out:
        if not NAME.match(t):
            sys.exit(f"sim-batch: {what} '{t}' must be letters, digits and _ only")
    return out


def read_truth(path):
    """Rows of a truth log as dicts of floats, and its metadata."""
    meta, rows, header = {}, [], None
    with open(path, newline="") as f:
        for line in f:
            if line.startswith("#"):
                k, _, v = line[1:].partition(":")
                meta[k.strip()] = v.strip()
                continue
            fields = line.rstrip("\n").split(",")
            if header is None:
                header = fields
                continue
            rows.append(dict(zip(header, fields)))
    return meta, rows


def changes_of(log, truth_path):
    """The truth's terrain changes: (log, t_s, kind, ids) per change, and the centre's count."""
    _, rows = read_truth(truth_path)
    out, prev_c, prev_k, n_centre = [], None, None, 0
    for r in rows:
        c = r["terrain_id"]
        k = tuple(r[f"terrain_id_{i}"] for i in range(4))
        if prev_c is not None and c != prev_c:
            out.append((log, r["t_s"], "centre", c))
            n_centre += 1
        if prev_k is not None and k != prev_k:
            out.append((log, r["t_s"], "contacts", " ".join(k)))
        prev_c, prev_k = c, k
    return out, n_centre


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--seconds", type=float, default=600.0)
    ap.add_argument("--field", default=os.path.join(ROOT, "sim", "fields", "sand-grass.toml"))
    ap.add_argument("--course-m", type=float, default=1.5)
    ap.add_argument("--drives", default="square,diagonal")
    ap.add_argument("--uniform", default="sand,frozen_grass")
    ap.add_argument("--screws", choices=["fil", "ideal"], default="fil")
    ap.add_argument("--seed0", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--model", help="the model file auger-sim-drive reads (default its own: models/robot.toml)")
    a = ap.parse_args()
    if a.runs < 1 or not a.seconds > 0 or not a.course_m > 0 or a.jobs < 1:
        sys.exit("sim-batch: --runs, --seconds, --course-m and --jobs must be positive")
    drives = names(a.drives, "drive")
    uniform = names(a.uniform, "terrain")
    exe = os.path.join(a.build, "sim", "robot", "auger-sim-drive")
    if not os.access(exe, os.X_OK):
        sys.exit(f"sim-batch: {exe} is missing (cmake --build {a.build} --target auger-sim-drive)")
    if not os.path.isfile(a.field):
        sys.exit(f"sim-batch: the field file {a.field} does not exist")
    os.makedirs(a.out, exist_ok=True)

    jobs = []  # (name, kind, terrain, drive, seed, extra args)
    for seed in range(a.seed0, a.seed0 + a.runs):
        for d in drives:
            jobs.append((f"field-{d}-{seed}", "field", "", d, seed, ["--field", a.field]))
            for t in uniform:
                jobs.append((f"uniform-{t}-{d}-{seed}", "uniform", t, d, seed, ["--terrain", t]))

    def run(job):
        name, kind, terrain, drive, seed, extra = job
        log = os.path.join(a.out, name + ".csv")
        truth = os.path.join(a.out, name + ".truth.csv")
        cmd = [exe, "--out", log, "--truth-out", truth, "--drive", drive, "--seed", str(seed),
               "--seconds", repr(a.seconds), "--course-m", repr(a.course_m), "--screws", a.screws] + extra
        if a.model:
            cmd += ["--model", a.model]
        t0 = time.monotonic()
        p = subprocess.run(cmd, capture_output=True, text=True)
        return job, p.returncode, p.stderr.strip(), time.monotonic() - t0

    t_start = time.monotonic()
    manifest, changes, failed = [], [], 0
    with concurrent.futures.ThreadPoolExecutor(max_workers=a.jobs) as pool:
        for job, rc, err, wall in pool.map(run, jobs):
            name, kind, terrain, drive, seed, _ = job
            if rc != 0:
                failed += 1
                print(f"sim-batch: {name} failed (exit {rc}): {err}", file=sys.stderr)
                continue
            ch, n_centre = changes_of(name, os.path.join(a.out, name + ".truth.csv"))
            changes += ch
            manifest.append([name + ".csv", name + ".truth.csv", kind, terrain or "(field)", drive, seed,
                             a.seconds, round(wall, 2), n_centre])
            print(f"sim-batch: {name}: {a.seconds:g} s simulated in {wall:.1f} s wall "
                  f"({a.seconds / wall:.0f}x real time), {n_centre} terrain changes under the centre")
    with open(os.path.join(a.out, "manifest.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["log", "truth", "kind", "terrain", "drive", "seed", "sim_s", "wall_s", "centre_changes"])
        w.writerows(manifest)
    with open(os.path.join(a.out, "changes.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["log", "t_s", "kind", "terrain_ids"])
        w.writerows(changes)
    wall = time.monotonic() - t_start
    sim_h = a.seconds * len(manifest) / 3600
    print(f"sim-batch: {len(manifest)} logs, {sim_h:.2f} h simulated in {wall:.0f} s wall with {a.jobs} jobs "
          f"({a.seconds * len(manifest) / wall:.0f}x real time); {a.out}/manifest.csv, {a.out}/changes.csv")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
