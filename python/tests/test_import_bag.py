"""auger import of ROS 2 bags written with rosbags' own writer in the group's topics and types."""

import math
import os

import numpy as np
import pytest

from bagmaker import POSITIONS, log_to_bag, read_log, strip_definitions
from conftest import run_import, synthetic_log, write_log

T0_NS = 1_767_225_600_123_456_789


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_round_trip_keeps_every_value(tmp_path, storage):
    t, cols = synthetic_log(tmp_path / "in.csv")
    bag = log_to_bag(tmp_path / "in.csv", tmp_path / "bag", storage=storage, t0_ns=T0_NS)
    code, out, err = run_import(bag, "--out", tmp_path / "out.csv", "--terrain", "gravel")
    assert code == 0, err
    meta, got = read_log(tmp_path / "out.csv")
    assert meta["format"] == "auger-robot-log v1"
    assert meta["t0_unix_s"] == "1767225600.123456789"
    assert meta["terrain"] == "gravel"
    np.testing.assert_allclose(got["t_s"], t, atol=1e-12)
    for i in range(4):
        # float32 on the wire: 7 significant digits
        np.testing.assert_allclose(got["omega_rpm_%d" % i], cols["omega_rpm_%d" % i], rtol=2e-7)
        np.testing.assert_allclose(got["current_a_%d" % i], cols["current_a_%d" % i], rtol=2e-7)
        np.testing.assert_allclose(got["voltage_v_%d" % i], cols["voltage_v_%d" % i], rtol=2e-7)
    # setpoints are sent every 10th row and held in between
    for i in range(4):
        held = cols["cmd_rpm_%d" % i][(np.arange(len(t)) // 10) * 10]
        np.testing.assert_array_equal(got["cmd_rpm_%d" % i], held)
    # the pose stays sparse: the same rows, the same values (float64 on the wire)
    for c in ("x_m", "y_m"):
        np.testing.assert_array_equal(np.isnan(got[c]), np.isnan(cols[c]))
        np.testing.assert_allclose(got[c][~np.isnan(got[c])], cols[c][~np.isnan(cols[c])], atol=1e-15)
    dpsi = np.angle(np.exp(1j * (got["psi_rad"] - cols["psi_rad"])))
    assert np.nanmax(np.abs(dpsi)) < 1e-12
    assert np.all(np.abs(got["imu_psi_rad"]) <= math.pi)
    assert np.max(np.abs(np.angle(np.exp(1j * (got["imu_psi_rad"] - cols["imu_psi_rad"]))))) < 1e-12
    assert "/robot_pose: 121 samples (20.0 Hz) -> x_m, y_m, psi_rad (sparse)" in out


def test_humble_bag_without_definitions(tmp_path):
    """ROS 2 Humble's recorder stores no definitions: the import knows the group's types."""
    synthetic_log(tmp_path / "in.csv", seconds=2)
    bag = log_to_bag(tmp_path / "in.csv", tmp_path / "bag", t0_ns=T0_NS)
    assert run_import(bag, "--out", tmp_path / "a.csv")[0] == 0
    strip_definitions(bag)
    code, _, err = run_import(bag, "--out", tmp_path / "b.csv")
    assert code == 0, err
    assert (tmp_path / "a.csv").read_text() == (tmp_path / "b.csv").read_text()


def test_group_rates_keep_measured_samples_only(tmp_path):
    """Motor feedback at 5 Hz (the group's modules), each screw's at its own phase, and an IMU
    with a dropout: every sample on its own row, the rows between empty (not interpolated); row 0
    carries each screw speed's last sample before it, so the log starts with all four."""
    t, cols = synthetic_log(tmp_path / "in.csv", seconds=8)
    cols["imu_psi_rad"][(t >= 3) & (t < 5)] = np.nan      # 2 s
    cols["imu_psi_rad"][(t >= 6) & (t < 6.5)] = np.nan    # 0.5 s
    write_log(tmp_path / "in.csv", t, cols)
    bag = log_to_bag(tmp_path / "in.csv", tmp_path / "bag", t0_ns=T0_NS, feedback_every=20, feedback_phase=5)
    code, out, err = run_import(bag, "--out", tmp_path / "out.csv")
    assert code == 0, err
    meta, got = read_log(tmp_path / "out.csv")
    # screw i is sent at rows k with (k + 5 i) % 20 == 0: screw 0 first at row 0, 1 at 15, 2 at
    # 10, 3 at 5; all four have one from row 15 to row 785 (screw 3's last)
    first = 15
    assert meta["t0_unix_s"] == "1767225600.273456789"   # T0 + 0.15 s
    rows = np.arange(first, 786)
    assert len(got["t_s"]) == len(rows)
    for i in range(4):
        w, want = got["omega_rpm_%d" % i], cols["omega_rpm_%d" % i]
        sent = (rows + 5 * i) % 20 == 0
        np.testing.assert_array_equal(~np.isnan(w[1:]), sent[1:])
        np.testing.assert_allclose(w[sent], want[rows[sent]], rtol=2e-7)
        # row 0: the last sample at or before it
        assert w[0] == pytest.approx(want[(0, 15, 10, 5)[i]], rel=2e-7), i
    assert "/front_right/motor_module: 41 samples (5.0 Hz)" in out
    imu = got["imu_psi_rad"]
    ts = got["t_s"] + first * 0.01
    gap = ((ts >= 3 - 1e-9) & (ts < 5 - 1e-9)) | ((ts >= 6 - 1e-9) & (ts < 6.5 - 1e-9))
    np.testing.assert_array_equal(np.isnan(imu), gap)


def test_motor_id_other_than_position_is_noted(tmp_path):
    synthetic_log(tmp_path / "in.csv", seconds=1)
    bag = log_to_bag(tmp_path / "in.csv", tmp_path / "bag", motor_ids=("0", "1", "3", "2"))
    code, out, _ = run_import(bag, "--out", tmp_path / "out.csv")
    assert code == 0
    assert "/rear_left/motor_module carries motor_id 3; mapped by its topic to screw 2 (rear-left)" in out


def test_missing_topic_is_an_error_and_writes_nothing(tmp_path):
    synthetic_log(tmp_path / "in.csv", seconds=1)
    bag = log_to_bag(tmp_path / "in.csv", tmp_path / "bag")
    m = tmp_path / "map.toml"
    m.write_text('schema = 1\n[columns]\n' + "".join(
        'omega_rpm_%d = { topic = "/%s/motor_module", field = "motor_rpm" }\n' % (i, p) for i, p in enumerate(POSITIONS))
        .replace("/front_left/", "/front_lft/"))
    out = tmp_path / "out.csv"
    out.write_text("precious\n")
    code, _, err = run_import(bag, "--out", out, "--map", m)
    assert code == 2
    assert "topic /front_lft/motor_module is not in the bag (column omega_rpm_3 needs it" in err
    assert str(bag) in err
    assert out.read_text() == "precious\n"
    assert sorted(os.listdir(tmp_path)) == ["bag", "in.csv", "map.toml", "out.csv"]


def test_corrupt_message_names_topic_and_message(tmp_path):
    import sqlite3
    synthetic_log(tmp_path / "in.csv", seconds=1)
    bag = log_to_bag(tmp_path / "in.csv", tmp_path / "bag")
    db = next(bag.glob("*.db3"))
    con = sqlite3.connect(db)
    tid = con.execute("SELECT id FROM topics WHERE name = '/rear_right/motor_module'").fetchone()[0]
    mid = con.execute("SELECT id FROM messages WHERE topic_id = ? ORDER BY timestamp LIMIT 1 OFFSET 6", (tid,)).fetchone()[0]
    con.execute("UPDATE messages SET data = X'000100000000' WHERE id = ?", (mid,))
    con.commit()
    con.close()
    code, _, err = run_import(bag, "--out", tmp_path / "out.csv")
    assert code == 2
    assert "topic /rear_right/motor_module: message 7 (robominer_msgs/msg/MotorModuleFeedback" in err
    assert sorted(os.listdir(tmp_path)) == ["bag", "in.csv"]   # no output, no temporary file left


def test_map_errors_name_file_and_key(tmp_path):
    synthetic_log(tmp_path / "in.csv", seconds=1)
    bag = log_to_bag(tmp_path / "in.csv", tmp_path / "bag")
    cases = {
        'schema = 1\n[columns]\nomega_rpm_0 = { topic = "/a", field = "b", scal = 2 }\n':
            "columns.omega_rpm_0: unknown key 'scal'",
        'schema = 1\n[columns]\nx_m = { topic = "/robot_pose", field = "pose.position.x" }\n':
            "omega_rpm_0 is not mapped",
        'schema = 2\n': "schema: must be 1",
        'schema = 1\nrate_hz = "fast"\n': "rate_hz: 'fast' is not a finite number",
        'schema = 1\n[columns\n': "not valid TOML",
    }
    for text, want in cases.items():
        m = tmp_path / "map.toml"
        m.write_text(text)
        code, _, err = run_import(bag, "--out", tmp_path / "out.csv", "--map", m)
        assert code == 2 and want in err and str(m) in err, (text, err)
    # a field the message does not have
    m.write_text('schema = 1\n[columns]\n' + "".join(
        'omega_rpm_%d = { topic = "/%s/motor_module", field = "motor_rpmm" }\n' % (i, p) for i, p in enumerate(POSITIONS)))
    code, _, err = run_import(bag, "--out", tmp_path / "out.csv", "--map", m)
    assert code == 2
    assert "/front_right/motor_module (robominer_msgs/msg/MotorModuleFeedback) has no field 'motor_rpmm'" in err


def test_list_topics(tmp_path):
    synthetic_log(tmp_path / "in.csv", seconds=1)
    bag = log_to_bag(tmp_path / "in.csv", tmp_path / "bag", storage="mcap")
    code, out, _ = run_import(bag, "--list-topics")
    assert code == 0
    assert "/front_right/motor_module" in out and "robominer_msgs/msg/MotorModuleFeedback" in out
    assert "/cmd_vel_keyboard" in out


def test_match_selects_messages_by_field(tmp_path):
    """Several modules on one topic are told apart by a field (`match`)."""
    synthetic_log(tmp_path / "in.csv", seconds=1)
    bag = log_to_bag(tmp_path / "in.csv", tmp_path / "bag")
    lines = "".join('omega_rpm_%d = { topic = "/%s/motor_module", field = "motor_rpm", match = { motor_id = "%s" } }\n'
                    % (i, p, mid) for i, (p, mid) in enumerate(zip(POSITIONS, ("0", "1", "2", "3"))))
    m = tmp_path / "map.toml"
    m.write_text("schema = 1\n[columns]\n" + lines)
    assert run_import(bag, "--out", tmp_path / "a.csv", "--map", m)[0] == 0
    m.write_text("schema = 1\n[columns]\n" + lines.replace('motor_id = "2"', 'motor_id = "9"'))
    code, _, err = run_import(bag, "--out", tmp_path / "b.csv", "--map", m)
    assert code == 2 and "no message matches /rear_left/motor_module field motor_rpm with motor_id == '9'" in err
    m.write_text("schema = 1\n[columns]\n" + lines.replace("motor_id =", "motor_idx ="))
    code, _, err = run_import(bag, "--out", tmp_path / "b.csv", "--map", m)
    assert code == 2 and "match: /front_right/motor_module (robominer_msgs/msg/MotorModuleFeedback) has no field 'motor_idx'" in err
