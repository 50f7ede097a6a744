"""The built programs together: a simulated drive with a hidden effect (auger-sim-log) written
as the group's ROS 2 bags (every kind issue 26 lists), `auger import` back, `auger diagnose` names
the effect the CSV of the run names; `auger export --mcap` read back with the independent `mcap`
reader, every value compared."""

import json
import math
import subprocess

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.stream_reader import StreamReader

from auger_interop.robominer import COMMAND, FEEDBACK
from bagmaker import log_to_bag, read_log, strip_definitions
from conftest import binary


def run(*cmd):
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, "%s exited %d: %s" % (cmd[:2], p.returncode, p.stderr)
    return p.stdout


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    """60 s of manual driving on sand with dry friction hidden (the suite's size range)."""
    d = tmp_path_factory.mktemp("drive")
    run(binary("AUGER_SIM_LOG_BIN"), "--out", d / "drive.csv", "--effect",
        "coulomb_friction:force_x_n=7,force_y_n=2.5,torque_nm=1.2", "--seed", "3", "--trajectory", "manual",
        "--seconds", "60")
    return d


def test_bags_to_diagnose_names_the_hidden_effect(drive):
    auger = binary("AUGER_BIN")
    # sqlite3 as ROS 2 Humble records it (no definitions), feedback at the log's 100 Hz;
    # MCAP with the group's 5 Hz motor feedback
    sq = log_to_bag(drive / "drive.csv", drive / "bag-sqlite3", storage="sqlite3")
    strip_definitions(sq)
    mc = log_to_bag(drive / "drive.csv", drive / "bag-mcap", storage="mcap", feedback_every=20)
    _, orig = read_log(drive / "drive.csv")
    for bag, name in ((sq, "sqlite3.csv"), (mc, "mcap.csv")):
        out = run(auger, "import", bag, "--out", drive / name, "--terrain", "sand")
        assert out.splitlines()[-1] == "next: auger compare %s" % (drive / name)
        _, got = read_log(drive / name)
        assert len(got["t_s"]) == len(orig["t_s"])
        np.testing.assert_array_equal(np.isnan(got["x_m"]), np.isnan(orig["x_m"]))
        d = json.loads(run(auger, "diagnose", drive / name, "--json"))
        best = d["candidates"][0]
        assert best["effect"] == "coulomb_friction", (name, [c["effect"] for c in d["candidates"][:3]])
        assert d["significant"] is True
        assert abs(best["params"]["force_x_n"] - 7) < 1.5, best["params"]
    # at the log's own rate the screw speeds survive up to float32 rounding
    _, got = read_log(drive / "sqlite3.csv")
    for i in range(4):
        np.testing.assert_allclose(got["omega_rpm_%d" % i], orig["omega_rpm_%d" % i], rtol=2e-7, atol=1e-30)


def _step(kind):
    if kind == "forward":   # an NTP step 5 s forward at 20 s
        return lambda t: t + 5_000_000_000 if t >= 20_000_000_000 else t
    return lambda t: t - 3_000_000_000 if t >= 40_000_000_000 else t   # 3 s back at 40 s


VARIANTS = {
    "feedback-before-june-2021-sqlite3-no-definitions": dict(storage="sqlite3", strip=True, versions={FEEDBACK: 1}),
    "feedback-before-june-2021-mcap-5hz": dict(storage="mcap", versions={FEEDBACK: 1}, feedback_every=20),
    "imu-without-orientation": dict(storage="mcap", imu_orientation="none"),
    "imu-50hz-feedback-5hz": dict(storage="sqlite3", imu_every=2, feedback_every=20, feedback_phase=5),
    "odometry-pose": dict(storage="mcap", pose_type="nav_msgs/msg/Odometry"),
    "command-int32-no-definitions": dict(storage="sqlite3", strip=True, versions={COMMAND: 1}),
    "clock-forward-split": dict(storage="sqlite3", clock=_step("forward"), split=2),
    "clock-back-split": dict(storage="mcap", clock=_step("back"), split=2),
}


@pytest.fixture(scope="module")
def csv_diagnosis(drive):
    auger = binary("AUGER_BIN")
    return (json.loads(run(auger, "diagnose", drive / "drive.csv", "--json")),
            json.loads(run(auger, "compare", drive / "drive.csv", "--json")))


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_each_kind_of_group_bag_diagnoses_as_its_csv(drive, csv_diagnosis, variant, tmp_path):
    """The bags the group has (older messages, slower sensors, no IMU orientation, another pose
    type, a clock that steps) of one simulated run: diagnose on each import names what diagnose
    on the run's CSV names; the measured samples give the CSV's noise floors within 10 %."""
    auger = binary("AUGER_BIN")
    kw = dict(VARIANTS[variant])
    strip, split = kw.pop("strip", False), kw.pop("split", 0)
    bag = log_to_bag(drive / "drive.csv", tmp_path / "bag", **kw)
    if strip:
        strip_definitions(bag)
    out = run(auger, "import", bag, "--out", tmp_path / "run.csv", "--terrain", "sand", *(["--split"] if split else []))
    logs = [tmp_path / ("run-%d.csv" % k) for k in range(1, split + 1)] if split else [tmp_path / "run.csv"]
    assert all(p.exists() for p in logs), out
    want, floors = csv_diagnosis
    for log in logs:
        d = json.loads(run(auger, "diagnose", log, "--json"))
        assert d["candidates"][0]["effect"] == want["candidates"][0]["effect"], (log, d["verdict"])
        assert d["significant"] is True
    if not split:
        got = json.loads(run(auger, "compare", logs[0], "--json"))["noise_floor"]
        for ch, v in floors["noise_floor"].items():
            if variant == "imu-without-orientation" and ch == "imu_psi":
                assert ch not in got   # no IMU heading at all, rather than a heading of 0
            else:
                assert got[ch] == pytest.approx(v, rel=0.10), (ch, got[ch], v)


GROUPS = {
    "/screws": ("omega_rpm_", "cmd_rpm_", "current_a_", "voltage_v_", "pwm_"),
    "/pose_2d": ("x_m", "y_m", "psi_rad"),
    "/imu": ("imu_psi_rad", "imu_r_radps"),
    "/reference": ("xd_m", "yd_m", "psid_rad"),
    "/status": ("status_", "seq_ack_", "loop_dt_s"),
}


def channel_of(column):
    for topic, names in GROUPS.items():
        if any(column == n or (n.endswith("_") and column.startswith(n)) for n in names):
            return topic
    return "/other"


def yaw(q):
    return math.atan2(2 * (q["w"] * q["z"] + q["x"] * q["y"]), 1 - 2 * (q["y"] ** 2 + q["z"] ** 2))


def assert_mcap_matches_log(mcap_path, log_path, t0_ns, min_chunks=2):
    """Every value of the log in its channel of the MCAP file (and nothing else there), the pose
    as foxglove.PoseInFrame and on /tf; CRCs checked. Returns {topic: [(log_time, message)]}."""
    meta, cols = read_log(log_path)
    by_topic = {}
    with open(mcap_path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        schemas = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
        assert schemas["/pose"] == "foxglove.PoseInFrame" and schemas["/tf"] == "foxglove.FrameTransform"
        assert all(c.message_encoding == "json" for c in summary.channels.values())
        assert summary.statistics.chunk_count >= min_chunks and len(summary.chunk_indexes) == summary.statistics.chunk_count
        (m,) = list(reader.iter_metadata())
        assert m.name == "auger-log" and m.metadata == meta
        for schema, channel, msg in reader.iter_messages():
            assert msg.log_time == msg.publish_time
            by_topic.setdefault(channel.topic, []).append((msg.log_time, json.loads(msg.data)))
    # every record's CRC (chunks, data section, summary) checked by a second pass
    assert sum(1 for _ in StreamReader(str(mcap_path), validate_crcs=True).records) > 0

    t = cols["t_s"]
    rows_ns = [t0_ns + round(x * 1e9) for x in t]
    names = [c for c in cols if c != "t_s"]
    for topic in set(channel_of(c) for c in names):
        mine = [c for c in names if channel_of(c) == topic]
        expect = []
        for k in range(len(t)):
            fields = {c: cols[c][k] for c in mine if not math.isnan(cols[c][k])}
            if fields:
                expect.append((rows_ns[k], dict(t_s=t[k], **fields)))
        assert by_topic.get(topic, []) == expect, topic   # exact: shortest round-trip numbers both ways
    pose_rows = [k for k in range(len(t)) if not math.isnan(cols["x_m"][k])]
    assert [ns for ns, _ in by_topic["/pose"]] == [rows_ns[k] for k in pose_rows]
    for (ns, p), k in zip(by_topic["/pose"], pose_rows):
        assert p["frame_id"] == "world" and p["timestamp"] == {"sec": ns // 10**9, "nsec": ns % 10**9}
        assert p["pose"]["position"] == {"x": cols["x_m"][k], "y": cols["y_m"][k], "z": 0}
        assert abs(math.remainder(yaw(p["pose"]["orientation"]) - cols["psi_rad"][k], 2 * math.pi)) < 1e-12
    tf = [m for m in by_topic["/tf"] if m[1]["child_frame_id"] == "base_link"]
    assert [(ns, m["translation"]) for ns, m in tf] == [(ns, p["pose"]["position"]) for ns, p in by_topic["/pose"]]
    return by_topic


def test_export_mcap_every_value(drive):
    auger = binary("AUGER_BIN")
    log = drive / "drive.csv"
    # a column of another program rides along on /other
    text = log.read_text().splitlines()
    h = next(i for i, l in enumerate(text) if not l.startswith("#"))
    text.insert(h, "# t0_unix_s: 1767225600.25")
    text[h + 1] += ",wheel_temp_c"
    for i in range(h + 2, len(text)):
        text[i] += "," + ("" if i % 7 else str(20 + i * 1e-3))
    log = drive / "drive-extra.csv"
    log.write_text("\n".join(text) + "\n")
    out = run(auger, "export", log, "--mcap", drive / "drive.mcap", "--model", "default")
    assert "prediction of" in out
    meta, cols = read_log(log)
    t0_ns = 1767225600250000000

    by_topic = assert_mcap_matches_log(drive / "drive.mcap", log, t0_ns)
    assert len(by_topic["/other"]) == sum(~np.isnan(cols["wheel_temp_c"])) > 0
    t = cols["t_s"]
    rows_ns = [t0_ns + round(x * 1e9) for x in t]

    # The prediction: one message per row, and its error against the measured pose is exactly
    # what `auger compare` reports for its 25 s segments (the same simulation).
    pred = by_topic["/model/pose_2d"]
    assert [ns for ns, _ in pred] == rows_ns
    cmp = json.loads(run(auger, "compare", log, "--json"))
    for ch, col in (("x", "x_m"), ("y", "y_m"), ("psi", "psi_rad"), ("imu_psi", "imu_psi_rad")):
        e = [math.remainder(p[col] - cols[col][k], 2 * math.pi) if "psi" in ch else p[col] - cols[col][k]
             for k, (_, p) in enumerate(pred) if col in p and not math.isnan(cols[col][k])]
        rms = math.sqrt(sum(x * x for x in e) / len(e))
        assert rms == pytest.approx(cmp["segments"]["rms"][ch], rel=1e-6), ch
    model_tf = [m for _, m in by_topic["/tf"] if m["child_frame_id"] == "base_link_model"]
    assert len(model_tf) == len(by_topic["/model/pose"]) > 0


def test_export_refuses_bad_input_and_keeps_the_old_file(drive, tmp_path):
    auger = binary("AUGER_BIN")
    bad = tmp_path / "bad.csv"
    bad.write_text("# format: auger-robot-log v1\nt_s,omega_rpm_0,omega_rpm_1,omega_rpm_2,omega_rpm_3,x_m,y_m,psi_rad\n"
                   "0,1,2,3,4,,,\n0.01,1,2,x,4,,,\n")
    out = tmp_path / "old.mcap"
    out.write_bytes(b"old")
    p = subprocess.run([auger, "export", str(bad), "--mcap", str(out)], capture_output=True, text=True)
    assert p.returncode == 2
    assert "bad.csv:4:" in p.stderr
    assert out.read_bytes() == b"old"
    assert sorted(x.name for x in tmp_path.iterdir()) == ["bad.csv", "old.mcap"]


def test_mcap_sample_writer_matches_the_csv_writer(tmp_path):
    """RobotLogMcapWriter fed RobotSamples (augerd's interface) holds what RobotLogWriter wrote,
    status words as integers, lost modules and reference rows included."""
    run(binary("MCAP_SAMPLES_BIN"), tmp_path / "s.csv", tmp_path / "s.mcap")
    by_topic = assert_mcap_matches_log(tmp_path / "s.mcap", tmp_path / "s.csv", 1767225600000250000)
    assert len(by_topic["/status"]) == 500 and isinstance(by_topic["/status"][-1][1]["status_0"], int)
    assert len(by_topic["/reference/pose"]) == 399 and len(by_topic["/other"]) == 500


def test_augerd_writes_mcap_beside_each_csv_file(tmp_path):
    """augerd's log writer with [log] mcap = true: each rotated CSV file has an MCAP file of the
    same name holding exactly its rows (the replay columns in /other), complete with summary."""
    run(binary("MCAP_SAMPLES_BIN"), "--augerd", tmp_path)
    csvs = sorted(tmp_path.glob("augerd-*.csv"), key=lambda p: int(p.stem.rsplit("-", 1)[1]))
    assert len(csvs) >= 3
    rows = 0
    for csv_path in csvs:
        mcap_path = csv_path.with_suffix(".mcap")
        assert mcap_path.exists(), mcap_path
        by_topic = assert_mcap_matches_log(mcap_path, csv_path, 1767225600000250000, min_chunks=1)
        rows += len(by_topic["/status"])
        assert {"goal_x_m", "psie_rad", "mode"} <= set().union(*(m.keys() for _, m in by_topic["/other"]))
    assert rows == 500
    assert len(list(tmp_path.glob("*.mcap"))) == len(csvs)
