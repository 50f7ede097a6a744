#!/usr/bin/env python3
"""An independent log generator for the model workbench (issue 25; docs/workbench-suite.md "The
independent generator"): robot logs in augerd's format from the paper's model with effects in
physical forms of this generator's own, sizes from just visible to dominant, and a truth file
beside the log.

  gen_indep.py --class C --seed N --out LOG.csv [--seconds 240] [--drive open|closed|auto]
               [--terrain sand|frozen_grass|auto] [--form FORM] [--size S[,S]]

C is clean, single:FAMILY, pair, pair:FAMILY+FAMILY, outside:MECHANISM, pair_outside
(`gen_indep.py --list` prints them). Writes LOG.csv and LOG.truth.json; deterministic per
(class, seed).
"""
import argparse
import json
import math
import os
import sys
import time
import zlib

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import indep_effects as fx  # noqa: E402
import indep_effects_env as fe  # noqa: E402
import indep_outside as fo  # noqa: E402
import indep_sensors as fs  # noqa: E402
from indep_drive import (CLOSED_KINDS, OPEN_KINDS, PROVIDES, Controller, manual_plan,  # noqa: E402
                         paper_plan)
from indep_run import DT_S, Sensors, Visibility, hermite, simulate  # noqa: E402

FAMILIES = {
    "paper_params": [fe.ParamsAxisOpposed, fe.ParamsAllScaled, fe.ParamsYawDrag],
    "coulomb_friction": [fx.CoulombSignDof, fx.CoulombTanhDof, fx.CoulombContact],
    "stick_slip_friction": [fx.StribeckGaussDof, fx.StaticKineticDof, fx.StribeckContact],
    "quadratic_drag": [fx.QuadIsotropic, fx.QuadPowerDof, fx.QuadContact],
    "screw_traction_loss": [fx.LossConstant, fx.LossSpeed, fx.LossIntermittent],
    "traction_saturation": [fx.SatScrewExp, fx.SatAxisTanh, fx.SatTotalClip],
    "force_lag": [fx.LagSpeed, fx.LagTwoStage, fx.LagDeadTime, fx.LagAsymmetric],
    "screw_dead_band": [fx.DeadRampJoin, fx.DeadSmooth, fx.DeadAsymmetric],
    "terrain_slope": [fe.SlopePlane, fe.SlopeHill, fe.SlopeLoadTransfer],
    "resistance_offset": [fe.OffsetFront, fe.OffsetLateral, fe.OffsetSpeed],
    "pose_time_offset": [fs.LatencyConst, fs.LatencyJitter, fs.LatencyDrift],
    "imu_heading_bias": [fs.BiasConst, fs.BiasStep, fs.BiasSettling, fs.BiasCompass],
    "imu_heading_drift": [fs.DriftLinear, fs.DriftRandomWalk, fs.DriftWarmup],
    "terrain_change": [fe.TerrainAbrupt, fe.TerrainTransition, fe.TerrainPatch],
    "rigid_body_coupling": [fe.CoriolisScaled, fe.CoriolisAddedMass, fe.CoriolisComOffset],
    "yaw_time_constant": [fe.YawInertia, fe.YawTorqueLag, fe.YawSoilSpring],
    "screw_blocking": [fe.BlockHard, fe.BlockSmooth, fe.BlockSinking],
}
OUTSIDE = {c.mechanism: c for c in (fo.BackwardWeak, fo.SpeedSquared, fo.Furrows, fo.AngleRipple,
                                    fo.Sinking, fo.BentScrew, fo.BatterySag, fo.Backlash,
                                    fo.TurnTraction, fo.FieldRows)}
VIS_MIN = 2.0               # the strongest channel's visibility at the smallest size drawn
CHANNELS = ("x", "y", "psi", "imu_psi", "imu_r")


def classes():
    return (["clean", "pair", "pair_outside"] + ["single:" + f for f in FAMILIES]
            + ["outside:" + m for m in OUTSIDE])


class Env:
    """What an effect may know when it draws its parameters: terrain, length, the path the
    robot takes without effects (for patches and hills on its way)."""

    def __init__(self, terrain, seconds, run):
        self.terrain, self.seconds = terrain, seconds
        tr = run["truth"]
        self.path = (np.arange(len(tr)) * DT_S, tr[:, 0], tr[:, 1])
        self.path_length_m = tr[-1, 6]


def pick_effects(cls, rng, form):
    """[(kind, name, class)] for the case class; raises ValueError on an unknown class."""
    fams = list(FAMILIES)

    def lib(name):
        forms = FAMILIES[name]
        if form:
            hit = [c for c in forms if c.form == form]
            if not hit:
                raise ValueError("family %s has no form %r (forms: %s)"
                                 % (name, form, ", ".join(c.form for c in forms)))
            return ("family", name, hit[0])
        return ("family", name, forms[int(rng.integers(len(forms)))])

    if cls == "clean":
        return []
    if cls.startswith("single:") and cls[7:] in FAMILIES:
        return [lib(cls[7:])]
    if cls.startswith("outside:") and cls[8:] in OUTSIDE:
        return [("outside", cls[8:], OUTSIDE[cls[8:]])]
    if cls == "pair":
        a, b = rng.choice(len(fams), size=2, replace=False)
        return [lib(fams[int(a)]), lib(fams[int(b)])]
    if cls.startswith("pair:"):
        names = cls[5:].split("+")
        if len(names) == 2 and names[0] != names[1] and all(n in FAMILIES for n in names):
            return [lib(n) for n in names]
    if cls == "pair_outside":
        mech = list(OUTSIDE)[int(rng.integers(len(OUTSIDE)))]
        return [lib(fams[int(rng.integers(len(fams)))]), ("outside", mech, OUTSIDE[mech])]
    raise ValueError("unknown class %r (gen_indep.py --list)" % cls)


def choose_drive(rng, drive, needs):
    kinds = {"open": OPEN_KINDS, "closed": CLOSED_KINDS,
             "auto": OPEN_KINDS + CLOSED_KINDS}[drive]
    fit = [k for k in kinds if needs <= PROVIDES[k]] or [k for k in OPEN_KINDS + CLOSED_KINDS
                                                         if needs <= PROVIDES[k]]
    if drive == "auto":      # as often open as closed loop
        op = [k for k in fit if k in OPEN_KINDS]
        cl = [k for k in fit if k in CLOSED_KINDS]
        fit = (op if rng.uniform() < 0.5 else cl) or fit
    return str(fit[int(rng.integers(len(fit)))])


def build_case(cls, seed, seconds, drive, terrain, form, attempt=0):
    ss = np.random.SeedSequence([seed, zlib.crc32(cls.encode())] + ([attempt] if attempt else []))
    r_case, r_drive, r_noise, r_motor, r_size, *r_eff = [np.random.default_rng(s) for s in ss.spawn(8)]
    specs = pick_effects(cls, r_case, form)
    if terrain == "auto":
        terrain = str(r_case.choice(["sand", "frozen_grass"]))
    needs = set()
    for s in specs:
        needs |= set(s[2].needs)
    kind = choose_drive(r_case, drive, needs)
    n_rows = int(round(seconds / DT_S)) + 1
    p0 = (float(r_case.uniform(-1, 1)), float(r_case.uniform(-1, 1)),
          float(r_case.uniform(-math.pi, math.pi)))
    motor = dict(seed=int(r_motor.integers(2 ** 31)),
                 tau_s=[float(r_motor.uniform(0.05, 0.1)) for _ in range(4)],
                 ripple_rpm=float(r_motor.uniform(0.05, 0.3)), ripple_tau_s=float(r_motor.uniform(0.1, 0.5)))
    sensors = Sensors(r_noise, n_rows)
    if kind in OPEN_KINDS:
        plan = (paper_plan(r_drive, n_rows, DT_S) if kind == "paper"
                else manual_plan(r_drive, n_rows, DT_S, "combined" in needs))
        ctrl = None
    else:
        null = "stopped" not in needs and r_drive.uniform() < 0.5
        ctrl = Controller(kind, r_drive, n_rows, DT_S, p0, terrain, null)
        plan = None
    return dict(cls=cls, seed=seed, seconds=seconds, terrain=terrain, kind=kind, specs=specs,
                n_rows=n_rows, p0=p0, motor=motor, sensors=sensors, plan=plan, ctrl=ctrl,
                r_size=r_size, r_eff=r_eff)


def run_case(c, effects, n_sub):
    if c["ctrl"] is not None:
        c["ctrl"].reset()
    return simulate(c["terrain"], [e for e in effects if not e.sensor], c["p0"], c["n_rows"],
                    c["plan"], c["ctrl"], c["sensors"], c["motor"], n_sub)


def strongest(v):
    return float(np.max(v[..., :4], axis=-1)) if np.ndim(v) == 1 else np.max(v[:, :4], axis=1)


def search_size(eff, vis):
    """The smallest size whose strongest channel reaches VIS_MIN (log-interpolated on a grid
    from 1e-3 of the maximum), or None when even the maximum stays below it."""
    smax = eff.size_max()
    grid = smax * np.logspace(-3, 0, 10)
    v = strongest(vis.of(eff, grid))
    if v[-1] < VIS_MIN:
        return None, grid, v
    i = int(np.argmax(v >= VIS_MIN))
    if i == 0:
        return float(grid[0]), grid, v
    f = (math.log(VIS_MIN) - math.log(max(v[i - 1], 1e-9))) / (math.log(v[i]) - math.log(max(v[i - 1], 1e-9)))
    return float(math.exp(math.log(grid[i - 1]) + f * (math.log(grid[i]) - math.log(grid[i - 1])))), grid, v


def parse_sizes(text):
    """--size: one size per effect of the class, in class order, each a number in the effect's
    size unit (the truth's size.unit) or F% of its maximum. Returns [(value, is_fraction)];
    raises ValueError naming the bad item."""
    out = []
    for k, item in enumerate(text.split(",")):
        item = item.strip()
        frac = item.endswith("%")
        try:
            v = float(item[:-1] if frac else item)
        except ValueError:
            raise ValueError("--size item %d %r: not a number (S or F%%)" % (k + 1, item)) from None
        if not (math.isfinite(v) and v > 0):
            raise ValueError("--size item %d %r: must be > 0" % (k + 1, item))
        out.append((v / 100.0 if frac else v, frac))
    return out


def _sizes(c, sizes=None):
    """The case's effects with their size records: the clean run gives the path and the screw
    speeds the sizes are searched on. sizes (parse_sizes) replaces the drawn sizes: explicit
    sizes are not searched, drawn or bumped, and may exceed the drawn range's maximum (a
    stalling robot). Returns (effects, records, clean run)."""
    clean = run_case(c, [], 2)
    env = Env(c["terrain"], c["seconds"], clean)
    effects = [spec[2](r, env) for spec, r in zip(c["specs"], c["r_eff"])]
    vis = Visibility(c["terrain"], clean, c["sensors"], n_sub=2) if effects else None
    if sizes is not None and len(sizes) != len(effects):
        raise ValueError("--size: %d size(s) for %d effect(s) of class %s"
                         % (len(sizes), len(effects), c["cls"]))
    record = []
    for k, e in enumerate(effects):
        smin, grid, v = search_size(e, vis)
        smax = e.size_max()
        weak = smin is None
        s = smax if weak else float(math.exp(c["r_size"].uniform(math.log(smin), math.log(smax))))
        if sizes is not None:
            s = sizes[k][0] * smax if sizes[k][1] else sizes[k][0]
        record.append(dict(min=smax if weak else smin, max=smax, drawn=s, final=s, weak_at_max=weak,
                           explicit=sizes is not None, search_grid=[float(g) for g in grid],
                           search_visibility=[float(x) for x in v]))
    return effects, record, clean


def generate_full(cls, seed, seconds=240.0, drive="auto", terrain="auto", form=None, sizes=None):
    """Returns (log columns, truth dict, the run, the case). sizes: parse_sizes's list, or None
    (drawn)."""
    t_wall = time.time()
    # a drive on which an effect stays below VIS_MIN even at its maximum is drawn again
    # (up to twice; then the truth says weak_at_max)
    for attempt in range(3):
        c = build_case(cls, seed, seconds, drive, terrain, form, attempt)
        effects, record, clean = _sizes(c, sizes)
        if sizes is not None or not any(r["weak_at_max"] for r in record):
            break
    for bump in range(3):
        for e, rec in zip(effects, record):
            e.set_size(rec["final"])
            if e.sensor and hasattr(e, "camera_latency"):
                c["sensors"].latency = e.camera_latency(c["sensors"].t_frames)
        # 1 ms substeps where an effect is a hard nonlinearity, 2 ms elsewhere
        n_sub = 10 if any(getattr(e, "hard", False) for e in effects) else 5
        run = run_case(c, effects, n_sub)
        vis = Visibility(c["terrain"], run, c["sensors"], n_sub=5) if effects else None
        bumped = False
        for e, rec in zip(effects, record):
            v = vis.of(e, [rec["final"]])[0]
            rec["visibility"] = {ch: round(float(x), 3) for ch, x in zip(CHANNELS, v)}
            # the log's own screw speeds (closed loop: changed by the effect) may show the
            # drawn size below VIS_MIN: scale it up (sizes act about linearly there)
            if strongest(v) < VIS_MIN and rec["final"] < rec["max"] and bump < 2 and not rec["explicit"]:
                rec["final"] = min(rec["max"], rec["final"] * 1.2 * VIS_MIN / max(strongest(v), 1e-3))
                bumped = True
        if not bumped:
            break
    for e, rec in zip(effects, record):
        e.set_size(rec["final"])
    log = make_log(c, run, effects)
    truth = make_truth(c, effects, record, run, log, time.time() - t_wall)
    truth["drive"]["attempt"] = attempt
    return log, truth, run, c


def generate(cls, seed, seconds=240.0, drive="auto", terrain="auto", form=None, sizes=None):
    """Returns (log columns dict, truth dict)."""
    return generate_full(cls, seed, seconds, drive, terrain, form, sizes)[:2]


def _fmt(a, spec):
    return np.char.mod(spec, a)


def make_log(c, run, effects):
    """The log's columns (strings per row; empty where nothing was measured)."""
    n, se, tr = c["n_rows"], c["sensors"], run["truth"]
    cols = {"t_s": _fmt(np.arange(n) * DT_S, "%.2f")}
    for i in range(4):
        cols["omega_rpm_%d" % i] = _fmt(run["omega"][:, i], "%.4f")
    for i in range(4):
        cols["cmd_rpm_%d" % i] = _fmt(run["setpoints"][:, i], "%.2f")
    pose = np.full((n, 3), np.nan)
    ok = ~se.drop & (se.row < n)
    ts = se.t_frames + se.jitter - se.latency
    pose[se.row[ok]] = hermite(tr, run["wvel"], ts[ok]) + se.noise[ok]
    pose[:, 2] = np.remainder(pose[:, 2] + math.pi, 2 * math.pi) - math.pi
    for j, name in enumerate(("x_m", "y_m", "psi_rad")):
        col = _fmt(pose[:, j], "%.5f" if j < 2 else "%.6f")
        col[np.isnan(pose[:, j])] = ""
        cols[name] = col
    t = np.arange(n) * DT_S
    dpsi, dr = np.zeros(n), np.zeros(n)
    for e in effects:
        if e.sensor and hasattr(e, "imu"):
            a, b = e.imu(t, tr[:, 2])
            dpsi, dr = dpsi + a, dr + b
    imu_psi = tr[:, 2] + dpsi + se.imu_noise[:, 0]
    cols["imu_psi_rad"] = _fmt(np.remainder(imu_psi + math.pi, 2 * math.pi) - math.pi, "%.6f")
    cols["imu_r_radps"] = _fmt(tr[:, 5] + dr + se.imu_noise[:, 1], "%.6f")
    if c["ctrl"] is not None:
        ref = c["ctrl"].ref_np
        cols["xd_m"] = _fmt(ref[:, 0], "%.5f")
        cols["yd_m"] = _fmt(ref[:, 1], "%.5f")
        cols["psid_rad"] = _fmt(np.remainder(ref[:, 2] + math.pi, 2 * math.pi) - math.pi, "%.6f")
    return cols


def make_truth(c, effects, record, run, log, wall_s):
    ctrl = c["ctrl"]
    out = dict(format="auger-indep-truth v1", generator="tests/workbench/indep/gen_indep.py",
               case_class=c["cls"], seed=c["seed"], seconds=c["seconds"], terrain=c["terrain"],
               drive=dict(kind=c["kind"], loop="closed" if ctrl else "open",
                          controller=ctrl.gains if ctrl else None),
               start_pose=list(c["p0"]), motor=c["motor"], sensors=c["sensors"].truth(),
               path_length_m=round(float(run["truth"][-1, 6]), 3),
               max_screw_rpm=round(float(np.max(np.abs(run["omega"]))), 3))
    eff = []
    for e, rec in zip(effects, record):
        d = dict(library=e.family is not None, family=e.family, mechanism=e.mechanism, form=e.form,
                 description=" ".join(e.__doc__.split()), params=e.params,
                 size=dict(name=e.size_name, unit=e.size_unit, min=rec["min"], max=rec["max"],
                           drawn=rec["drawn"], final=rec["final"], weak_at_max=rec["weak_at_max"],
                           explicit=rec["explicit"]),
                 visibility=rec["visibility"],
                 strongest_visibility=max(rec["visibility"][ch] for ch in CHANNELS[:4]),
                 search=dict(grid=rec["search_grid"], visibility=rec["search_visibility"]))
        if e.family is None:
            d.update(variables=list(e.variables), form_string=e.form_string,
                     variable_groups=[list(x) for x in e.groups])
        eff.append(d)
    out["effects"] = eff
    out["library_families"] = sorted({e.family for e in effects if e.family})
    out["outside_mechanisms"] = sorted({e.mechanism for e in effects if e.mechanism})
    out["wall_s"] = round(wall_s, 2)
    return out


def write(path, log, truth):
    keys = list(log)
    n = len(log["t_s"])
    with open(path, "w", encoding="utf-8") as f:
        f.write("# format: auger-robot-log v1\n# terrain: %s\n" % truth["terrain"])
        f.write(",".join(keys) + "\n")
        cols = [log[k] for k in keys]
        f.write("\n".join(",".join(col[i] for col in cols) for i in range(n)))
        f.write("\n")
    base = path[:-4] if path.endswith(".csv") else path
    with open(base + ".truth.json", "w", encoding="utf-8") as f:
        json.dump(truth, f, indent=1, default=float)
        f.write("\n")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--class", dest="cls", help="clean, single:FAMILY, pair, pair:A+B, "
                    "outside:MECHANISM, pair_outside")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", help="the log to write (LOG.csv; the truth goes to LOG.truth.json)")
    ap.add_argument("--seconds", type=float, default=240.0)
    ap.add_argument("--drive", choices=("open", "closed", "auto"), default="auto")
    ap.add_argument("--terrain", choices=("sand", "frozen_grass", "auto"), default="auto")
    ap.add_argument("--form", help="the form of a single library effect (default: per seed)")
    ap.add_argument("--size", help="the effects' sizes instead of drawn ones, in class order: "
                    "S (the truth's size unit) or F%% of the size's maximum, e.g. 5 or 80%%,50%%")
    ap.add_argument("--list", action="store_true", help="print the classes and forms, then exit")
    a = ap.parse_args(argv)
    if a.list:
        for f, forms in FAMILIES.items():
            print("single:%s  forms: %s" % (f, ", ".join(c.form for c in forms)))
        for m, c in OUTSIDE.items():
            print("outside:%s  variables: %s" % (m, ", ".join(c.variables)))
        print("clean\npair\npair:FAMILY+FAMILY\npair_outside")
        return 0
    if not a.cls or not a.out:
        ap.error("--class and --out are required")
    if not 30 <= a.seconds <= 3600:
        ap.error("--seconds %g: must be within 30..3600" % a.seconds)
    try:
        sizes = parse_sizes(a.size) if a.size else None
        log, truth = generate(a.cls, a.seed, a.seconds, a.drive, a.terrain, a.form, sizes)
    except ValueError as e:
        print("gen_indep.py: %s" % e, file=sys.stderr)
        return 2
    truth["command"] = ("gen_indep.py --class %s --seed %d --seconds %g --drive %s --terrain %s%s"
                        % (a.cls, a.seed, a.seconds, a.drive, a.terrain,
                           " --form " + a.form if a.form else "")
                        + (" --size " + a.size if a.size else ""))
    write(a.out, log, truth)
    return 0


if __name__ == "__main__":
    sys.exit(main())
