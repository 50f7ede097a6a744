#!/usr/bin/env python3
"""The tracking error of an auger-sim-drive run (docs/daemon.md "Online identification"): the
true position and heading (its --truth-out log, interpolated at the log's times) against the
controller's reference (the log's xd_m, yd_m, psid_rad), RMS from --from-s on (to --to-s).

  scripts/sim-tracking-rms.py LOG TRUTH [--from-s 5] [--to-s T]

Prints "tracking RMS 0.0350 m, 0.0038 rad over N rows from 5 s" ("... to T s" with --to-s).
Standard library only.
"""
import bisect
import math
import sys


def fail(msg):
    print("sim-tracking-rms: " + msg, file=sys.stderr)
    sys.exit(2)


def read_csv(path, need):
    header, rows = None, []
    try:
        with open(path) as f:
            for n, line in enumerate(f, 1):
                if line.startswith("#") or not line.strip():
                    continue
                cells = line.rstrip("\n").split(",")
                if header is None:
                    header = cells
                    missing = [c for c in need if c not in header]
                    if missing:
                        fail("%s:%d: no column %s" % (path, n, ", ".join(missing)))
                    continue
                rows.append((n, dict(zip(header, cells))))
    except OSError as e:
        fail("%s: %s" % (path, e.strerror))
    if not rows:
        fail("%s: no rows" % path)
    return rows


def number(path, n, row, key):
    try:
        return float(row[key])
    except (KeyError, ValueError):
        fail("%s:%d: '%s' is not a number" % (path, n, key))


def seconds_option(argv, name, default):
    if name not in argv:
        return default
    i = argv.index(name)
    try:
        value = float(argv[i + 1])
    except (IndexError, ValueError):
        fail(name + " needs seconds")
    del argv[i:i + 2]
    return value


def main(argv):
    from_s = seconds_option(argv, "--from-s", 5.0)
    to_s = seconds_option(argv, "--to-s", math.inf)
    if len(argv) != 2:
        fail("usage: sim-tracking-rms.py LOG TRUTH [--from-s 5] [--to-s T]")
    log_path, truth_path = argv
    truth = read_csv(truth_path, ("t_s", "x_m", "y_m", "psi_rad"))
    t_true = [number(truth_path, n, r, "t_s") for n, r in truth]
    cols = {k: [number(truth_path, n, r, k) for n, r in truth] for k in ("x_m", "y_m", "psi_rad")}

    def at(t, k):
        i = min(max(bisect.bisect_left(t_true, t), 1), len(t_true) - 1)
        a, b = t_true[i - 1], t_true[i]
        w = 0.0 if b == a else (t - a) / (b - a)
        return cols[k][i - 1] * (1 - w) + cols[k][i] * w

    sum_m2 = sum_rad2 = 0.0
    count = 0
    for n, r in read_csv(log_path, ("t_s", "xd_m", "yd_m", "psid_rad")):
        t = number(log_path, n, r, "t_s")
        if t < from_s or t > to_s or t > t_true[-1] or r["xd_m"] in ("", "nan"):
            continue
        ex = at(t, "x_m") - number(log_path, n, r, "xd_m")
        ey = at(t, "y_m") - number(log_path, n, r, "yd_m")
        ep = math.remainder(at(t, "psi_rad") - number(log_path, n, r, "psid_rad"), 2 * math.pi)
        sum_m2 += ex * ex + ey * ey
        sum_rad2 += ep * ep
        count += 1
    if count == 0:
        fail("%s: no row with a reference from %g s" % (log_path, from_s))
    print("tracking RMS %.4f m, %.4f rad over %d rows from %g s%s" %
          (math.sqrt(sum_m2 / count), math.sqrt(sum_rad2 / count), count, from_s,
           "" if math.isinf(to_s) else " to %g s" % to_s))


if __name__ == "__main__":
    main(sys.argv[1:])
