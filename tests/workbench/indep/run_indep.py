#!/usr/bin/env python3
"""Scores `auger diagnose` and `auger explain` on logs of the independent generator
(gen_indep.py; docs/workbench-suite.md "The independent generator"), by issue 25's criteria:

  single:FAMILY   diagnose's significant candidates[0] and explain's first named effect are the
                  family (or a confusable partner, CONFUSABLE of ../hidden/run_hidden.py)
  pair            both named, nothing else named, every channel of explain's final.ratio <= 1.2
  clean           explain names nothing
  outside:MECH    never a noise / near_noise verdict with a library effect kept; when explain
                  emits `discovered`, the terms' inputs use the mechanism's variables (one of
                  each of the truth's variable_groups)
  pair_outside    the library effect named, and the outside rule for the rest
  all logs        false-discovery rate: named effects that are in no truth, over all named

Named = explain's `effects`, plus paper_params when the final fit re-identified the paper's
parameters (its description says "(was ...)"). Prints a row per case (the reasons for a failure,
the commands to reproduce it), totals per class, the explain wall time; exits 1 when a class is
below its threshold, 2 on bad usage.

  run_indep.py --auger build/host/auger/auger [--python build/venv/bin/python3] [--seeds 5]
               [--pairs N] [--only CLASSES] [--sample] [--jobs 2] [--keep DIR]
               [--min-single 0.95] [--min-pair 0.9] [--min-clean 1] [--max-fdr 0.05]
               [--min-outside 1] [--min-discovered 0.7]
"""
import argparse
import concurrent.futures
import json
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "hidden"))
from run_hidden import CONFUSABLE  # noqa: E402  (the one home of the confusable pairs)

PAIR_MAX_RATIO = 1.2
NOISE_VERDICTS = ("noise", "near_noise")
FAMILIES = ("paper_params", "coulomb_friction", "stick_slip_friction", "quadratic_drag",
            "screw_traction_loss", "traction_saturation", "force_lag", "screw_dead_band",
            "terrain_slope", "resistance_offset", "pose_time_offset", "imu_heading_bias",
            "imu_heading_drift", "terrain_change", "rigid_body_coupling", "yaw_time_constant",
            "screw_blocking")
MECHANISMS = ("backward_weak", "speed_squared_traction", "heading_dependent_resistance",
              "screw_angle_ripple", "sinking_with_distance", "sideways_from_forward",
              "battery_sag", "lateral_speed_to_yaw", "traction_falls_with_yaw_rate",
              "periodic_in_position")
# make test's sample: about 3 minutes on 2 cores (a clean log, two single effects, a pair)
SAMPLE = [("clean", 1), ("single:terrain_slope", 1), ("single:screw_traction_loss", 1), ("pair", 1)]


def same_family(named, fam):
    return named == fam or frozenset({named, fam}) in CONFUSABLE


def worst(ratio):
    vals = [v for v in (ratio or {}).values() if isinstance(v, (int, float))]
    return max(vals) if vals else float("nan")


def explain_named(r):
    """explain's findings in order: its effects, then paper_params when re-identified."""
    named = list(r.get("effects", []))
    for f in r.get("final", {}).get("fitted", []):
        if f.get("effect") == "paper_params" and "(was" in f.get("description", "") \
                and "paper_params" not in named:
            named.append("paper_params")
    return named


def plan(args):
    if args.sample:
        return list(SAMPLE)
    seeds = range(1, args.seeds + 1)
    cases = [("clean", s) for s in seeds]
    cases += [("single:" + f, s) for f in FAMILIES for s in seeds]
    cases += [("outside:" + m, s) for m in MECHANISMS for s in seeds]
    cases += [("pair", s) for s in range(1, (args.pairs if args.pairs is not None else 4 * args.seeds) + 1)]
    cases += [("pair_outside", s) for s in range(1, (args.pair_outside if args.pair_outside is not None
                                                     else args.seeds) + 1)]
    if args.only:
        want = args.only.split(",")
        cases = [c for c in cases if any(c[0] == w or c[0].startswith(w + ":") or
                                         (w.endswith(":") and c[0].startswith(w)) for w in want)]
    return cases


class Case:
    def __init__(self, cls, seed):
        self.cls, self.seed = cls, seed
        self.failures, self.notes, self.info = [], [], {}

    @property
    def name(self):
        return "%s/%d" % (self.cls, self.seed)

    def fail(self, why):
        self.failures.append(why)


def run_json(cmd, timeout):
    t0 = time.time()
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True,
                       timeout=timeout)
    dt = time.time() - t0
    if p.returncode not in (0, 1):
        raise RuntimeError("%s exited %d: %s" % (os.path.basename(cmd[0]) + " " + cmd[1], p.returncode,
                                                 p.stderr.strip()[-300:]))
    return json.loads(p.stdout), dt


def score(case, truth, d, r):
    lib = [e["family"] for e in truth["effects"] if e["library"]]
    outside = [e for e in truth["effects"] if not e["library"]]
    named = explain_named(r)
    case.info["named"] = named
    cands = d.get("candidates", [])
    case.info["diag"] = [c.get("effect") for c in cands[:3]]
    ratio = r.get("final", {}).get("ratio", {})
    case.info["ratio"] = worst(ratio)
    case.info["verdict"] = r.get("verdict_kind")
    # false discoveries: named effects that stand for no effect of the truth
    case.info["false"] = [n for n in named if not any(same_family(n, f) for f in lib)]
    kind = case.cls.split(":")[0]
    if kind == "clean":
        if named:
            case.fail("no effect in the log, explain named %s" % ", ".join(named))
        if d.get("significant"):
            case.notes.append("diagnose significant (first %s)" % case.info["diag"][:1])
        return
    if kind == "single":
        fam = lib[0]
        first = cands[0].get("effect") if cands else None
        second_ok = (len(cands) > 1 and cands[1].get("effect") == fam and cands[0].get("near_tie")
                     and first is not None and frozenset({first, fam}) in CONFUSABLE)
        if not d.get("significant"):
            case.fail("diagnose: not significant (first %s)" % first)
        elif not (first is not None and same_family(first, fam)) and not second_ok:
            case.fail("diagnose ranks %s first" % first)
        if not named:
            case.fail("explain named nothing (%s)" % case.info["verdict"])
        elif not same_family(named[0], fam):
            case.fail("explain named %s first" % named[0])
        return
    for fam in lib:
        if not any(same_family(n, fam) for n in named):
            case.fail("%s not named (named: %s)" % (fam, ", ".join(named) or "nothing"))
    if kind.startswith("pair") and case.info["false"]:
        case.fail("also named %s" % ", ".join(case.info["false"]))
    if kind == "pair" and not worst(ratio) <= PAIR_MAX_RATIO:
        case.fail("final error %.2f times the noise floor (limit %.1f)" % (worst(ratio), PAIR_MAX_RATIO))
    if outside:
        wrong = case.info["false"]
        case.info["noise_with_wrong"] = bool(case.info["verdict"] in NOISE_VERDICTS and wrong)
        if case.info["noise_with_wrong"]:
            case.fail("verdict %s with %s kept (the log's missing term is outside the library)"
                      % (case.info["verdict"], ", ".join(wrong)))
        elif kind == "outside" and wrong:
            case.notes.append("kept %s, verdict %s" % (", ".join(wrong), case.info["verdict"]))
        if "discovered" in r:
            inputs = {i for t in r["discovered"] for term in t.get("terms", []) for i in term.get("inputs", [])}
            ok = all(any(v in inputs for v in grp) for grp in outside[0]["variable_groups"])
            case.info["discovered_ok"] = ok
            if not ok:
                case.fail("discovered inputs %s miss %s" % (sorted(inputs) or "none",
                                                           outside[0]["variable_groups"]))


def run_case(args, workdir, cls, seed):
    case = Case(cls, seed)
    base = os.path.join(workdir, "%s_%d" % (cls.replace(":", "_"), seed))
    log = base + ".csv"
    gen = [args.python, os.path.join(HERE, "gen_indep.py"), "--class", cls, "--seed", str(seed),
           "--seconds", "%g" % args.seconds, "--out", log]
    threads = ["--threads", str(args.threads)] if args.threads else []
    case.info["repro"] = " ".join(shlex.quote(x) for x in gen) + " && %s explain %s --json" % (
        shlex.quote(args.auger), shlex.quote(log))
    try:
        t0 = time.time()
        p = subprocess.run(gen, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True,
                           timeout=600)
        case.info["t_gen"] = time.time() - t0
        if p.returncode != 0:
            raise RuntimeError("generator exited %d: %s" % (p.returncode, p.stderr.strip()[-300:]))
        with open(base + ".truth.json", encoding="utf-8") as f:
            truth = json.load(f)
        case.info["truth"] = truth
        d, case.info["t_diag"] = run_json([args.auger, "diagnose", log, "--json", "--quiet"] + threads,
                                          args.timeout)
        r, case.info["t_explain"] = run_json([args.auger, "explain", log, "--json", "--quiet"] + threads,
                                             args.timeout)
        for name, obj in (("diagnose", d), ("explain", r)):
            with open("%s.%s.json" % (base, name), "w", encoding="utf-8") as f:
                json.dump(obj, f)
        score(case, truth, d, r)
    except (RuntimeError, ValueError, OSError, subprocess.TimeoutExpired) as e:
        case.fail(str(e))
    return case


def describe(truth):
    parts = []
    for e in truth.get("effects", []):
        v = max(e["visibility"][c] for c in ("x", "y", "psi", "imu_psi"))
        parts.append("%s/%s %s=%.3g (%.0f%% of max, vis %.1f)" % (
            e["family"] or e["mechanism"], e["form"], e["size"]["name"], e["size"]["final"],
            100 * e["size"]["final"] / e["size"]["max"], v))
    cam = truth.get("sensors", {}).get("camera", {})
    noise = "coloured %.1fs" % cam["coloured_tau_s"] if cam.get("coloured") else "white"
    return "%s %s %s; %s" % (truth.get("drive", {}).get("kind"), truth.get("terrain"), noise,
                             "; ".join(parts) or "no effect")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--auger", required=True, help="the auger binary")
    ap.add_argument("--python", default=sys.executable, help="Python with numpy for the generator")
    ap.add_argument("--seeds", type=int, default=5, help="seeds per class (1..N)")
    ap.add_argument("--pairs", type=int, help="random pairs (default 4 x seeds)")
    ap.add_argument("--pair-outside", type=int, help="library + outside pairs (default seeds)")
    ap.add_argument("--only", help="classes, comma-separated (clean, single, single:FAMILY, pair, ...)")
    ap.add_argument("--sample", action="store_true", help="make test's sample (%d cases)" % len(SAMPLE))
    ap.add_argument("--seconds", type=float, default=240.0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--threads", type=int, help="auger's --threads (default its own)")
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds per auger command")
    ap.add_argument("--keep", help="keep logs, truths and JSON outputs in DIR")
    ap.add_argument("--min-single", type=float, default=0.95)
    ap.add_argument("--min-pair", type=float, default=0.90)
    ap.add_argument("--min-clean", type=float, default=1.0)
    ap.add_argument("--max-fdr", type=float, default=0.05)
    ap.add_argument("--min-outside", type=float, default=1.0, help="share of outside logs without "
                    "a noise verdict that keeps a wrong library effect")
    ap.add_argument("--min-discovered", type=float, default=0.70)
    args = ap.parse_args()
    if not os.access(args.auger, os.X_OK):
        ap.error("--auger %s: not an executable" % args.auger)
    if args.jobs < 1 or args.seeds < 1:
        ap.error("--jobs and --seeds must be at least 1")
    cases = plan(args)
    if not cases:
        ap.error("--only %s selects no case" % args.only)
    workdir = args.keep or tempfile.mkdtemp(prefix="auger-indep-")
    os.makedirs(workdir, exist_ok=True)
    t0 = time.time()
    results = []
    try:
        with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as ex:
            futs = [ex.submit(run_case, args, workdir, c, s) for c, s in cases]
            for fu in concurrent.futures.as_completed(futs):
                c = fu.result()
                results.append(c)
                print_row(c)
                sys.stdout.flush()
    finally:
        if not args.keep:
            shutil.rmtree(workdir, ignore_errors=True)
    return summary(args, results, time.time() - t0)


def print_row(c):
    i = c.info
    status = "PASS" if not c.failures else "FAIL"
    print("%-4s %-44s explain %5.0fs %-4s named %-40s diagnose %-22s final %5.2fx  %s" % (
        status, c.name, i.get("t_explain", 0), (i.get("verdict") or "-")[:10], ",".join(i.get("named", [])) or "-",
        ",".join(x or "-" for x in i.get("diag", [])[:2]) or "-", i.get("ratio", float("nan")),
        describe(i["truth"]) if "truth" in i else ""))
    for f in c.failures:
        print("       - " + f)
    for n in c.notes:
        print("       . " + n)
    if c.failures:
        print("       reproduce: " + c.info.get("repro", "?"))


def summary(args, results, wall):
    groups = {}
    for c in results:
        groups.setdefault(c.cls.split(":")[0] if c.cls.startswith(("single", "outside")) else c.cls,
                          []).append(c)
    print("\nper class (PASS / cases):")
    for c in sorted({r.cls for r in results}):
        rs = [r for r in results if r.cls == c]
        print("  %-44s %d / %d" % (c, sum(not r.failures for r in rs), len(rs)))
    named = sum(len(c.info.get("named", [])) for c in results)
    false = sum(len(c.info.get("false", [])) for c in results)
    fdr = false / named if named else 0.0
    times = sorted(c.info["t_explain"] for c in results if "t_explain" in c.info)
    print("\ntotals:")
    bad = []

    def share(kind, key, limit, label):
        rs = groups.get(kind, [])
        if not rs:
            return
        ok = sum(key(r) for r in rs)
        frac = ok / len(rs)
        print("  %-34s %3d / %-3d = %5.1f %%  (threshold %.0f %%)" % (label, ok, len(rs), 100 * frac, 100 * limit))
        if frac < limit:
            bad.append(label)

    share("single", lambda r: not r.failures, args.min_single, "single effects named first")
    share("pair", lambda r: not r.failures, args.min_pair, "pairs: both, nothing else, <= 1.2x")
    share("clean", lambda r: not r.failures, args.min_clean, "clean: nothing named")
    outs = groups.get("outside", []) + groups.get("pair_outside", [])
    if outs:
        ok = sum(not r.info.get("noise_with_wrong", False) and "named" in r.info for r in outs)
        frac = ok / len(outs)
        print("  %-34s %3d / %-3d = %5.1f %%  (threshold %.0f %%)" % (
            "outside: no noise verdict w/ wrong", ok, len(outs), 100 * frac, 100 * args.min_outside))
        if frac < args.min_outside:
            bad.append("outside")
        disc = [r for r in outs if "discovered_ok" in r.info]
        if disc:
            frac = sum(r.info["discovered_ok"] for r in disc) / len(disc)
            print("  %-34s %3d / %-3d = %5.1f %%  (threshold %.0f %%)" % (
                "outside: discovered inputs right", sum(r.info["discovered_ok"] for r in disc), len(disc),
                100 * frac, 100 * args.min_discovered))
            if frac < args.min_discovered:
                bad.append("discovered")
        else:
            print("  outside: discovered inputs right    (explain emits no `discovered` yet)")
    print("  %-34s %3d / %-3d = %5.1f %%  (threshold %.0f %%)" % ("false-discovery rate", false, named,
                                                                  100 * fdr, 100 * args.max_fdr))
    if fdr > args.max_fdr:
        bad.append("false-discovery rate")
    errors = [c for c in results if "named" not in c.info]
    if errors:
        print("  %d case(s) did not run to a score (generator or auger errors above)" % len(errors))
        bad.append("errors")
    if times:
        print("  explain wall time: median %.0f s, max %.0f s over %d logs of %g s (--jobs %d)"
              % (times[len(times) // 2], times[-1], len(times), args.seconds, args.jobs))
    print("  %d cases in %.0f s" % (len(results), wall))
    if bad:
        print("BELOW THRESHOLD: " + ", ".join(bad))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
