#!/usr/bin/env bash
# make bench-ros2: what augerd's ROS 2 interface costs its 100 Hz loop (docs/benchmarks.md).
# The simulated robot (real firmware on ptys) and augerd, twice for SECONDS each: without
# [ros2], then with it while tests/ros2/bench_load.py floods its inputs (Twist 1 kHz, pose and
# IMU 500 Hz each) and reads every output. augerd prints, at exit, its loop period statistics
# and the time its loop spent inside the bridge's poll and publish. DDS on loopback only.
#   scripts/bench-ros2.sh [BUILD_DIR] [SECONDS]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
seconds=${2:-30}
py=$build/venv/bin/python3
[[ -x $py ]] || { echo "bench-ros2: $py is missing (make venv)" >&2; exit 1; }
work=$(mktemp -d /tmp/auger-bench-ros2-XXXXXX)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
domain=$(( ($$ % 200) + 20 ))
export CYCLONEDDS_URI=file://$root/tests/ros2/dds-loopback.xml
AUGER_BUILD=$build AUGER_SRC=$root
# shellcheck source=sim-robot.sh
. "$root/scripts/sim-robot.sh"

for run in without-ros2 with-ros2; do
  d=$work/$run
  mkdir -p "$d"
  sim_start "$d" frozen_grass $((seconds + 20))
  sim_pid=$SIM_PID
  pids+=("$sim_pid")
  sections=""
  [[ $run == without-ros2 ]] || sections="[ros2]
enabled = true
domain_id = $domain
dds_config = \"$root/tests/ros2/dds-loopback.xml\"
insecure = true
pose_topic = \"/camera/pose\"
imu_topic = \"imu\""
  AUGERD_SENSORS_SOCKET=$d/augerd-sensors.sock augerd_start "$d" frozen_grass "" "" "$sections"
  augerd_pid=$AUGERD_PID
  pids+=("$augerd_pid")
  "$build/host/auger/auger" cmd --socket "$d/commands.sock" enable > /dev/null
  if [[ $run == with-ros2 ]]; then
    (cd "$root/tests/ros2" && "$py" bench_load.py "$domain" "$seconds")
  else
    sleep "$seconds"
  fi
  kill -TERM "$augerd_pid"
  wait "$augerd_pid" || true
  kill -TERM "$sim_pid" 2>/dev/null || true
  wait "$sim_pid" || true
  echo "bench-ros2: $run:"
  grep -E "loop period|ROS 2:.*per cycle" "$d/augerd.out" | sed 's/^/  /'
done
