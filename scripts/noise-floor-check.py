#!/usr/bin/env python3
"""How well `auger compare` knows a log's noise (docs/workbench.md "Noise floor").

Logs of the lock-step chain (auger-sim-drive, ideal screws, the square on sand, the camera's
coloured noise) are written with their true trajectory; for each, the noise the log really carries
(measured pose minus the true pose, the true trajectory shifted by the camera's latency) is set
against the noise floor `auger compare --json` estimates, and that true noise is passed through
the whitening filter compare reports (`noise_colour.ar`): a Ljung-Box Q over 10 lags near 10
(its 1 % limit is 23.2) says the residual tests would take the camera's own noise for noise.

    scripts/noise-floor-check.py [BUILD_DIR] [LOGS] [SECONDS]

Needs numpy (the venv `make test` builds has it: build/venv/bin/python).
"""
import csv
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

LB_LAGS = 10
LB_LIMIT_1PCT = 23.2


def read_log(path):
    rows = [line for line in open(path) if not line.startswith("#")]
    table = list(csv.DictReader(rows))

    def col(name):
        return np.array([float(r[name]) if r.get(name, "") != "" else np.nan for r in table])

    return col


def ljung_box(w, run):
    w = w - w.mean()
    n, var, q = len(w), float(np.sum(w * w)), 0.0
    for lag in range(1, LB_LAGS + 1):
        same = run[lag:] == run[:-lag]
        rho = float(np.sum(w[lag:][same] * w[:-lag][same])) / var
        q += rho * rho / (n - lag)
    return n * (n + 2) * q


def whiten(e, t_s, ar, frame_s):
    """w_k = e_k - sum_j ar_j e_{k-j} where the p frames before k are there (as auger does)."""
    p, out, run, runs, broken = len(ar), [], 0, [], True
    for k in range(len(e)):
        ok = k >= p and all(abs(t_s[k] - t_s[k - j] - j * frame_s) < 0.5 * frame_s for j in range(1, p + 1))
        if not ok:
            broken = True
            continue
        run += broken
        broken = False
        out.append(e[k] - sum(ar[j - 1] * e[k - j] for j in range(1, p + 1)))
        runs.append(run)
    return np.array(out), np.array(runs)


def main():
    build = Path(sys.argv[1] if len(sys.argv) > 1 else "build").resolve()
    logs = int(sys.argv[2]) if len(sys.argv) > 2 else 12
    seconds = sys.argv[3] if len(sys.argv) > 3 else "60"
    auger = build / "host/auger/auger"
    drive = build / "sim/robot/auger-sim-drive"
    work = Path(tempfile.mkdtemp(prefix="auger-noise-"))
    print(f"{logs} logs of {seconds} s (auger-sim-drive --screws ideal, seeds 1-{logs}); logs under {work}")
    print("| seed | x: true / floor | y: true / floor | psi: true / floor | AR filter | Q x | Q y | Q psi |")
    print("|---|---|---|---|---|---|---|---|")
    ratios, qs = [], []
    for seed in range(1, logs + 1):
        log, truth = work / f"drive-{seed}.csv", work / f"truth-{seed}.csv"
        subprocess.run([str(drive), "--out", str(log), "--truth-out", str(truth), "--seconds", seconds,
                        "--seed", str(seed), "--screws", "ideal"], check=True, capture_output=True)
        rep = json.loads(subprocess.run([str(auger), "compare", str(log), "--json"], check=True,
                                        capture_output=True, text=True).stdout)
        floor, colour = rep["noise_floor"], rep["noise_colour"]
        lc, tc = read_log(log), read_log(truth)
        t_true = tc("t_s")
        have = ~np.isnan(lc("x_m"))
        t_s = lc("t_s")[have]
        # The camera's latency: the shift of the true trajectory that fits the poses best.
        shifts = np.arange(-0.1, 0.1, 0.002)
        shift = min(shifts, key=lambda s: np.std(np.interp(t_s + s, t_true, tc("x_m")) - lc("x_m")[have]))
        row, q_row = [], []
        for name, key in (("x_m", "x"), ("y_m", "y"), ("psi_rad", "psi")):
            e = lc(name)[have] - np.interp(t_s + shift, t_true, tc(name))
            row.append(float(np.std(e)) / floor[key])
            ar = colour["ar"] if colour["applied"] else []
            w, runs = whiten(e, t_s, ar, colour["frame_s"]) if ar else (e, np.zeros(len(e)))
            q_row.append(ljung_box(w, runs))
        ratios.append(row)
        qs.extend(q_row)
        ar_text = "AR(%d) %s" % (len(colour["ar"]), " ".join("%.3f" % a for a in colour["ar"])) if colour["applied"] else "white"
        print(f"| {seed} | {row[0]:.2f} | {row[1]:.2f} | {row[2]:.2f} | {ar_text} | "
              + " | ".join(f"{q:.1f}" for q in q_row) + " |")
    r = np.array(ratios)
    print("true noise / estimated floor: mean x %.3f y %.3f psi %.3f; spread (std) x %.3f y %.3f psi %.3f; "
          "largest |error| x %.0f %% y %.0f %% psi %.0f %%"
          % (*r.mean(0), *r.std(0), *(100 * np.abs(r - 1).max(0))))
    qs = np.array(qs)
    print("whitened true noise: Ljung-Box Q median %.1f (white noise: about 9.3), %d of %d above the 1 %% limit %.1f"
          % (float(np.median(qs)), int(np.sum(qs > LB_LIMIT_1PCT)), len(qs), LB_LIMIT_1PCT))


if __name__ == "__main__":
    main()
