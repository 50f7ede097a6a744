"""auger import of the bags the group really has (issue 26): each case as rosbags' writer makes it,
in both storages where the storage allows, and what the import must say or refuse."""

import json
import math
import os
import subprocess
import time

import numpy as np
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from auger_interop.robominer import COMMAND, FEEDBACK, VERSIONS
from bagmaker import POSITIONS, log_to_bag, read_log, strip_definitions
from conftest import run_import, synthetic_log

T0_NS = 1_767_225_600_000_000_000
STORAGES = ["sqlite3", "mcap"]


def bag_of(tmp_path, storage="sqlite3", stripped=False, seconds=4, name="bag", **kw):
    if not (tmp_path / "in.csv").exists():
        synthetic_log(tmp_path / "in.csv", seconds=seconds)
    bag = log_to_bag(tmp_path / "in.csv", tmp_path / name, storage=storage, t0_ns=T0_NS, **kw)
    if stripped:
        strip_definitions(bag)
    return bag


@pytest.mark.parametrize("storage", STORAGES)
@pytest.mark.parametrize("orientation,why", [("none", "no orientation: orientation_covariance[0] = -1"),
                                             ("zero", "not a unit quaternion")])
def test_imu_without_orientation_leaves_its_heading_empty(tmp_path, storage, orientation, why):
    bag = bag_of(tmp_path, storage, imu_orientation=orientation)
    code, out, err = run_import(bag, "--out", tmp_path / "out.csv", "--terrain", "sand")
    assert code == 0, err
    _, got = read_log(tmp_path / "out.csv")
    assert np.isnan(got["imu_psi_rad"]).all()
    np.testing.assert_allclose(got["imu_r_radps"], 0.1)          # the yaw rate is still there
    assert "column imu_psi_rad (/bno080_imu field orientation): 401 of 401 samples left empty, " + why in err
    assert "message 1 at t = 0.000 s" in err


@pytest.mark.parametrize("acceleration,why", [
    ("none", "no linear acceleration: linear_acceleration_covariance[0] = -1"),
    ("zero", "no linear acceleration: 0, 0, 0 (an accelerometer always reads gravity)")])
def test_imu_without_acceleration_leaves_it_empty(tmp_path, acceleration, why):
    """REP 145's "absent", and the all-zero vector of a driver that never fills the field in (as
    augerd's ROS 2 input reads them): the accelerometer's columns empty and why said; the heading
    and rate of the same messages kept. A measured one is kept (float64 on the wire: exactly)."""
    t, cols = synthetic_log(tmp_path / "in.csv", seconds=4)
    bag = bag_of(tmp_path, "sqlite3", imu_acceleration="measured", name="measured")
    assert run_import(bag, "--out", tmp_path / "measured.csv", "--terrain", "sand")[0] == 0
    _, got = read_log(tmp_path / "measured.csv")
    for c in ("imu_ax_mps2", "imu_ay_mps2"):
        np.testing.assert_array_equal(got[c], cols[c])
    bag = bag_of(tmp_path, "sqlite3", imu_acceleration=acceleration)
    code, out, err = run_import(bag, "--out", tmp_path / "out.csv", "--terrain", "sand")
    assert code == 0, err
    _, got = read_log(tmp_path / "out.csv")
    assert np.isnan(got["imu_ax_mps2"]).all() and np.isnan(got["imu_ay_mps2"]).all()
    np.testing.assert_allclose(got["imu_r_radps"], 0.1)
    assert not np.isnan(got["imu_psi_rad"]).any()
    assert ("column imu_ax_mps2 (/bno080_imu field linear_acceleration.x): 401 of 401 samples left empty, "
            + why) in err


@pytest.mark.parametrize("storage,stripped", [("sqlite3", True), ("sqlite3", False), ("mcap", False)])
@pytest.mark.parametrize("versions", [{FEEDBACK: 1}, {FEEDBACK: 2, COMMAND: 3}, {COMMAND: 1}],
                         ids=["feedback-2021-04", "before-2021-04", "command-int32-2023"])
def test_every_version_of_the_group_messages(tmp_path, storage, stripped, versions):
    """Bags of the group's older message versions: read from the bag's definition when it has one,
    else by what its bytes fit; a field the version lacks leaves its optional column empty."""
    t, cols = synthetic_log(tmp_path / "in.csv", seconds=4)
    bag = bag_of(tmp_path, storage, stripped, versions=versions)
    code, out, err = run_import(bag, "--out", tmp_path / "out.csv", "--terrain", "sand")
    assert code == 0, err
    _, got = read_log(tmp_path / "out.csv")
    for i in range(4):
        np.testing.assert_allclose(got["omega_rpm_%d" % i], cols["omega_rpm_%d" % i], rtol=2e-7)
        np.testing.assert_allclose(got["current_a_%d" % i], cols["current_a_%d" % i], rtol=2e-7)
        held = cols["cmd_rpm_%d" % i][(np.arange(len(t)) // 10) * 10]
        np.testing.assert_array_equal(got["cmd_rpm_%d" % i], held)
    old_feedback = versions.get(FEEDBACK, 0) > 0
    assert np.isnan(got["voltage_v_0"]).all() == old_feedback
    if old_feedback:
        assert "has no field 'motor_voltage_v'" in err and "voltage_v_3 (/front_left/motor_module)" in err
    for typ, k in versions.items():
        label = VERSIONS[typ][k][0]
        assert ("decoded as %s %s" % (typ.rsplit("/", 1)[1], label) in out) == stripped, out


def _custom_bag(path, storage, typ, text, value_of, topic="/motor0/motor_rpm_setpoint"):
    """The group's feedback topics (current version) plus one topic of a type of our own."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg(VERSIONS[FEEDBACK][0][1], FEEDBACK))
    if text:
        store.register(get_types_from_msg(text, typ))
    T = store.types
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3) as w:
        fb = [w.add_connection("/%s/motor_module" % p, FEEDBACK, typestore=store) for p in POSITIONS]
        own = w.add_connection(topic, typ, typestore=store)
        for k in range(200):
            ns = T0_NS + k * 10_000_000
            h = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
                                         frame_id="")
            for i, c in enumerate(fb):
                m = T[FEEDBACK](header=h, motor_id=str(i), motor_rpm=float(k), motor_current_ma=1.0, motor_voltage_v=2.0)
                w.write(c, ns, store.serialize_cdr(m, FEEDBACK))
            m = T[typ](**value_of(T, h, k))
            w.write(own, ns, store.serialize_cdr(m, typ))
    return path


def test_optional_topic_that_fits_no_definition_is_dropped(tmp_path):
    """Setpoints of a version nobody knows (float64) in a bag without definitions: the topic is
    dropped with a warning, the import goes on."""
    text = "std_msgs/Header header\nstring motor_id\nfloat64 motor_rpm_goal\n"
    bag = _custom_bag(tmp_path / "bag", "sqlite3", COMMAND, text,
                      lambda T, h, k: dict(header=h, motor_id="0", motor_rpm_goal=float(k)))
    strip_definitions(bag)
    code, out, err = run_import(bag, "--out", tmp_path / "out.csv", "--terrain", "sand")
    assert code == 0, err
    assert ("topic /motor0/motor_rpm_setpoint: its messages (36 bytes) fit none of MotorModuleCommand int8 "
            "motor_rpm_goal") in err and "dropped, columns cmd_rpm_0 left empty" in err
    _, got = read_log(tmp_path / "out.csv")
    assert np.isnan(got["cmd_rpm_0"]).all() and len(got["t_s"]) == 200


def test_msg_gives_a_definition_the_bag_lacks(tmp_path):
    """A type of another package in a definition-less bag: refused naming --msg; with --msg
    TYPE=FILE (or a map's [msg]) it is read."""
    typ, text = "rig_msgs/msg/Wheel", "std_msgs/Header header\nfloat64 rpm\nuint8 flags\n"
    bag = _custom_bag(tmp_path / "bag", "sqlite3", typ, text,
                      lambda T, h, k: dict(header=h, rpm=0.5 * k, flags=3), topic="/wheel")
    strip_definitions(bag)
    cols = "".join('omega_rpm_%d = { topic = "/%s/motor_module", field = "motor_rpm" }\n' % (i, p)
                   for i, p in enumerate(POSITIONS))
    (tmp_path / "map.toml").write_text("schema = 1\n[columns]\n" + cols + 'pwm_0 = { topic = "/wheel", field = "rpm" }\n')
    code, _, err = run_import(bag, "--out", tmp_path / "a.csv", "--map", tmp_path / "map.toml")
    assert code == 2
    assert ("topic /wheel (columns pwm_0): its type rig_msgs/msg/Wheel is neither defined in the bag nor given "
            "with --msg rig_msgs/msg/Wheel=FILE") in err
    (tmp_path / "wheel.msg").write_text(text)
    code, _, err = run_import(bag, "--out", tmp_path / "a.csv", "--map", tmp_path / "map.toml",
                              "--msg", "rig_msgs/Wheel=%s" % (tmp_path / "wheel.msg"))
    assert code == 0, err
    _, got = read_log(tmp_path / "a.csv")
    np.testing.assert_array_equal(got["pwm_0"], 0.5 * np.arange(200))
    (tmp_path / "map2.toml").write_text("schema = 1\n[msg]\n\"rig_msgs/msg/Wheel\" = \"\"\"\n%s\"\"\"\n[columns]\n%s"
                                        'pwm_0 = { topic = "/wheel", field = "rpm" }\n' % (text, cols))
    code, _, err = run_import(bag, "--out", tmp_path / "b.csv", "--map", tmp_path / "map2.toml")
    assert code == 0, err
    assert (tmp_path / "a.csv").read_text().split("\n", 3)[3] == (tmp_path / "b.csv").read_text().split("\n", 3)[3]
    # a definition that does not fit the bytes (a field too many) is said, per topic
    (tmp_path / "wrong.msg").write_text(text + "float64 extra\n")
    code, _, err = run_import(bag, "--out", tmp_path / "c.csv", "--map", tmp_path / "map.toml",
                              "--msg", "rig_msgs/msg/Wheel=%s" % (tmp_path / "wrong.msg"))
    assert code == 2 and "topic /wheel: message 1 (rig_msgs/msg/Wheel as --msg rig_msgs/msg/Wheel=" in err


def test_terrain_is_never_assumed(tmp_path):
    bag = bag_of(tmp_path)
    code, out, err = run_import(bag, "--out", tmp_path / "a.csv", "--json")
    assert code == 0, err
    meta, _ = read_log(tmp_path / "a.csv")
    assert "terrain" not in meta
    doc = json.loads(out)
    assert doc["terrain"] is None
    assert any("no terrain given" in w and "--terrain NAME" in w for w in doc["warnings"])
    assert "no terrain given" in err
    code, out, err = run_import(bag, "--out", tmp_path / "b.csv", "--terrain", "frozen_grass")
    assert code == 0 and "terrain" not in err
    assert read_log(tmp_path / "b.csv")[0]["terrain"] == "frozen_grass"


def step_clock(kind):
    """A clock that steps 5 s forward at 2 s, or 1.5 s back at 3 s (row times since the start)."""
    if kind == "forward":
        return lambda t: t + 5_000_000_000 if t >= 2_000_000_000 else t
    return lambda t: t - 1_500_000_000 if t >= 3_000_000_000 else t


@pytest.mark.parametrize("storage", STORAGES)
@pytest.mark.parametrize("kind", ["forward", "back"])
def test_clock_step_is_refused_or_split(tmp_path, storage, kind):
    t, cols = synthetic_log(tmp_path / "in.csv", seconds=6)
    bag = bag_of(tmp_path, storage, clock=step_clock(kind))
    code, _, err = run_import(bag, "--out", tmp_path / "run.csv", "--terrain", "sand")
    assert code == 2
    if kind == "forward":
        assert "every mapped topic is silent for 5.010 s, from t = 1.990 s to 7.000 s" in err
    else:
        assert "the clock steps back by 1.50 s at t = 2.990 s (10 topics together: stamps 1.500..2.990 s" in err
    assert "--split writes each stretch" in err
    assert sorted(os.listdir(tmp_path)) == ["bag", "in.csv"]
    code, out, err = run_import(bag, "--out", tmp_path / "run.csv", "--terrain", "sand", "--split")
    assert code == 0, err
    (m1, a), (m2, b) = read_log(tmp_path / "run-1.csv"), read_log(tmp_path / "run-2.csv")
    first = 2.99 if kind == "back" else 1.99
    assert len(a["t_s"]) == round(first * 100) + 1 and len(b["t_s"]) == len(t) - len(a["t_s"])
    np.testing.assert_allclose(np.concatenate([a["omega_rpm_1"], b["omega_rpm_1"]]), cols["omega_rpm_1"], rtol=2e-7)
    assert m1["t0_unix_s"] == "1767225600"
    assert m2["t0_unix_s"] == ("1767225607" if kind == "forward" else "1767225601.5")
    assert "stretch 2 of 2, --split" in m2["source"]
    assert out.splitlines()[-1].startswith("next: auger compare %s (each stretch" % (tmp_path / "run-1.csv"))


def test_a_span_beyond_the_limit_is_refused_at_once(tmp_path):
    """10 messages per screw over 1e14 ns (and 1e16): refused with the span, nothing written."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg(VERSIONS[FEEDBACK][0][1], FEEDBACK))
    T = store.types
    for span in (10**14, 10**16):
        bag = tmp_path / ("bag%d" % span)
        with Writer(bag, version=9, storage_plugin=StoragePlugin.SQLITE3) as w:
            cs = [w.add_connection("/%s/motor_module" % p, FEEDBACK, typestore=store) for p in POSITIONS]
            for k in range(10):
                ns = T0_NS + k * span // 9
                h = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
                                             frame_id="")
                for i, c in enumerate(cs):
                    m = T[FEEDBACK](header=h, motor_id=str(i), motor_rpm=1.0, motor_current_ma=0.0, motor_voltage_v=0.0)
                    w.write(c, ns, store.serialize_cdr(m, FEEDBACK))
        start = time.monotonic()
        code, _, err = run_import(bag, "--out", tmp_path / "out.csv")
        assert time.monotonic() - start < 10
        assert code == 2
        assert "its mapped topics span %.1f s (%.1f h: %d rows at 100 Hz, more than max_rows 8640000)" % (
            span / 1e9, span / 3.6e12, span // 10**7 + 1) in err
        assert "falls silent 9 times" in err
        assert not (tmp_path / "out.csv").exists()
    # one dense stretch longer than a map's max_rows
    bag = bag_of(tmp_path)
    cols = "".join('omega_rpm_%d = { topic = "/%s/motor_module", field = "motor_rpm" }\n' % (i, p)
                   for i, p in enumerate(POSITIONS))
    (tmp_path / "map.toml").write_text("schema = 1\nmax_rows = 100\n[columns]\n" + cols)
    code, _, err = run_import(bag, "--out", tmp_path / "out.csv", "--map", tmp_path / "map.toml")
    assert code == 2 and "the four screw speeds span 4.0 s (0.0 h): 401 rows at 100 Hz, more than max_rows 100" in err


@pytest.mark.parametrize("storage", STORAGES)
@pytest.mark.parametrize("imu", ["fused", "none"])
def test_a_bag_without_pose_suggests_what_takes_it(tmp_path, storage, imu):
    """Without pose, next: names compare where the IMU heading is there (and compare accepts the
    log, where the built program is at hand), else merge or export."""
    bag = bag_of(tmp_path, storage, pose_type=None, imu_orientation=imu)
    code, out, err = run_import(bag, "--out", tmp_path / "out.csv", "--terrain", "sand")
    assert code == 0, err
    assert "topic /robot_pose is not in the bag: columns x_m, y_m, psi_rad left empty" in err
    last = out.splitlines()[-1]
    if imu == "fused":
        assert last.startswith("next: auger compare %s (the log has no pose" % (tmp_path / "out.csv"))
        if os.environ.get("AUGER_BIN"):
            p = subprocess.run([os.environ["AUGER_BIN"], "compare", str(tmp_path / "out.csv"), "--json"],
                               capture_output=True, text=True, timeout=120)
            assert p.returncode == 0, p.stderr
            assert any("the log has no pose" in w for w in json.loads(p.stdout)["warnings"])
    else:
        assert last.startswith("next: auger merge %s CAMERA_LOG --out merged.csv" % (tmp_path / "out.csv"))
        assert "auger export %s --mcap" % (tmp_path / "out.csv") in last and "compare" not in last.split("(")[0]


@pytest.mark.parametrize("storage", STORAGES)
@pytest.mark.parametrize("pose_type", ["geometry_msgs/msg/PoseWithCovarianceStamped", "nav_msgs/msg/Odometry"])
def test_pose_types_other_than_pose_stamped(tmp_path, storage, pose_type):
    a = bag_of(tmp_path, storage, name="a")
    b = bag_of(tmp_path, storage, name="b", pose_type=pose_type)
    assert run_import(a, "--out", tmp_path / "a.csv", "--terrain", "sand")[0] == 0
    code, _, err = run_import(b, "--out", tmp_path / "b.csv", "--terrain", "sand")
    assert code == 0, err
    assert (tmp_path / "a.csv").read_text().replace("of a\n", "of b\n") == (tmp_path / "b.csv").read_text()


def test_pose_as_transform_stamped(tmp_path):
    def tf(T, h, k):
        return dict(header=h, child_frame_id="base_link", transform=T["geometry_msgs/msg/Transform"](
            translation=T["geometry_msgs/msg/Vector3"](x=0.01 * k, y=-1.0, z=0.0),
            rotation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(0.25), w=math.cos(0.25))))
    bag = _custom_bag(tmp_path / "bag", "mcap", "geometry_msgs/msg/TransformStamped", "", tf, topic="/robot_pose")
    code, _, err = run_import(bag, "--out", tmp_path / "out.csv", "--terrain", "sand")
    assert code == 0, err
    _, got = read_log(tmp_path / "out.csv")
    np.testing.assert_allclose(got["x_m"], 0.01 * np.arange(200), atol=1e-12)
    np.testing.assert_allclose(got["psi_rad"], 0.5, atol=1e-12)


def test_pose_of_an_unknown_layout_points_to_the_map(tmp_path):
    text = "std_msgs/Header header\nfloat64 east\nfloat64 north\n"
    bag = _custom_bag(tmp_path / "bag", "mcap", "rig_msgs/msg/Fix", text,
                      lambda T, h, k: dict(header=h, east=1.0, north=2.0), topic="/robot_pose")
    m = (tmp_path / "map.toml")
    m.write_text("schema = 1\n[columns]\n" + "".join(
        'omega_rpm_%d = { topic = "/%s/motor_module", field = "motor_rpm" }\n' % (i, p) for i, p in enumerate(POSITIONS))
        + 'x_m = { topic = "/robot_pose", field = ["pose.position.x", "pose.pose.position.x"] }\n')
    code, _, err = run_import(bag, "--out", tmp_path / "out.csv", "--map", m)
    assert code == 2
    assert "column x_m: /robot_pose (rig_msgs/msg/Fix) has no field 'pose'" in err
    assert "give a map (--map FILE, docs/formats.md) whose x_m names its field" in err


def test_files_are_read_with_limits(tmp_path):
    bag = bag_of(tmp_path)
    (tmp_path / "big.toml").write_text("#" * (1 << 20) + "\nschema = 1\n")
    os.mkfifo(tmp_path / "fifo.toml")
    cases = [("--map", "/dev/zero", "/dev/zero: the map is not a regular file"),
             ("--map", str(tmp_path / "fifo.toml"), "fifo.toml: the map is not a regular file"),
             ("--map", str(tmp_path), ": the map is a directory"),
             ("--map", str(tmp_path / "big.toml"), "the map is 1048588 bytes, more than the 1048576"),
             ("--msg", "robominer_msgs/msg/MotorModuleFeedback=/dev/zero", "the .msg file is not a regular file"),
             ("--msg", "robominer_msgs/msg/MotorModuleFeedback", "give TYPE=FILE"),
             ("--msg", "no type=x.msg", "is not a message type name")]
    for opt, value, want in cases:
        start = time.monotonic()
        code, _, err = run_import(bag, "--out", tmp_path / "out.csv", opt, value)
        assert time.monotonic() - start < 5, opt
        assert code == 2 and want in err, (value, err)
    assert not (tmp_path / "out.csv").exists()


def test_cut_mcap_files_are_errors_not_tracebacks(tmp_path):
    full = bag_of(tmp_path, "mcap") / "bag.mcap"
    data = full.read_bytes()
    for n in (8, len(data) // 2, len(data) - 10):
        (tmp_path / "cut.mcap").write_bytes(data[:n])
        code, _, err = run_import(tmp_path / "cut.mcap", "--out", tmp_path / "out.csv")
        assert code == 2, n
        assert "cut.mcap (%d bytes) ends without the MCAP footer: the file is cut short" % n in err
        assert "Traceback" not in err
    (tmp_path / "x.mcap").write_bytes(b"not mcap at all")
    code, _, err = run_import(tmp_path / "x.mcap", "--out", tmp_path / "out.csv")
    assert code == 2 and "does not start with the MCAP magic bytes" in err


def test_json_output(tmp_path):
    bag = bag_of(tmp_path, "mcap", feedback_every=20)
    code, out, err = run_import(bag, "--out", tmp_path / "out.csv", "--terrain", "gravel", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["command"] == "import" and doc["terrain"] == "gravel" and doc["warnings"] == []
    o = doc["outputs"][0]
    assert o["out"] == str(tmp_path / "out.csv") and o["rows"] == 401 and o["rows_with_pose"] == 81
    assert o["rows_measured"]["omega_rpm_0"] == 21 and o["rows_measured"]["imu_r_radps"] == 401
    fb = next(s for s in doc["sources"] if s["source"] == "/front_right/motor_module")
    assert fb["samples"] == 21 and math.isclose(fb["rate_hz"], 5.0) and fb["modes"] == ["sparse"]
    assert doc["next"] == "auger compare %s" % (tmp_path / "out.csv")
    code, out, _ = run_import(bag, "--list-topics", "--json")
    topics = {t["topic"]: t for t in json.loads(out)["topics"]}
    assert topics["/bno080_imu"] == {"topic": "/bno080_imu", "type": "sensor_msgs/msg/Imu", "messages": 401}


def test_header_clock_reads_the_stamps_in_the_messages(tmp_path):
    """clock = "header": header.stamp instead of the recorder's stamps (here the same instants,
    the receive stamps shifted by 7 s in the bag); a type without a header is refused."""
    synthetic_log(tmp_path / "in.csv", seconds=2)
    bag = bag_of(tmp_path)
    shifted = bag_of(tmp_path, name="shifted", stripped=True)
    import sqlite3
    con = sqlite3.connect(next(shifted.glob("*.db3")))
    con.execute("UPDATE messages SET timestamp = timestamp + 7000000000")
    con.commit()
    con.close()
    cols = "".join('omega_rpm_%d = { topic = "/%s/motor_module", field = "motor_rpm" }\n' % (i, p)
                   for i, p in enumerate(POSITIONS))
    (tmp_path / "map.toml").write_text('schema = 1\nclock = "header"\n[columns]\n' + cols)
    assert run_import(bag, "--out", tmp_path / "a.csv", "--map", tmp_path / "map.toml")[0] == 0
    assert run_import(shifted, "--out", tmp_path / "b.csv", "--map", tmp_path / "map.toml")[0] == 0
    assert (tmp_path / "a.csv").read_text() == (tmp_path / "b.csv").read_text().replace("of shifted", "of bag")
    old = bag_of(tmp_path, name="old", stripped=True, versions={FEEDBACK: 2})
    code, _, err = run_import(old, "--out", tmp_path / "c.csv", "--map", tmp_path / "map.toml")
    assert code == 2 and "topic /front_right/motor_module (robominer_msgs/msg/MotorModuleFeedback) has no header" in err


@pytest.mark.parametrize("storage", STORAGES)
@pytest.mark.parametrize("mode", ["MESSAGE", "FILE"])
def test_zstd_compressed_bags(tmp_path, storage, mode, monkeypatch):
    """rosbag2's zstd compression, per message and per file: the same log as uncompressed (the
    recording-order reader decompresses what the storage does not)."""
    from rosbags.rosbag2 import CompressionFormat, CompressionMode
    plain = bag_of(tmp_path, storage, name="plain")
    init = Writer.__init__

    def compressed(self, *a, **k):
        init(self, *a, **k)
        self.set_compression(getattr(CompressionMode, mode), CompressionFormat.ZSTD)
    monkeypatch.setattr(Writer, "__init__", compressed)
    packed = bag_of(tmp_path, storage, name="packed")
    assert run_import(plain, "--out", tmp_path / "a.csv", "--terrain", "sand")[0] == 0
    code, _, err = run_import(packed, "--out", tmp_path / "b.csv", "--terrain", "sand")
    assert code == 0, err
    assert (tmp_path / "a.csv").read_text().replace("of plain", "of packed") == (tmp_path / "b.csv").read_text()


def test_values_beyond_the_log_bounds_are_left_out(tmp_path):
    """A screw speed of 500 rpm (beyond the format's +-327.67) or NaN on one row: that sample
    left out with a warning; the log stays readable by every auger tool."""
    t, cols = synthetic_log(tmp_path / "in.csv", seconds=2)
    cols["omega_rpm_2"][50] = 500.0
    cols["imu_r_radps"][70] = math.inf
    from conftest import write_log
    write_log(tmp_path / "in.csv", t, cols)
    bag = bag_of(tmp_path)
    code, _, err = run_import(bag, "--out", tmp_path / "out.csv", "--terrain", "sand")
    assert code == 0, err
    assert ("column omega_rpm_2 (/rear_left/motor_module field motor_rpm): 1 of 201 samples left empty, outside "
            "+-327.67, the log format's bound (docs/log-format.md) (the first: message 51 at t = 0.500 s, 500)") in err
    assert "column imu_r_radps (/bno080_imu field angular_velocity.z): 1 of 201 samples left empty, not a finite" in err
    _, got = read_log(tmp_path / "out.csv")
    assert np.isnan(got["omega_rpm_2"][50]) and np.isnan(got["imu_r_radps"][70])
    assert np.isnan(got["omega_rpm_2"]).sum() == 1


def _sqlite_topic(bag, name):
    import sqlite3
    con = sqlite3.connect(next(bag.glob("*.db3")))
    return con, con.execute("SELECT id FROM topics WHERE name = ?", (name,)).fetchone()[0]


def test_undecodable_messages_of_an_optional_topic_are_left_out(tmp_path):
    bag = bag_of(tmp_path)
    con, tid = _sqlite_topic(bag, "/bno080_imu")
    ids = [r[0] for r in con.execute("SELECT id FROM messages WHERE topic_id = ? ORDER BY id", (tid,))]
    con.executemany("UPDATE messages SET data = X'0001000000' WHERE id = ?", [(ids[11],), (ids[300],)])
    con.commit()
    con.close()
    code, _, err = run_import(bag, "--out", tmp_path / "out.csv", "--terrain", "sand")
    assert code == 0, err
    assert "topic /bno080_imu: 2 messages cannot be decoded (the first: message 12 at t = 0.110 s" in err
    _, got = read_log(tmp_path / "out.csv")
    assert np.isnan(got["imu_r_radps"]).sum() == 2 and np.isnan(got["imu_r_radps"][[11, 300]]).all()


def test_one_topic_stepping_back_alone_is_refused(tmp_path):
    """Only the IMU's stamps go back 1.5 s at 2 s: no clock step of the recording, a source of
    its own; refused naming it and another topic."""
    bag = bag_of(tmp_path)
    con, tid = _sqlite_topic(bag, "/bno080_imu")
    con.execute("UPDATE messages SET timestamp = timestamp - 1500000000 WHERE topic_id = ? AND timestamp >= ?",
                (tid, T0_NS + 2_000_000_000))
    con.commit()
    con.close()
    code, _, err = run_import(bag, "--out", tmp_path / "out.csv", "--terrain", "sand")
    assert code == 2
    assert "topic /bno080_imu's stamps go back by 1.490 s at t = 1.990 s, but topic /front_right/motor_module's do not" in err
    assert "do not share one clock" in err


def test_one_module_silent_is_said(tmp_path):
    """One screw's feedback missing for 2 s while every other topic goes on: no clock step (the
    import goes on) but a warning, since the workbench holds that screw speed through it."""
    t, cols = synthetic_log(tmp_path / "in.csv", seconds=5)
    bag = bag_of(tmp_path)
    con, tid = _sqlite_topic(bag, "/rear_left/motor_module")
    con.execute("DELETE FROM messages WHERE topic_id = ? AND timestamp > ? AND timestamp < ?",
                (tid, T0_NS + 1_000_000_000, T0_NS + 3_000_000_000))
    con.commit()
    con.close()
    code, out, err = run_import(bag, "--out", tmp_path / "out.csv", "--terrain", "sand")
    assert code == 0, err
    assert ("topic /rear_left/motor_module is silent 1 times for longer than max_gap_s while other topics go on "
            "(the longest 2.000 s, from t = 1.000 s); the workbench holds the last screw speed") in err
    _, got = read_log(tmp_path / "out.csv")
    assert len(got["t_s"]) == len(t) and np.isnan(got["omega_rpm_2"][101:300]).all()
