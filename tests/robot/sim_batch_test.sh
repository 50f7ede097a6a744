#!/bin/sh
# sim_batch_test.sh SOURCE_DIR BUILD_DIR WORK_DIR: scripts/sim-batch.py with ideal screws (a few
# seconds): every log and truth log written, the field's square crosses the frozen-grass band in
# and out, the uniform sand square never changes terrain (docs/robot-sim.md "Batch driving").
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
