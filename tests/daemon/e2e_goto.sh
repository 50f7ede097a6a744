#!/usr/bin/env bash
# End to end, real time: the simulated robot on frozen grass (four modules running the real
# firmware on ptys, commissioned with auger-module), the real augerd on those ptys with the
# simulated camera and IMU on its sensors socket, and `auger cmd goto`: the robot must arrive.
# This is the path `make demo` takes, short. Usage: e2e_goto.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$1 src=$2
AUGER_BUILD=$build AUGER_SRC=$src
# shellcheck source=../../scripts/sim-robot.sh
. "$src/scripts/sim-robot.sh"
sim_work e2e
fail() { echo "e2e_goto: $*" >&2; for f in "$work"/*.out; do echo "--- $f" >&2; tail -5 "$f" >&2; done; exit 1; }

sim_start "$work" frozen_grass 40 || fail "the simulated robot did not start"
sim_pid=$SIM_PID
pids+=($sim_pid)
augerd_start "$work" frozen_grass "gamma_per_s = [0.5, 0.5, 0.5]" "rotate_bytes = 65536" ||
  fail "augerd did not start"
augerd_pid=$AUGERD_PID
pids+=($augerd_pid)
auger=$build/host/auger/auger
"$auger" cmd --socket "$work/commands.sock" enable "goto 0.2 0.1 0" > "$work/cmd.out" || fail "commands refused"
sleep 12
status=$("$auger" cmd --socket "$work/commands.sock" status)
echo "$status"
"$auger" cmd --socket "$work/commands.sock" stop > /dev/null
# Arrived, judged on the true robot (the simulator's truth log), not on augerd's estimate; and
# augerd's estimate (EKF with the simulated camera) agrees.
kill -TERM "$sim_pid"
wait "$sim_pid" || true
awk -F, -v s="$status" -v gx=0.2 -v gy=0.1 -v name=e2e_goto -f "$src/tests/support/check_arrival.awk" \
  "$work/truth.csv" || fail "the robot did not arrive"
# The log, rotated at 64 KiB: several files, each a whole robot log (its own metadata and
# header, readable alone, with camera pose and reference rows).
kill -TERM "$augerd_pid"
wait "$augerd_pid" || true
logs=("$work"/logs/*.csv)
((${#logs[@]} >= 2)) || fail "expected rotated logs, got ${#logs[@]} file(s)"
for f in "${logs[@]}"; do
  head -1 "$f" | grep -q '^# format: auger-robot-log v1' || fail "$f does not start with the format line"
done
"$build/host/track/auger-track" "${logs[@]}" || fail "a rotated log is not a readable robot log"
# The pandas lines of docs/formats.md read augerd's own log (the venv of `make venv`).
"$build/venv/bin/python3" "$src/python/tests/check_pandas_doc.py" "${logs[0]}" ||
  fail "the documented pandas lines do not read augerd's log"
echo "e2e_goto: ${#logs[@]} log files after rotation at 64 KiB"
