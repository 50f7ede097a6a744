"""Shared helpers of the Python tests (run by ctest as py_interop, or `build/venv/bin/python3 -m
pytest python/tests`). The tests that need the built programs read their paths from AUGER_BIN
and AUGER_SIM_LOG_BIN (ctest sets them) and are skipped without them."""

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))


def run_import(*args):
    """`auger import` through the Python entry the C++ front runs: (exit code, stdout, stderr)."""
    p = subprocess.run([sys.executable, "-m", "auger_interop", "import", *map(str, args)],
                       capture_output=True, text=True, timeout=120)
    return p.returncode, p.stdout, p.stderr


def binary(var):
    path = os.environ.get(var)
    if not path:
        pytest.skip("%s not set (ctest sets it to the built program)" % var)
    return path


def write_log(path, t_s, columns, meta=None):
    """A robot log with the given columns (NaN -> empty)."""
    with open(path, "w") as f:
        f.write("# format: auger-robot-log v1\n")
        for k, v in (meta or {}).items():
            f.write("# %s: %s\n" % (k, v))
        names = list(columns)
        f.write(",".join(["t_s"] + names) + "\n")
        for k in range(len(t_s)):
            vals = [repr(float(t_s[k]))] + ["" if math.isnan(columns[n][k]) else repr(float(columns[n][k])) for n in names]
            f.write(",".join(vals) + "\n")


def synthetic_log(path, seconds=6.0, pose_every=5):
    """Smooth screw speeds, a pose every pose_every rows, an IMU heading that crosses +-pi and an
    accelerometer's body-frame specific force."""
    t = np.round(np.arange(0, seconds + 1e-9, 0.01), 10)
    cols = {}
    for i in range(4):
        cols["omega_rpm_%d" % i] = (-1) ** (i // 2 + 1) * (5 + 3 * np.sin(0.7 * t + i))
        cols["cmd_rpm_%d" % i] = np.round(cols["omega_rpm_%d" % i])
        cols["current_a_%d" % i] = 0.5 + 0.1 * np.cos(t + i)
        cols["voltage_v_%d" % i] = 18.0 - 0.01 * t
    pose = np.arange(len(t)) % pose_every == 0
    cols["x_m"] = np.where(pose, 0.02 * t, np.nan)
    cols["y_m"] = np.where(pose, -0.01 * t, np.nan)
    cols["psi_rad"] = np.where(pose, np.mod(3.0 + 0.1 * t + np.pi, 2 * np.pi) - np.pi, np.nan)
    cols["imu_psi_rad"] = np.mod(3.0 + 0.1 * t + np.pi, 2 * np.pi) - np.pi
    cols["imu_r_radps"] = np.full(len(t), 0.1)
    cols["imu_ax_mps2"] = 0.05 * np.sin(1.3 * t)
    cols["imu_ay_mps2"] = -0.02 + 0.01 * np.cos(2.1 * t)
    write_log(path, t, cols)
    return t, cols
