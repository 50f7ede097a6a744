"""auger import of another program's CSV with a map: renamed, scaled, resampled."""

import math

import numpy as np

from bagmaker import read_log
from conftest import run_import

MAP = """\
schema = 1
[time]
column = "stamp_ms"
scale = 0.001
unix = true
[metadata]
terrain = "frozen_grass"
[columns]
omega_rpm_0 = { column = "fr_rpm", scale = -0.5 }   # motor rpm, reversed, 2:1 to the screw
omega_rpm_1 = { column = "rr_rpm", scale = -0.5 }
omega_rpm_2 = { column = "rl_rpm", scale = 0.5 }
omega_rpm_3 = { column = "fl_rpm", scale = 0.5 }
x_m = { column = "cam_x_mm", scale = 0.001 }
y_m = { column = "cam_y_mm", scale = 0.001 }
psi_rad = { quaternion = ["qx", "qy", "qz", "qw"] }
imu_r_radps = { column = "gyro_z_dps", scale = 0.017453292519943295, required = false }
"""


def foreign_csv(path, n=300, dt_ms=20):
    """50 Hz rows, the camera every 5th row, Unix time in ms."""
    t0_ms = 1_767_225_600_000
    lines = ["# exported by some logger", "stamp_ms,fr_rpm,rr_rpm,rl_rpm,fl_rpm,cam_x_mm,cam_y_mm,qx,qy,qz,qw,gyro_z_dps"]
    for k in range(n):
        t = k * dt_ms / 1000
        w = 10 + 4 * math.sin(t)
        cam = k % 5 == 0
        yaw = 0.3 * t
        q = [0, 0, math.sin(yaw / 2), math.cos(yaw / 2)] if cam else ["", "", "", ""]
        lines.append(",".join(str(x) for x in [t0_ms + k * dt_ms, -2 * w, -2 * w, 2 * w, 2 * w,
                                                 *((1000 * 0.01 * t, -3.0) if cam else ("", "")), *q, 17.188733853924695]))
    path.write_text("\n".join(lines) + "\n")


def test_csv_map_renames_scales_and_resamples(tmp_path):
    foreign_csv(tmp_path / "f.csv")
    (tmp_path / "m.toml").write_text(MAP)
    code, out, err = run_import(tmp_path / "f.csv", "--out", tmp_path / "log.csv", "--map", tmp_path / "m.toml")
    assert code == 0, err
    meta, got = read_log(tmp_path / "log.csv")
    assert meta["terrain"] == "frozen_grass" and meta["t0_unix_s"] == "1767225600"
    t = got["t_s"]
    assert len(t) == 599 and abs(t[1] - 0.01) < 1e-12    # 5.98 s at 100 Hz
    # the 50 Hz rows on every other row of the 100 Hz grid, unchanged; the rows between empty
    measured = np.arange(len(t)) % 2 == 0
    for i in range(4):  # the motors' -2 w (right) and 2 w (left) after the map's scales: w
        w = got["omega_rpm_%d" % i]
        np.testing.assert_array_equal(np.isnan(w), ~measured)
        np.testing.assert_allclose(w[measured], 10 + 4 * np.sin(t[measured]), rtol=1e-12)
    rows = ~np.isnan(got["x_m"])
    assert rows.sum() == 60
    np.testing.assert_allclose(got["x_m"][rows], 0.01 * t[rows], atol=1e-12)
    np.testing.assert_allclose(got["y_m"][rows], -0.003)
    np.testing.assert_allclose(got["psi_rad"][rows], 0.3 * t[rows], atol=1e-12)
    np.testing.assert_allclose(got["imu_r_radps"][measured], 0.3, rtol=1e-12)
    assert np.isnan(got["imu_r_radps"][~measured]).all()


def test_csv_errors_name_file_and_line(tmp_path):
    foreign_csv(tmp_path / "f.csv", n=20)
    (tmp_path / "m.toml").write_text(MAP)
    lines = (tmp_path / "f.csv").read_text().splitlines()
    lines[7] = lines[7].replace(",-", ",minus", 1)
    (tmp_path / "bad.csv").write_text("\n".join(lines) + "\n")
    code, _, err = run_import(tmp_path / "bad.csv", "--out", tmp_path / "log.csv", "--map", tmp_path / "m.toml")
    assert code == 2
    assert "bad.csv:8: column fr_rpm: 'minus" in err
    lines = (tmp_path / "f.csv").read_text().splitlines()
    lines[9] = lines[8]
    (tmp_path / "bad.csv").write_text("\n".join(lines) + "\n")
    code, _, err = run_import(tmp_path / "bad.csv", "--out", tmp_path / "log.csv", "--map", tmp_path / "m.toml")
    assert code == 2 and "bad.csv:10: column stamp_ms: time" in err and "is not after the previous row" in err
    code, _, err = run_import(tmp_path / "f.csv", "--out", tmp_path / "log.csv")
    assert code == 2 and "a CSV import needs --map FILE" in err
    assert not (tmp_path / "log.csv").exists()


def test_csv_quaternion_that_is_no_orientation_is_left_out(tmp_path):
    foreign_csv(tmp_path / "f.csv", n=40)
    lines = (tmp_path / "f.csv").read_text().splitlines()
    f = lines[12].split(",")   # row 10 (a camera row): qx, qy, qz, qw = 0
    f[7:11] = ["0", "0", "0", "0"]
    lines[12] = ",".join(f)
    (tmp_path / "f.csv").write_text("\n".join(lines) + "\n")
    (tmp_path / "m.toml").write_text(MAP)
    code, _, err = run_import(tmp_path / "f.csv", "--out", tmp_path / "log.csv", "--map", tmp_path / "m.toml")
    assert code == 0, err
    assert "column psi_rad (the yaw of columns qx, qy, qz, qw): 1 of 8 samples left empty, not a unit quaternion" in err
    assert "f.csv:13, t = 0.200 s, (0, 0, 0, 0), norm 0" in err
    _, got = read_log(tmp_path / "log.csv")
    assert np.isnan(got["psi_rad"][20]) and not np.isnan(got["x_m"][20]) and not np.isnan(got["psi_rad"][30])
