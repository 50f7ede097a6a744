#!/usr/bin/env python3
"""The no-stall check of issue 29 on auger-sim-drive logs (docs/benchmarks.md "Online
identification"): for each LOG with its truth log beside it (LOG without .csv + .truth.csv, as
`auger-sim-drive --out LOG --truth-out ...` and scripts/sim-batch.py name them), the longest span
in which the robot moved slower than 5 mm/s (true pose, over 0.1 s) while the reference moved
faster than 10 mm/s, overall and while the screws' contacts stood on two terrains (an edge).

  scripts/stall-check.py LOG...

Standard library only.
"""
import csv
import math
import sys

SLOW_MPS, MOVING_MPS, SPAN = 0.005, 0.010, 10  # rows of 10 ms


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def num(text):
    return float(text) if text not in ("", None) else math.nan


def main(logs):
    if not logs:
        sys.exit("usage: scripts/stall-check.py LOG...")
    for log in logs:
        truth_path = log[:-4] + ".truth.csv" if log.endswith(".csv") else log + ".truth.csv"
        try:
            log_rows, truth = rows(log), rows(truth_path)
        except OSError as e:
            sys.exit(f"stall-check: {e}")
        if not truth or "terrain_id_0" not in truth[0]:
            sys.exit(f"stall-check: {truth_path}: no terrain_id_0..3 columns")
        n = min(len(log_rows), len(truth))
        longest = {"all": (0.0, None), "edge": (0.0, None)}
        start = {"all": None, "edge": None}
        ref = [(num(r["xd_m"]), num(r["yd_m"])) for r in log_rows[:n]]
        for k in range(SPAN, n):
            t = float(truth[k]["t_s"])
            dt = t - float(truth[k - SPAN]["t_s"])
            v = math.hypot(float(truth[k]["x_m"]) - float(truth[k - SPAN]["x_m"]),
                           float(truth[k]["y_m"]) - float(truth[k - SPAN]["y_m"])) / dt
            vr = math.hypot(ref[k][0] - ref[k - SPAN][0], ref[k][1] - ref[k - SPAN][1]) / dt
            edge = len({truth[k][f"terrain_id_{i}"] for i in range(4)}) > 1
            for key, cond in (("all", True), ("edge", edge)):
                if cond and v < SLOW_MPS and vr > MOVING_MPS:
                    start[key] = t if start[key] is None else start[key]
                    if t - start[key] > longest[key][0]:
                        longest[key] = (t - start[key], start[key])
                else:
                    start[key] = None
        def say(key):
            d, at = longest[key]
            return f"{d:.2f} s" + (f" (from t = {at:.2f} s)" if at is not None else "")
        print(f"{log}: longest stall (slower than 5 mm/s while the reference moves): {say('all')}; "
              f"on an edge: {say('edge')}")


if __name__ == "__main__":
    main(sys.argv[1:])
