#!/usr/bin/env bash
# make bench-explain: how long `auger explain` takes (docs/benchmarks.md "explain"). Logs with two
# hidden effects from auger-sim-log (240 s and 10 min, manual driving) and an augerd-format log of
# the firmware-in-the-loop chain (auger-sim-drive, 240 s, sand, the square); each explained RUNS
# times (default 3) with /usr/bin/time; prints wall and CPU seconds per run and the median.
#   scripts/bench-explain.sh [BUILD_DIR] [RUNS]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
runs=${2:-3}
auger=$build/host/auger/auger
work=$build/bench-explain
mkdir -p "$work"
pair=(--effect screw_dead_band:omega_rpm=2.2 --effect resistance_offset:asym=0.6)
"$build/sim/robot/auger-sim-log" --out "$work/pair-240s.csv" --seconds 240 --seed 3 "${pair[@]}" 2>/dev/null
"$build/sim/robot/auger-sim-log" --out "$work/pair-600s.csv" --seconds 600 --seed 3 "${pair[@]}" 2>/dev/null
"$build/sim/robot/auger-sim-drive" --out "$work/fil-square-240s.csv" --drive square --seconds 240 --seed 1
echo "machine: $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg) at the start"
echo "| log | run | wall s | CPU s (user+sys) | effects named |"
echo "|---|---|---|---|---|"
for log in pair-240s pair-600s fil-square-240s; do
  walls=()
  for ((i = 1; i <= runs; i++)); do
    /usr/bin/time -f "%e %U %S" -o "$work/time.txt" "$auger" explain "$work/$log.csv" --json --quiet > "$work/$log.json"
    read -r wall user sys < "$work/time.txt"
    named=$(python3 -c "import json,sys; print(','.join(json.load(open(sys.argv[1]))['effects']))" "$work/$log.json")
    echo "| $log | $i | $wall | $(python3 -c "print(round($user + $sys, 1))") | $named |"
    walls+=("$wall")
  done
  median=$(printf '%s\n' "${walls[@]}" | sort -n | sed -n "$(( (runs + 1) / 2 ))p")
  echo "| $log | median | $median | | |"
done
