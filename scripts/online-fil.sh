#!/usr/bin/env bash
# augerd's [online] with the firmware in the loop (docs/benchmarks.md "Online identification"):
# the 1.5 m square and the 1.5 m helix diagonal of `auger-sim-drive --course-m 1.5`, across
# sim/fields/sand-grass.toml and on uniform sand, augerd configured for sand, each once with
# [online] apply = false (fixed) and once with apply = true (adapt), the given [online] keys
# otherwise; four runs side by side (about 5 minutes in all). Prints the terrain changes against
# augerd's alarms (scripts/demo-field.py) and the tracking error of each run (auger-track).
#   scripts/online-fil.sh BUILD_DIR OUT_DIR [ONLINE_KEYS]
# ONLINE_KEYS: TOML lines for [online] (default: the kinematic velocity, the drag held,
# the accelerometer fused with the camera's noise taken as coloured over 0.3 s,
# velocity_sd = [0.002, 0.002, 0.01], slow_screw_rpm = 2, cusum_threshold = 8, as make demo).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:?usage: scripts/online-fil.sh BUILD_DIR OUT_DIR [ONLINE_KEYS]}" && pwd)
out=${2:?usage: scripts/online-fil.sh BUILD_DIR OUT_DIR [ONLINE_KEYS]}
keys=${3:-'velocity = "kinematic"
velocity_sd = [0.002, 0.002, 0.01]
camera_noise_corr_s = 0.3
drag_prior_rel_sd = 0.01
slow_screw_rpm = 2
cusum_threshold = 8'}
mkdir -p "$out"
out=$(cd "$out" && pwd)
AUGER_BUILD=$build AUGER_SRC=$root
# shellcheck source=sim-robot.sh
. "$root/scripts/sim-robot.sh"
"$build/sim/robot/auger-sim-drive" --drive square --course-m 1.5 --seconds 144 --course-out "$out/square.csv"
"$build/sim/robot/auger-sim-drive" --drive diagonal --course-m 1.5 --seconds 120 --course-out "$out/diagonal.csv"
field=$root/sim/fields/sand-grass.toml
pids=()
trap 'for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done' EXIT INT TERM
for ground in field sand; do
  f=""
  [[ $ground == sand ]] || f=$field
  pids=()
  for course in square diagonal; do
    seconds=150
    [[ $course == square ]] || seconds=125
    for apply in false true; do
      name=$ground-$course-$([[ $apply == true ]] && echo adapt || echo fixed)
      follow_run "$out/$name" "$out/$course.csv" "$seconds" "$f" "[online]
enabled = true
apply = $apply
$keys" & pids+=($!)
    done
  done
  wait "${pids[@]}"
done
pids=()
cd "$out"
"$build/venv/bin/python3" "$root/scripts/demo-field.py" field-square-fixed field-square-adapt field-diagonal-fixed \
  field-diagonal-adapt
"$build/host/track/auger-track" ./*/logs/augerd-*.csv
for r in sand-square-fixed sand-square-adapt sand-diagonal-fixed sand-diagonal-adapt; do
  echo "$r: $(grep -c 'event=terrain-change' "$r"/logs/*-events.log || true) alarms on uniform sand," \
    "$(grep -c 'event=online-fallback' "$r"/logs/*-events.log || true) fallback"
done
