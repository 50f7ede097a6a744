"""Self-tests of the independent generator (ctest indep_gen_unit; pytest in the build venv):
the paper's signs and steady speeds, the noise a clean log carries, the visibility each effect
records, determinism."""
import argparse
import math
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import gen_indep as g  # noqa: E402
from indep_drive import PATTERN, check_kinematics  # noqa: E402
from indep_model import (KAPPA_M, POS_M, SCALAR, TERRAIN, Model, State, k_inverse, lanes,  # noqa: E402
                         steady_velocity)
from indep_run import DT_S, hermite, replay, segments  # noqa: E402


def test_screw_table_is_rigid_body_consistent():
    # docs/model-notes.md "Frames": -a_i y_i + b_i x_i = c_i = -kappa for every screw
    for (a, b, c), (x, y) in zip(k_inverse(), POS_M):
        assert -a * y + b * x == pytest.approx(c)
        assert c == pytest.approx(-KAPPA_M)
    check_kinematics()


@pytest.mark.parametrize("terrain", ["sand", "frozen_grass"])
def test_signs_and_steady_speeds(terrain):
    p = TERRAIN[terrain]
    for dof, sign_ok in (("x", (1, 0, 0)), ("y", (0, 1, 0)), ("psi", (0, 0, 1))):
        w = [10.0 * s for s in PATTERN[dof]]
        u, v, r = steady_velocity(terrain, w)
        assert [np.sign(round(a, 12)) for a in (u, v, r)] == list(sign_ok), dof
        # eq. (6) at rest: the integrator reaches D^-1 S B omega (time constants <= 0.82 s)
        st = State(SCALAR)
        m = Model(terrain)
        m.reset(SCALAR, st)
        for _ in range(int(20.0 / 0.002)):
            m.substep(SCALAR, st, w, [x * 0.002 / 60 for x in w], 0.002)
        assert (st.u, st.v, st.r) == pytest.approx((u, v, r), rel=1e-6, abs=1e-12)
    # docs/model-notes.md's red flag: the sand set gives 0.087 m/s at 15 rpm forward
    if terrain == "sand":
        assert steady_velocity("sand", [-15, -15, 15, 15])[0] == pytest.approx(
            4 * 15 * p["sigma_long"] / p["d_x"]) == pytest.approx(0.087, abs=5e-4)


def test_scalar_and_lane_backends_agree():
    X = lanes(3)
    st1, st3 = State(SCALAR), State(X)
    m1, m3 = Model("sand"), Model("sand")
    m1.reset(SCALAR, st1)
    m3.reset(X, st3)
    w = [-12.0, 4.0, 15.0, 9.0]
    for _ in range(500):
        m1.substep(SCALAR, st1, w, [x * 0.002 / 60 for x in w], 0.002)
        m3.substep(X, st3, [np.full(3, x) for x in w], [np.full(3, x * 0.002 / 60) for x in w], 0.002)
    for a in ("x", "y", "psi", "u", "v", "r"):
        assert getattr(st3, a) == pytest.approx(getattr(st1, a), rel=1e-12, abs=1e-15)


@pytest.fixture(scope="module")
def clean_case():
    log, truth, run, c = g.generate_full("clean", 3, seconds=120.0, drive="open")
    return log, truth, run, c


def test_clean_log_carries_the_injected_noise(clean_case):
    log, truth, run, c = clean_case
    se = c["sensors"]
    have = np.array([s != "" for s in log["x_m"]])
    pose = np.array([[float(v) for v in log[k][have]] for k in ("x_m", "y_m", "psi_rad")]).T
    ok = ~se.drop & (se.row < c["n_rows"])
    assert have.sum() == ok.sum()
    ts = se.t_frames + se.jitter
    err = pose - hermite(run["truth"], run["wvel"], ts[ok])
    err[:, 2] = np.remainder(err[:, 2] + math.pi, 2 * math.pi) - math.pi
    assert np.std(err, axis=0) == pytest.approx(se.std, rel=0.15)
    # the frame's row time differs from its true time by at most half a row plus the jitter
    d = se.row[ok] * DT_S - ts[ok]
    assert np.max(np.abs(d)) <= 0.005 + 3 * se.jitter_s + 1e-9
    imu = np.array([float(v) for v in log["imu_psi_rad"]]) - run["truth"][:, 2]
    imu = np.remainder(imu + math.pi, 2 * math.pi) - math.pi
    assert np.std(imu) == pytest.approx(se.imu_std[0], rel=0.1)
    frac = 1 - ok.sum() / len(ok)
    assert 0.005 < frac < 0.4
    assert truth["effects"] == [] and truth["library_families"] == []
    assert "# " not in "".join(log["t_s"][:3])


def test_clean_log_is_the_base_model_at_the_noise_floor(clean_case):
    # the logged screw speeds, open loop through eqs. (5)-(10) from the true state every 25 s,
    # reproduce the true pose far below the camera noise
    log, truth, run, c = clean_case
    pose, mask = replay(c["terrain"], [], run, 1, 5)
    starts, seg = segments(c["n_rows"])
    rows = np.minimum(starts[None, :] + np.arange(seg + 1)[:, None], c["n_rows"] - 1)
    tr = np.transpose(run["truth"][rows][:, :, :3], (0, 2, 1))
    rms = np.sqrt(np.mean(((pose - tr) ** 2)[:, :, :][np.repeat(mask[:, None, :], 3, axis=1)]
                          .reshape(-1, 3), axis=0))
    assert np.all(rms < 0.02 * c["sensors"].std)


# make test: a form for each kind of hook of the model (a screw's speed, a screw's force, the
# total drive, implicit contact damping, explicit forces, sigma and D factors, the mass, the
# screws' angles, a world-frame resistance); INDEP_ALL_FORMS=1 (make test-full): every form
# of every family and every outside mechanism
if os.environ.get("INDEP_ALL_FORMS"):
    CASES = ([("single:" + f, c.form) for f, forms in g.FAMILIES.items() for c in forms]
             + [("outside:" + m, None) for m in g.OUTSIDE])
else:
    CASES = [("single:force_lag", "speed_lag"), ("single:screw_traction_loss", "intermittent"),
             ("single:traction_saturation", "axis_tanh"), ("single:coulomb_friction", "contact_isotropic"),
             ("single:rigid_body_coupling", "com_offset"), ("single:terrain_change", "abrupt"),
             ("single:yaw_time_constant", "inertia"), ("outside:screw_angle_ripple", None),
             ("outside:heading_dependent_resistance", None), ("single:imu_heading_drift", "warmup")]


@pytest.mark.parametrize("cls,form", CASES)
def test_effect_changes_the_log_by_its_visibility(cls, form):
    log, truth, run, c = g.generate_full(cls, 5, seconds=40.0, drive="open", form=form)
    e = truth["effects"][0]
    vis = e["visibility"]
    assert max(vis[ch] for ch in ("x", "y", "psi", "imu_psi")) >= g.VIS_MIN or e["size"]["weak_at_max"]
    assert e["size"]["min"] <= e["size"]["final"] <= e["size"]["max"] * (1 + 1e-9)
    if e["library"]:
        assert e["family"] in g.FAMILIES and truth["library_families"] == [e["family"]]
    else:
        assert e["variables"] and e["form_string"]
    if e["family"] in ("pose_time_offset", "imu_heading_bias", "imu_heading_drift"):
        return     # sensors: the visibility is computed from the truth directly
    # the log's true motion against the base model's replay: the effect's own size of error
    # (within 15 %; 25 % where the replays restart an internal state of the effect at rest, more
    # where the effect says so)
    cls_ = [c for c in g.FAMILIES.get(e["family"], [g.OUTSIDE.get(e["mechanism"])]) if c.form == e["form"]][0]
    tol = max(0.25 if cls_.stateful else 0.15, cls_.replay_tolerance)
    pose, mask = replay(c["terrain"], [], run, 1, 5)
    starts, seg = segments(c["n_rows"])
    rows = np.minimum(starts[None, :] + np.arange(seg + 1)[:, None], c["n_rows"] - 1)
    tr = np.transpose(run["truth"][rows][:, :, :3], (0, 2, 1))
    for j, ch in enumerate(("x", "y", "psi")):
        got = math.sqrt(np.mean((pose[:, j] - tr[:, j])[mask] ** 2)) / c["sensors"].std[j]
        assert got == pytest.approx(vis[ch], rel=tol, abs=0.15), (ch, got, vis)


def test_deterministic_per_class_and_seed():
    a, ta = g.generate("pair", 11, seconds=30.0)
    b, tb = g.generate("pair", 11, seconds=30.0)
    assert all(np.array_equal(a[k], b[k]) for k in a) and list(a) == list(b)
    assert ta["effects"] == tb["effects"]
    c, _ = g.generate("clean", 12, seconds=30.0)
    assert not np.array_equal(a["x_m"], c["x_m"])


def test_unknown_class_is_refused():
    with pytest.raises(ValueError, match="unknown class"):
        g.pick_effects("single:nope", np.random.default_rng(1), None)
    with pytest.raises(ValueError, match="has no form"):
        g.pick_effects("single:force_lag", np.random.default_rng(1), "bogus")


def test_backlash_holds_the_screw_for_the_play_after_a_reversal():
    # a play of 0.25 turn at 10 rpm: the screw stands 1.5 s after the motor reverses, then
    # follows it at full speed (outside the library: a lost angle, not a lost time)
    from indep_model import SCALAR
    from indep_outside import Backlash
    b = Backlash.__new__(Backlash)
    b.set_size(0.25)
    b.reset(SCALAR, None, None)
    h, out = 0.002, []
    for k in range(4000):
        w = 10.0 if k < 1000 else -10.0
        out.append(b.speed(SCALAR, None, [w] * 4, h)[0])
    out = np.array(out)
    # from the middle of the play: 0.125 turn (0.75 s) before the first motion
    assert np.sum(out[:1000] == 0.0) == pytest.approx(0.75 / h, abs=2)
    stood = np.sum(out[1000:] == 0.0)
    assert stood == pytest.approx(1.5 / h, abs=2)
    assert out[-1] == pytest.approx(-10.0)


def test_runner_knows_the_generators_classes():
    import run_indep as ri
    assert list(ri.FAMILIES) == list(g.FAMILIES)
    assert sorted(ri.MECHANISMS) == sorted(g.OUTSIDE)


def _truth(*effects):
    return {"effects": [dict(library=lib, family=f if lib else None, mechanism=None if lib else f,
                             variable_groups=[["u_mps"]]) for lib, f in effects]}


def test_runner_scores_pairs_and_false_discoveries():
    import run_indep as ri
    r = {"effects": ["terrain_slope", "quadratic_drag", "imu_heading_bias"], "verdict_kind": "near_noise",
         "final": {"ratio": {"x": 1.1, "y": 0.9}}}
    c = ri.Case("pair", 1)
    ri.score(c, _truth((True, "terrain_slope"), (True, "quadratic_drag")), {}, r, 0.1)
    assert c.info["false"] == ["imu_heading_bias"] and any("also named" in f for f in c.failures)
    # an outside log ending near the noise floor with a library effect kept; the discovered
    # term's inputs miss the mechanism's variable
    c = ri.Case("outside:sideways_from_forward", 1)
    r = {"effects": ["terrain_slope"], "verdict_kind": "near_noise", "final": {"ratio": {}},
         "discovered": [{"terms": [{"inputs": ["v_mps"]}]}]}
    ri.score(c, _truth((False, "sideways_from_forward")), {}, r, 0.1)
    assert c.info["noise_with_wrong"] and not c.info["discovered_ok"] and len(c.failures) == 2
    r.update(effects=[], verdict_kind="outside_library", discovered=[{"terms": [{"inputs": ["u_mps"]}]}])
    c = ri.Case("outside:sideways_from_forward", 2)
    ri.score(c, _truth((False, "sideways_from_forward")), {}, r, 0.1)
    assert not c.failures and c.info["discovered_ok"]


def test_runner_counts_a_twin_listed_beside_the_term_apart():
    import run_indep as ri
    truth = {"effects": [dict(library=False, family=None, mechanism="battery_sag",
                              variable_groups=[["t_s"], ["omega_rpm_0", "omega_rpm_1"]])]}
    drag = {"dof": "drag", "form": "t_s", "inputs": ["t_s", "u_mps"]}
    r = {"effects": [], "verdict_kind": "outside_library", "final": {"ratio": {}},
         "discovered": [{"terms": [dict(drag)]}]}
    alone = ri.Case("outside:battery_sag", 1)
    ri.score(alone, truth, {}, r, 0.1)
    assert not alone.info["discovered_ok"] and alone.failures
    drag["alternatives"] = [{"dof": "screws", "form": "omega_rpm*t_s", "inputs": ["omega_rpm_0", "t_s"]}]
    r["discovered"] = [{"terms": [drag]}]
    twin = ri.Case("outside:battery_sag", 2)
    ri.score(twin, truth, {}, r, 0.1)
    assert twin.info["discovered_ok"] and twin.info["discovered_via_twin"] and not twin.failures


def test_runner_scores_an_effect_below_the_floor_at_its_maximum_like_a_clean_log():
    # weak_at_max: not asked to be named (nor diagnose to be significant), but nothing else may
    # be; such cases leave the singles' share for a row of their own
    import run_indep as ri
    truth = _truth((True, "rigid_body_coupling"))
    truth["effects"][0].update(size=dict(weak_at_max=True), strongest_visibility=0.6)
    quiet, wrong = ri.Case("single:rigid_body_coupling", 1), ri.Case("single:rigid_body_coupling", 2)
    ri.score(quiet, truth, {"significant": False}, {"effects": [], "verdict_kind": "unexplained"}, 0.1)
    ri.score(wrong, truth, {"significant": False}, {"effects": ["pose_time_offset"], "final": {}}, 0.1)
    assert quiet.info["weak"] and not quiet.failures
    assert wrong.info["false"] == ["pose_time_offset"] and "below the noise floor" in wrong.failures[0]
    strong = ri.Case("single:rigid_body_coupling", 3)
    ri.score(strong, _truth((True, "rigid_body_coupling")), {"significant": False}, {"effects": []}, 0.1)
    assert "weak" not in strong.info and strong.failures
    args = argparse.Namespace(min_single=0.95, min_pair=0.9, min_clean=1.0, min_outside=1.0,
                              min_discovered=0.7, max_fdr=0.05, seconds=120, jobs=1)
    rows = {r["key"]: r for r in ri.totals(args, [quiet, wrong, strong], 1.0)["rows"]}
    assert (rows["single_weak"]["ok"], rows["single_weak"]["cases"]) == (1, 2)
    assert (rows["single"]["ok"], rows["single"]["cases"]) == (0, 1)


def test_runner_counts_a_partner_named_beside_the_family_as_false():
    import run_indep as ri
    truth = ["screw_dead_band", "paper_params"]
    assert ri.unmatched(["screw_dead_band", "paper_params"], truth) == []
    assert ri.unmatched(["coulomb_friction", "quadratic_drag"], truth) == []     # partners
    assert ri.unmatched(["quadratic_drag", "screw_dead_band", "terrain_change", "paper_params"],
                        truth) == ["quadratic_drag", "terrain_change"]


def test_explicit_sizes_replace_the_drawn_ones():
    # --size: a stall beyond the drawn range (dry friction at 12 rpm of drive, the maximum
    # drawn being 8) and a percentage of the maximum; bad lists are refused by name
    log, truth = g.generate("single:coulomb_friction", 1, seconds=40.0, drive="open",
                            terrain="frozen_grass", form="hard_sign_dof", sizes=g.parse_sizes("12"))
    s = truth["effects"][0]["size"]
    assert s["final"] == 12.0 and s["drawn"] == 12.0 and s["explicit"] and s["max"] == 8.0
    _, drawn = g.generate("single:coulomb_friction", 1, seconds=40.0, drive="open",
                          terrain="frozen_grass", form="hard_sign_dof")
    assert not drawn["effects"][0]["size"]["explicit"] and drawn["effects"][0]["size"]["final"] < 8.0
    # the bigger friction moves the robot less: its path is shorter
    assert truth["path_length_m"] < drawn["path_length_m"]
    assert g.parse_sizes("50%,0.01") == [(0.5, True), (0.01, False)]
    for bad in ("0", "x", "5,-1", "nan"):
        with pytest.raises(ValueError, match="--size item"):
            g.parse_sizes(bad)
    with pytest.raises(ValueError, match="1 effect"):
        g.generate("single:coulomb_friction", 1, seconds=40.0, sizes=g.parse_sizes("1,2"))
