#!/bin/sh
# sim_batch_test.sh SOURCE_DIR BUILD_DIR WORK_DIR: scripts/sim-batch.py with ideal screws (a few
# seconds): every log and truth log written, the field's square crosses the frozen-grass band in
# and out, the uniform sand square never changes terrain (docs/robot-sim.md "Batch driving").
# Then the tools that read such a batch (docs/benchmarks.md "Online identification"): online_fil
# finds sand's sigma_long from the true velocity once the slow (blocking) screws' windows are out,
# and not with them in; stall-check.py finds no stall on the field's edges; auger-sim-drive
# --online-apply closes the loop without falling back, and on a tilted ground (--incline-pitch-rad)
# estimates the slope a model file marks online within 3 of its SDs, and the controller's model
# takes it.
set -eu
src=$1 build=$2 work=$3
rm -rf "$work"
python3 "$src/scripts/sim-batch.py" --out "$work" --build "$build" --runs 1 --seconds 60 --screws ideal \
  --drives square --uniform sand --jobs 1
python3 - "$work" <<'PY'
import csv, os, sys
work = sys.argv[1]
rows = {r["log"]: r for r in csv.DictReader(open(os.path.join(work, "manifest.csv")))}
field, uniform = rows["field-square-1.csv"], rows["uniform-sand-square-1.csv"]
for r in (field, uniform):
    for f in (r["log"], r["truth"]):
        assert os.path.getsize(os.path.join(work, f)) > 10000, f + " is (nearly) empty"
assert int(field["centre_changes"]) == 2, "the field's square crossed the band %s times, not in and out" % field["centre_changes"]
assert int(uniform["centre_changes"]) == 0, "uniform sand changed terrain"
changes = [r for r in csv.DictReader(open(os.path.join(work, "changes.csv"))) if r["log"] == "field-square-1"]
kinds = [c["kind"] for c in changes]
# Each crossing: the front pair's contacts first, then the centre, then the rear pair; out the same.
assert kinds.count("centre") == 2 and kinds.count("contacts") >= 4 and kinds[0] == "contacts", kinds
assert [c["terrain_ids"] for c in changes if c["kind"] == "centre"] == ["1", "0"]
print("sim_batch: the field's square crossed frozen grass in and out; uniform sand never changed")
PY
# sigma_long on uniform sand from the true velocity: exact with the slow screws' windows out, the
# blocking drags it low with them in (median 0.812 and 0.796, 5th percentile 0.812 and 0.53 N/rpm).
sigma_row() { "$build/bench/online_fil" stats "$work" --truth "$@" | grep '^| sand, square |'; }
with_out=$(sigma_row)
with_in=$(sigma_row --slow-screw-rpm 0)
python3 - "$with_out" "$with_in" <<'PY'
import re, sys
def nums(row):
    return [float(x) for x in re.findall(r"[0-9]+\.[0-9]+", row)]  # median, 5th, 95th pct.
out, inn = nums(sys.argv[1]), nums(sys.argv[2])
assert abs(out[0] / 0.812 - 1) < 0.01 and out[1] > 0.8, "slow screws out: %s" % sys.argv[1]
assert inn[1] < 0.75, "every window in, the 5th percentile should show the blocking: %s" % sys.argv[2]
print("sim_batch: online_fil: sigma_long on sand %s with the slow screws out, %s with them in" % (out, inn))
PY
stall=$(python3 "$src/scripts/stall-check.py" "$work/field-square-1.csv")
echo "$stall"
case $stall in *"on an edge: 0.00 s"*) ;; *) echo "sim_batch: a stall on the field's edge" >&2; exit 1 ;; esac
apply=$("$build/sim/robot/auger-sim-drive" --out "$work/apply.csv" --drive diagonal --terrain sand --seconds 60 \
  --screws ideal --online-apply 2>&1)
echo "$apply"
case $apply in *"[online] apply: "*"sigma_long used at the end 0."*) ;; *) echo "sim_batch: --online-apply" >&2; exit 1 ;; esac
case $apply in *fallback*) echo "sim_batch: --online-apply fell back" >&2; exit 1 ;; esac
# A model file with the slope's inclines online, the truth's ground descending towards +x by
# 0.05 rad (rising towards -x: incline_x 0.0499 rad, the in-plane weight m g sin p cos p).
{ cat "$src/models/robot.toml"; printf '\n[[effect]]\nid = "terrain_slope"\n'
  printf 'incline_x_rad = { value = 0.0, online = true }\nincline_y_rad = { value = 0.0, online = true }\n'; } > "$work/slope.toml"
slope=$("$build/sim/robot/auger-sim-drive" --out "$work/slope.csv" --drive manual --seconds 120 --screws ideal \
  --model "$work/slope.toml" --incline-pitch-rad -0.05 --online-apply 2>&1)
echo "$slope"
python3 - "$slope" <<'PY'
import re, sys
est = {m[0]: (float(m[1]), float(m[2]), float(m[3])) for m in
       re.findall(r"terrain_slope\.(incline_[xy])_rad (\S+) \+- (\S+) rad, used at the end (\S+) rad\n", sys.argv[1] + "\n")}
assert set(est) == {"incline_x", "incline_y"}, sys.argv[1]
for name, truth in (("incline_x", 0.0499), ("incline_y", 0.0)):
    v, sd, used = est[name]
    assert abs(v - truth) < 3 * sd and sd < 0.01, "%s %g +- %g rad, truth %g" % (name, v, sd, truth)
    # What the controller's model holds (applied: within 2 SD of the estimate when last applied).
    assert abs(used - truth) < 4 * sd, "%s used %g rad, truth %g" % (name, used, truth)
print("sim_batch: the slope marked online: %s" % est)
PY
