#!/usr/bin/env bash
# Online and offline agree (issue 29 point 5; docs/daemon.md "Online identification"): the
# simulated robot on uniform sand (four modules running the real firmware on ptys), augerd
# configured for sand with [online] as `make demo` runs it (the kinematic velocity, the drag held:
# drag_prior_rel_sd = 0.01) following a 1 m straight along x and the start of the next side
# (auger-sim-drive's 1 m square, 25 s). Then `auger report` of augerd's log: the online estimate at
# the log's end against `auger fit LOG --add paper_params --hold D_x,D_y,D_psi` of the same log
# (the drag held offline as online). Every parameter the online data informed must agree within 2
# combined SDs, and sigma_long, which 18 s of driving along x informs, must be among them; the
# held drag is named held and not compared. Usage: online_agreement.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$1 src=$2
AUGER_BUILD=$build AUGER_SRC=$src
# shellcheck source=../../scripts/sim-robot.sh
. "$src/scripts/sim-robot.sh"
sim_work online
fail() { echo "online_agreement: $*" >&2; for f in "$work"/run/*.out; do echo "--- $f" >&2; tail -5 "$f" >&2; done; exit 1; }

"$build/sim/robot/auger-sim-drive" --drive square --course-m 1.0 --seconds 25 --course-out "$work/course.csv" ||
  fail "no course"
follow_run "$work/run" "$work/course.csv" 25 "" '[online]
enabled = true
velocity = "kinematic"
velocity_sd = [0.012, 0.012, 0.01]
drag_prior_rel_sd = 0.01
cusum_threshold = 40' || fail "the run did not start"
logs=("$work"/run/logs/augerd-*-0.csv)
"$build/host/auger/auger" report "${logs[0]}" --out "$work/report" --no-diagnose --json > "$work/report.json" ||
  fail "auger report failed"
python3 - "$work/report.json" <<'PY' || fail "online and offline disagree"
import json, sys
d = json.load(open(sys.argv[1]))
rows = d["online"]
for o in rows:
    print("online_agreement: %-10s online %.4g +- %.2g, offline %.4g +- %.2g %s, z %s" % (
        o["name"], o["online"], o["online_sd"], o["offline"], o["offline_sd"] or 0, o["unit"],
        "held" if o["held"] else ("%.2f" % o["z"]) if o["informed"] else "not informed"))
held = [o["name"] for o in rows if o["held"]]
assert held == ["D_x", "D_y", "D_psi"], held
informed = [o for o in rows if o["informed"]]
assert "sigma_long" in [o["name"] for o in informed], "sigma_long not informed online"
bad = [o["name"] for o in informed if not o["z"] <= 2]
assert not bad, "beyond 2 combined SDs: %s" % bad
PY
