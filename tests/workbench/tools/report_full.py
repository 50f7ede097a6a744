#!/usr/bin/env python3
"""make test-full: auger report --explain on a 150 s simulator log with a hidden dry friction:
explain's steps on the page and its model (with coulomb_friction, or stick_slip_friction, whose
special case it is: a declared confusable pair of the hidden-effect suite; within 1.3 times the noise
floor) as the one after; loaded in headless Chromium (no console error, no request outside the
page, every chart drawn) and a screenshot of the whole page kept for a look (ctest puts it in
build/report-screenshot.png).

usage: report_full.py --auger PATH --sim-log PATH [--screenshot OUT.png] [--keep DIR]
"""
import argparse
import json
import os
import pathlib
import struct
import subprocess
import sys
import tempfile
import time

HERE = pathlib.Path(__file__).resolve().parent


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--auger", required=True)
    ap.add_argument("--sim-log", required=True)
    ap.add_argument("--screenshot", default="report-screenshot.png")
    ap.add_argument("--keep", default="", help="write the log and the page here instead of a temporary directory")
    a = ap.parse_args()
    work = pathlib.Path(a.keep) if a.keep else pathlib.Path(tempfile.mkdtemp(prefix="auger-report-full-"))
    work.mkdir(parents=True, exist_ok=True)
    log, page = work / "drive.csv", work / "report"
    subprocess.run([a.sim_log, "--out", str(log), "--effect", "coulomb_friction", "--seed", "4", "--trajectory",
                    "manual"], check=True, stdout=subprocess.DEVNULL)
    t0 = time.monotonic()
    r = subprocess.run([a.auger, "report", str(log), "--out", str(page), "--explain", "--json"], check=True,
                       capture_output=True, text=True)
    report_s = time.monotonic() - t0
    rep = json.loads(r.stdout)
    js = ("JSON.stringify({charts: Object.keys(window.augerCharts).length, "
          "empty: Object.values(window.augerCharts).filter(g => g.numRows() < 2).length, "
          "sections: [...document.querySelectorAll('section')].map(s => s.id)})")
    b = subprocess.run([sys.executable, str(HERE / "browser_check.py"), str(page / "index.html"), "--eval", js,
                        "--screenshot", a.screenshot], capture_output=True, text=True)
    print(b.stdout.strip())
    if b.returncode != 0:
        print("report_full: the browser saw errors or outside requests (above)", file=sys.stderr)
        return 1
    out = json.loads(b.stdout)
    ev = out["eval"]
    problems = []
    if ev["charts"] != rep["charts"] or ev["empty"]:
        problems.append(f"charts drawn {ev['charts']} of {rep['charts']}, {ev['empty']} empty")
    if ev["sections"] != rep["sections"]:
        problems.append(f"sections {ev['sections']} != {rep['sections']}")
    dry_friction = ("coulomb_friction", "stick_slip_friction")
    if "explain" not in rep["sections"] or not any(e in rep.get("effect_added", "") for e in dry_friction):
        problems.append("explain's steps or its model missing: " + json.dumps(rep))
    elif max(rep["after"]["ratio_to_noise"].values()) > 1.3:
        problems.append("explain's model leaves more than 1.3 times the noise floor: " + json.dumps(rep["after"]))
    html = (page / "index.html").read_text(encoding="utf-8")
    for needle in ('id="explain-step-0"', 'id="explain-step-1"', "Held-out error at each step of auger explain"):
        if needle not in html:
            problems.append("the page lacks " + needle)
    png = pathlib.Path(a.screenshot).read_bytes()
    width, height = struct.unpack(">II", png[16:24])  # the IHDR chunk
    # A page that did not draw is a few kB of white; this one is many charts tall.
    if png[:8] != b"\x89PNG\r\n\x1a\n" or width != 1200 or height < 5000 or len(png) < 200_000:
        problems.append(f"screenshot {width}x{height}, {len(png)} bytes")
    print(f"report_full: report {report_s:.1f} s, page {os.path.getsize(page / 'index.html') / 1e6:.1f} MB, "
          f"{ev['charts']} charts, browser {out['seconds']} s, screenshot {a.screenshot} {width}x{height}")
    for p in problems:
        print("report_full: " + p, file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
