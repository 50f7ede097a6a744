#!/usr/bin/env python3
"""The explain suite (issue 12; docs/workbench-suite.md "explain"): `auger explain` on logs with
several hidden effects at once, on clean logs, and on augerd-format logs of the firmware-in-the-loop
chain.

  pairs   two effects from two of the library's families per log (sizes drawn per seed from the
          ranges of run_hidden.py), 240 s; a case passes when `explain --json` names both (or a
          confusable partner, CONFUSABLE of run_hidden.py) and ends with every channel of
          final.ratio <= PAIR_MAX_RATIO; at least --min-frac of each pair class must pass.
  clean   no hidden effect: explain adds nothing and says what remains is noise.
  fil     auger-sim-drive: four modules running the firmware image, the physical robot (Coriolis
          terms, the real lever arms' yaw, blocking of stopped screws on sand), camera and IMU, the
          host controller around squares / along the helix diagonal, or a simulated joystick; a case
          passes when explain names what it added (at least one effect) and ends with every channel
          <= FIL_MAX_RATIO.
  recorded  logs augerd wrote in a real-time run of the same chain (RECORDED, in recorded/): the
          demo's sand squares, 58 s each, with the timing of a real serial line; a case passes when
          explain names the truth's effects listed there, ends with every channel <= FIL_MAX_RATIO,
          names none of those it must not, and leaves the paper's parameters (the truth's
          terrain) held or within PAPER_MAX_SHIFT of the paper's tables.

The logs carry only format and terrain metadata; the workbench never sees the truth.

Usage: run_explain.py --auger PATH --sim-log PATH --sim-drive PATH [--suite pairs,clean,fil,recorded]
                      [--seeds N] [--min-frac F] [--sample] [--only TEXT] [--jobs 2] [--keep DIR]
                      [--seconds 240]
--sample: the make-test subset (SAMPLE_PAIRS, one clean log, one FIL log, the recorded logs).
Exit 0 iff every class meets --min-frac (and every clean / FIL case passes). Python 3 stdlib only.
"""

import argparse
import concurrent.futures
import gzip
import json
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import run_hidden  # noqa: E402  (effect sizes, confusable pairs: one place)

# ---- the criteria (the numbers; never loosen them) ----
PAIR_MAX_RATIO = 1.2   # "ends with every channel <= 1.2x the noise floor"
FIL_MAX_RATIO = 1.5    # the firmware-in-the-loop chain: "<= 1.5x the noise floor in every channel"

# ---- pair classes: every library family at least once, including the examples ----
PAIR_CLASSES = [
    ("screw_dead_band", "resistance_offset"),
    ("terrain_slope", "force_lag"),
    ("terrain_change", "traction_saturation"),
    ("coulomb_friction", "imu_heading_bias"),
    ("quadratic_drag", "pose_time_offset"),
    ("screw_traction_loss", "imu_heading_drift"),
    ("stick_slip_friction", "terrain_slope"),
]
# (class, seed): the example, and cases the search once got wrong: a change of terrain
# after a saturation that imitated it, found only when its time is profiled with everything
# refitted (seed 0, in make test); stick-slip must come in place of the Coulomb friction chosen
# before it (seed 2), and a slope that the held-out segments alone refused after stick-slip (a
# breakaway placed by a hair in one of them), taken on the other splits' second opinion (seed 4):
# these two run in make test-full, which takes every class with seeds 0-4 (make test's time is
# spent elsewhere).
# A change that falls inside a held-out segment (seed 3 of that pair) has its own unit test
# ("explain: a change of terrain inside a held-out segment ...").
SAMPLE_PAIRS = [(("screw_dead_band", "resistance_offset"), 0), (("terrain_change", "traction_saturation"), 0)]

FIL_CASES = [(terrain, drive) for terrain in ("sand", "frozen_grass") for drive in ("square", "diagonal", "manual")]
SAMPLE_FIL = [("sand", "square")]
# augerd's log of the 0.5 m square on sand (null-space allocator) from `make demo` (scripts/demo.sh)
# on 2026-11-24 00:38 UTC, and the effects of the simulator's truth that explain must name there.
# explain once ended it at 2.3 times the noise floor in x: fitted jointly on its 41 s of training
# segments, the paper's parameters took up the blocking of the stopped screws.
# The second, from `make demo` at 15:54 UTC: freed on every segment at the end, the paper's
# parameters once stretched together (sigma_lat and D_y to 2.8 times the paper's, the same steady
# speeds, shorter time constants): more in BIC, no better on the 25 s segments.
# The third, from `make demo` at 16:33 UTC: a terrain change (there is none: the demo drives on one
# sand) taken on the other splits' second opinion won the final choice on its luckier split and
# ended at 1.45 times the noise floor. (The second and third in test-full only: make test's time is
# spent elsewhere.)
# Each: the log, the effects of the truth explain must name, effects it must not name.
RECORDED = [("augerd-sand-square.csv.gz", ["screw_blocking"], ["terrain_change"]),
            ("augerd-sand-square-2.csv.gz", ["screw_blocking"], ["terrain_change"]),
            ("augerd-sand-square-3.csv.gz", ["screw_blocking"], ["terrain_change"])]
SAMPLE_RECORDED = RECORDED[:1]
PAPER_MAX_SHIFT = 0.3  # re-identified paper parameters: at most 30 % from the tables
RECORDED_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "recorded")


def same_family(named, hidden):
    return named == hidden or frozenset({named, hidden}) in run_hidden.CONFUSABLE


class Case:
    def __init__(self, suite, key, seed):
        self.suite, self.key, self.seed = suite, key, seed
        self.failures, self.info = [], {}

    @property
    def name(self):
        if self.suite == "pairs":
            return "pair/" + "+".join(self.key)
        if self.suite == "fil":
            return "fil/%s/%s" % self.key
        if self.suite == "recorded":
            return "recorded/" + self.key[0].split(".")[0]
        return "clean"

    def fail(self, why):
        self.failures.append(why)


def explain(args, log, case):
    t0 = time.time()
    p = subprocess.run([args.auger, "explain", log, "--json", "--quiet"], stdout=subprocess.PIPE,
                       stderr=subprocess.PIPE, universal_newlines=True, timeout=args.timeout)
    case.info["t"] = time.time() - t0
    if p.returncode != 0:
        raise RuntimeError("explain exited %d: %s" % (p.returncode, p.stderr.strip()[-300:]))
    r = json.loads(p.stdout)
    for key in ("effects", "steps", "final", "verdict"):
        if key not in r:
            raise RuntimeError("explain --json has no '%s'" % key)
    case.info["effects"] = r["effects"]
    case.info["ratio"] = r["final"].get("ratio", {})
    case.info["verdict"] = r.get("verdict_kind")
    # The error falls step by step (held-out, each step's model refitted jointly), on one split: a
    # step taken on the other splits' second opinion is judged on its new split, against the
    # structure before it refitted there.
    steps = r["steps"]
    for prev, cur in zip(steps, steps[1:]):
        a, b = prev.get("heldout_combined"), cur.get("heldout_combined")
        second = cur.get("second_opinion")
        if second:
            split = cur.get("split")
            a = next((x.get("before") for x in second.get("splits", []) if x.get("split") == split), None)
            if a is None:
                case.fail("step %s: taken on split %s, which its second opinion does not list" % (cur.get("step"), split))
        elif prev.get("split", 1) != cur.get("split", 1):
            case.fail("step %s changed split without a second opinion" % cur.get("step"))
        if b is not None and a is not None and b > a * 1.001:
            case.fail("held-out error rose at step %s: %.3f after %.3f" % (cur.get("step"), b, a))
    return r


def worst(ratio):
    vals = [v for v in ratio.values() if isinstance(v, (int, float))]
    return max(vals) if vals else float("nan")


def check(case, args, workdir):
    base = os.path.join(workdir, case.name.replace("/", "-") + "-%d" % case.seed)
    log = base + ".csv"
    try:
        if case.suite == "recorded":
            with gzip.open(os.path.join(RECORDED_DIR, case.key[0]), "rb") as src, open(log, "wb") as dst:
                shutil.copyfileobj(src, dst)
            cmd = None
        elif case.suite == "fil":
            terrain, drive = case.key
            cmd = [args.sim_drive, "--out", log, "--terrain", terrain, "--drive", drive, "--seed", str(case.seed),
                   "--seconds", str(args.seconds), "--threads", "1"]
        else:
            cmd = [args.sim_log, "--out", log, "--seed", str(case.seed + 2000), "--seconds", str(args.seconds),
                   "--trajectory", run_hidden.TRAJECTORIES[case.seed % 2],
                   "--pose-noise-m", str(run_hidden.POSE_NOISE_M), "--psi-noise-rad", str(run_hidden.PSI_NOISE_RAD),
                   "--imu-psi-noise-rad", str(run_hidden.IMU_PSI_NOISE_RAD)]
            if case.suite == "pairs":
                gens = []
                for fam in case.key:
                    rng = random.Random("pair/%s/%s/%d" % ("+".join(case.key), fam, case.seed))
                    gens.append(run_hidden.ROBOT_EFFECTS[fam](rng))
                case.info["gen"] = gens
                for g in gens:
                    cmd += ["--effect", g]
        if cmd:
            p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
            if p.returncode != 0:
                case.fail("generator: " + p.stderr.strip()[-300:])
                return case
        r = explain(args, log, case)
    except (RuntimeError, ValueError, OSError, subprocess.TimeoutExpired) as e:
        case.fail(str(e))
        return case
    named = r["effects"]
    ratio = r["final"].get("ratio", {})
    if case.suite == "clean":
        if named:
            case.fail("no hidden effect but explain added %s" % named)
        if worst(ratio) > PAIR_MAX_RATIO:
            case.fail("no hidden effect but %.2f times the noise floor" % worst(ratio))
        return case
    if case.suite == "pairs":
        for fam in case.key:
            if not any(same_family(n, fam) for n in named):
                case.fail("%s not named (named: %s)" % (fam, ", ".join(named) or "nothing"))
        if worst(ratio) > PAIR_MAX_RATIO:
            case.fail("final error %.2f times the noise floor (limit %.1f): %s" % (worst(ratio), PAIR_MAX_RATIO, ratio))
        return case
    if case.suite == "recorded":
        for fam in case.key[1]:
            if fam not in named:
                case.fail("%s (in the truth) not named (named: %s)" % (fam, ", ".join(named) or "nothing"))
        for fam in case.key[2]:
            if fam in named:
                case.fail("%s named (not in the truth)" % fam)
        for f in r["final"].get("fitted", []):
            # "re-identified: sigma_long 1.35 N/rpm (was 0.812), ..." (held: no "was").
            for name, value, was in re.findall(r"(\w+) ([-\d.e+]+) [^,]*?\(was ([-\d.e+]+)\)", f.get("description", "")):
                if f["effect"] == "paper_params" and abs(float(value) / float(was) - 1) > PAPER_MAX_SHIFT:
                    case.fail("the paper's %s re-identified at %s (the tables, the truth: %s)" % (name, value, was))
    if not named:
        case.fail("named nothing")
    if worst(ratio) > FIL_MAX_RATIO:
        case.fail("final error %.2f times the noise floor (limit %.1f): %s" % (worst(ratio), FIL_MAX_RATIO, ratio))
    return case


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--auger", required=True)
    ap.add_argument("--sim-log", required=True)
    ap.add_argument("--sim-drive", required=True)
    ap.add_argument("--suite", default="pairs,clean,fil,recorded")
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--min-frac", type=float, default=0.8)
    ap.add_argument("--sample", action="store_true")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--only", help="run only the classes whose name contains this text")
    ap.add_argument("--keep")
    ap.add_argument("--seconds", type=float, default=240.0)
    ap.add_argument("--timeout", type=float, default=600.0)
    args = ap.parse_args()
    suites = set(args.suite.split(","))
    cases = []
    if "pairs" in suites:
        if args.sample:
            cases += [Case("pairs", key, seed) for key, seed in SAMPLE_PAIRS]
        else:
            for key in PAIR_CLASSES:
                cases += [Case("pairs", key, s) for s in range(args.seeds)]
    if "clean" in suites:
        cases += [Case("clean", None, s) for s in range(1 if args.sample else 2)]
    if "fil" in suites:
        for key in (SAMPLE_FIL if args.sample else FIL_CASES):
            cases += [Case("fil", key, s + 1) for s in range(1 if args.sample else max(1, args.seeds // 3))]
    if "recorded" in suites:
        cases += [Case("recorded", key, 0) for key in (SAMPLE_RECORDED if args.sample else RECORDED)]
    if args.only:
        cases = [c for c in cases if args.only in c.name]
    workdir = args.keep or tempfile.mkdtemp(prefix="auger-explain-")
    os.makedirs(workdir, exist_ok=True)
    t0 = time.time()
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as ex:
        done = list(ex.map(lambda c: check(c, args, workdir), cases))
    by_class = {}
    for c in done:
        by_class.setdefault(c.name, []).append(c)
        status = "ok  " if not c.failures else "FAIL"
        print("%s %-44s seed %d  %5.1f s  named %-50s worst %.2f  %s" % (
            status, c.name, c.seed, c.info.get("t", 0), ",".join(c.info.get("effects", [])) or "-",
            worst(c.info.get("ratio", {})), "; ".join(c.failures)))
    ok = True
    print("\n%-44s %s" % ("class", "passed"))
    for name, cs in sorted(by_class.items()):
        passed = sum(1 for c in cs if not c.failures)
        need = len(cs) if name.startswith("clean") else max(1, int(round(args.min_frac * len(cs) + 1e-9)))
        good = passed >= need
        ok = ok and good
        print("%-44s %d of %d (need %d)%s" % (name, passed, len(cs), need, "" if good else "  <-- FAILED"))
    print("\n%d cases, %.0f s" % (len(done), time.time() - t0))
    if ok and not args.keep:
        shutil.rmtree(workdir, ignore_errors=True)
    elif not ok:
        print("logs kept in %s" % workdir)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
