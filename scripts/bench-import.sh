#!/usr/bin/env bash
# make bench-import: time and peak memory of `auger import` (docs/benchmarks.md "Import and
# export"). Simulated drives of SECONDS... (default 600 3600) written as the research group's bags
# (python/tests/bagmaker.py: motor feedback at 5 Hz, setpoints 10 Hz, pose 20 Hz, IMU 100 Hz),
# sqlite3 and MCAP; each imported once under /usr/bin/time (wall s, peak RSS).
#   scripts/bench-import.sh [BUILD_DIR] [SECONDS...]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
shift || true
lengths=("${@:-600 3600}")
read -r -a lengths <<< "${lengths[*]}"
auger=$build/host/auger/auger
work=$build/bench-import
mkdir -p "$work"
echo "machine: $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg) at the start"
echo "| drive | storage | messages | bag MB | rows | wall s | peak RSS MB |"
echo "|---|---|---|---|---|---|---|"
for s in "${lengths[@]}"; do
  "$build/sim/robot/auger-sim-log" --out "$work/drive-$s.csv" --trajectory manual --seconds "$s" --seed 4 \
    --effect coulomb_friction 2>/dev/null
  for storage in sqlite3 mcap; do
    bag=$work/bag-$s-$storage
    rm -rf "$bag"
    PYTHONPATH=$root/python/tests "$build/venv/bin/python3" -c "import sys, bagmaker; \
      bagmaker.log_to_bag(sys.argv[1], sys.argv[2], storage=sys.argv[3], feedback_every=20)" \
      "$work/drive-$s.csv" "$bag" "$storage"
    msgs=$("$auger" import "$bag" --list-topics --json | python3 -c \
      "import json,sys; print(sum(t['messages'] for t in json.load(sys.stdin)['topics']))")
    mb=$(du -sm "$bag" | cut -f1)
    /usr/bin/time -f "%e %M" -o "$work/time.txt" "$auger" import "$bag" --out "$work/out.csv" --terrain sand \
      > /dev/null 2>&1
    read -r wall rss < "$work/time.txt"
    rows=$(($(grep -vc '^#' "$work/out.csv") - 1))
    echo "| ${s} s | $storage | $msgs | $mb | $rows | $wall | $((rss / 1024)) |"
  done
done
