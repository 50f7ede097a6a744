#!/usr/bin/env bash
# The field tools (host/operator, docs/operator.md) against the simulated robot on frozen grass
# (four modules running the real firmware on ptys, the real augerd, the simulated camera and
# IMU), in real time. Terminal programs run under a private tmux server (send-keys,
# capture-pane). One robot for all tools, to keep to the time budget:
#   monitor  shows the four modules; later a fault, highlighted (reverse video), after resize
#   step     through augerd and on a port: summary within the firmware step test's criteria,
#            ~100 Hz samples, an SVG plot
#   teleop   Up held: the robot moves forward (+x); released: mode idle, screws stopped < 0.7 s
#   follow   arrives: arrived=1, mode hold (it stayed follow before), an event
#   replay   the unmodified log reproduces (exit 0); altered cmd column / changed gain: exit 1
#   calib    a deliberately wrong dir_sign (module 1) is found and fixed; a halved
#            counts_per_rev (module 2) is found from the operator's count of turns and fixed
#   events   an injected fault (module 3's under-voltage threshold above the pack) is in the
#            event log with the module, the fault and what augerd did; re-enable by whom
# Usage: operator_sim.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$1 src=$2
work=$(mktemp -d /tmp/auger-op-XXXXXX)
tmux_srv="auger-op-$$"
pids=()
export TERM=${TERM:-xterm}
T() { tmux -L "$tmux_srv" "$@"; }
cleanup() {
  T kill-server 2>/dev/null || true
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
fail() {
  echo "operator_sim: FAIL: $*" >&2
  for f in "$work"/*.out; do echo "--- $f" >&2; tail -8 "$f" >&2; done
  exit 1
}
ok() { echo "operator_sim: ok: $*"; }
auger=$build/host/auger/auger
module=$build/host/tools/auger-module
sock=$work/commands.sock
cmd() { "$auger" cmd --socket "$sock" "$@"; }
# status_field KEY: one field of `status all`.
status_field() { cmd "status all" | tr ' ' '\n' | sed -n "s/^$1=//p"; }

AUGER_BUILD=$build AUGER_SRC=$src
# shellcheck source=../../scripts/sim-robot.sh
. "$src/scripts/sim-robot.sh"
sim_start "$work" frozen_grass 120 || fail "the simulated robot did not start"
pids+=("$SIM_PID")
augerd_start "$work" frozen_grass "gamma_per_s = [0.5, 0.5, 0.5]" "" || fail "augerd did not start"
augerd_pid=$AUGERD_PID
pids+=("$augerd_pid")

# ---- monitor: the four modules ----
T new-session -d -s mon -x 160 -y 30 "$auger monitor --socket $sock"
sleep 1.2
T capture-pane -p -t mon > "$work/monitor1.out"
for i in 0 1 2 3; do
  grep -Eq "^$i +.*/pty/module$i +-?[0-9]+\.[0-9]+ " "$work/monitor1.out" || fail "monitor does not show module $i"
done
grep -Eq "mode=stopped  arrived=0  fault=(none|[0-3]:no-telemetry)" "$work/monitor1.out" || fail "monitor does not show the robot's state"
grep -Eq "loop period [0-9]+\.[0-9]+ ms, jitter" "$work/monitor1.out" || fail "monitor does not show the loop period"
T resize-window -t mon -x 100 -y 20
sleep 0.5
T capture-pane -p -t mon > "$work/monitor2.out"
grep -q "auger monitor" "$work/monitor2.out" && grep -Eq "^3 +" "$work/monitor2.out" ||
  fail "monitor after a resize to 100x20"
T send-keys -t mon q
sleep 0.3
T has-session -t mon 2>/dev/null && fail "monitor did not quit on q"
ok "monitor shows the four modules, the loop period, survives a resize, quits on q"

# ---- step through augerd (spin) ----
"$auger" step 0 10 --socket "$sock" --enable --out "$work/step.csv" > "$work/step.out" ||
  fail "auger step exit $? (criteria or augerd)"
cat "$work/step.out"
rise=$(sed -n 's/.*rise time (10-90 %) *\([0-9.]*\) s.*/\1/p' "$work/step.out")
awk -v r="$rise" 'BEGIN { exit !(r > 0 && r <= 0.3) }' || fail "rise time '$rise' not within the firmware test's 0.3 s"
# Samples once per augerd cycle (100 Hz); a loaded machine misses some: at least 50 per second.
n=$(($(wc -l < "$work/step.csv") - 1))
((n >= 100)) || fail "only $n samples in 2 s"
ok "step: rise time $rise s, $n samples"

# ---- teleop: Up held, then released ----
cmd stop > /dev/null
T new-session -d -s tele -x 120 -y 20 "$auger teleop --socket $sock"
sleep 0.5
T send-keys -t tele e
sleep 0.3
[[ $(status_field enabled) == 1 ]] || fail "teleop's e did not enable"
x0=$(status_field cam_x_m) y0=$(status_field cam_y_m)
for _ in $(seq 25); do T send-keys -t tele Up; sleep 0.1; done
[[ $(status_field mode) == vel ]] || fail "teleop: not in vel while the key repeats"
released=$(date +%s.%N)
# The dead-man: augerd's 0.5 s after the last repeat; then the screws spin down.
while [[ $(status_field mode) == vel ]]; do sleep 0.02; done
stopped=$(date +%s.%N)
sleep 0.3
x1=$(status_field cam_x_m) y1=$(status_field cam_y_m)
st=$(cmd "status all")
T capture-pane -p -t tele > "$work/teleop.out"
T send-keys -t tele q
awk -v a="$released" -v b="$stopped" -v x0="$x0" -v x1="$x1" -v y0="$y0" -v y1="$y1" -v s="$st" 'BEGIN {
  n = split(s, f, " "); for (i = 1; i <= n; i++) { split(f[i], kv, "="); v[kv[1]] = kv[2] }
  printf "operator_sim: teleop moved dx=%.3f m dy=%.3f m; mode idle %.2f s after the last key\n", x1 - x0, y1 - y0, b - a
  spin = 0; for (i = 0; i < 4; i++) { w = v["m" i "_omega_rpm"]; if (w < 0) w = -w; if (w > spin) spin = w }
  exit !(x1 - x0 > 0.02 && (y1 - y0) ^ 2 < (x1 - x0) ^ 2 / 4 && b - a < 0.7 && v["mode"] == "idle" && spin < 0.5)
}' || fail "teleop: wrong motion or no stop after release (see above)"
grep -q "last command: vel 0.0200 0.0000 0.0000 -> ok" "$work/teleop.out" || fail "teleop screen"
ok "teleop forward, stopped by the dead-man"

# ---- the commissioning check: +u, +v, +r move forward, left, counter-clockwise ----
"$auger" calib --check-motion --socket "$sock" --seconds 1.5 > "$work/motion.out" 2>&1 ||
  fail "calib --check-motion: exit $?: $(cat "$work/motion.out")"
cat "$work/motion.out"
(($(grep -c ": ok$" "$work/motion.out") == 3)) || fail "calib --check-motion did not report three ok"
ok "commissioning check"

# ---- follow: arrives, reports it, holds the final pose (and the log exercises the controller) ----
read -r x y psi < <(cmd status | tr ' ' '\n' | sed -n 's/^\(x_m\|y_m\|psi_rad\)=//p' | tr '\n' ' '; echo)
printf 't_s,x_m,y_m,psi_rad\n0,%s,%s,%s\n1,%s,%s,%s\n' "$x" "$y" "$psi" \
  "$(awk -v x="$x" 'BEGIN { print x + 0.04 }')" "$y" "$psi" > "$work/traj.csv"
# Retried if a loaded machine stalls the simulated modules (fault=N:no-telemetry stops the
# robot, as it should); any other outcome counts.
for _ in 1 2 3; do
  cmd enable "follow $work/traj.csv" > /dev/null || fail "follow refused"
  for _ in $(seq 60); do [[ $(status_field mode) == hold || $(status_field enabled) == 0 ]] && break; sleep 0.1; done
  st=$(cmd status)
  [[ $st == *":no-telemetry"* ]] || break
  echo "operator_sim: the simulated modules stalled (machine load); follow again"
done
[[ $st == *"mode=hold"* && $st == *"arrived=1"* && $st == *"enabled=1"* ]] || fail "follow did not arrive: $st"
sleep 0.5
[[ $(status_field mode) == hold ]] || fail "hold did not hold"
grep -q 'event=arrived action="follow arrived at' "$work"/logs/*-events.log || fail "no arrival in the event log"
cmd stop > /dev/null
ok "follow arrived, reported arrived=1, holds (mode hold)"
kill -TERM "$augerd_pid"
wait "$augerd_pid" || true

# ---- replay ----
log=$(ls "$work"/logs/augerd-*-0.csv)
"$auger" replay "$log" --config "$work/augerd.toml" > "$work/replay1.out" 2>&1 || fail "replay of the unmodified log: exit $?: $(cat "$work/replay1.out")"
grep -q "same: the log is reproduced" "$work/replay1.out" || fail "replay did not say same"
awk -F, -v OFS=, '/^#/ { print; next } !h { for (i = 1; i <= NF; i++) c[$i] = i; h = 1; print; next }
  { if ($c["mode"] == 4 && !done) { $c["cmd_rpm_2"] += 0.25; done = 1; line = NR } print }
  END { print line > "/dev/stderr" }' "$log" > "$work/logs/altered.csv" 2> "$work/altered_line"
set +e
"$auger" replay "$work/logs/altered.csv" --config "$work/augerd.toml" > "$work/replay2.out"
code=$?
set -e
((code == 1)) || fail "replay of an altered cmd column: exit $code, expected 1"
grep -Eq "^cmd_rpm_2 .*/altered.csv:$(cat "$work/altered_line") " "$work/replay2.out" ||
  fail "replay did not name cmd_rpm_2 at line $(cat "$work/altered_line"): $(cat "$work/replay2.out")"
grep -Eq "^cmd_rpm_0 .* -$" "$work/replay2.out" || fail "replay flagged an unaltered column"
sed 's/^\[control\]$/[control]\nkp = [1.0, 1.0, 1.0]/' "$work/augerd.toml" > "$work/gain.toml"
set +e
"$auger" replay "$log" --config "$work/gain.toml" > "$work/replay3.out"
code=$?
set -e
((code == 1)) || fail "replay with a changed gain: exit $code, expected 1"
# A robot log without the replay columns (the simulator's truth): refused, naming the column.
set +e
"$auger" replay "$work/truth.csv" --model "$src/models/robot.toml" > "$work/replay4.out" 2>&1
code=$?
set -e
((code == 2)) && grep -q "truth.csv:3:1: .*mode" "$work/replay4.out" ||
  fail "replay of a log without replay columns: exit $code: $(cat "$work/replay4.out")"
ok "replay: same log passes, altered cmd_rpm_2 and changed kp flagged, a log without replay columns refused"

# ---- calib: a wrong dir_sign on module 1, a halved counts_per_rev on module 2 ----
"$module" "$work/pty/module1" set dir=-1 > /dev/null || fail "could not set module 1's dir"
cpr=$("$module" "$work/pty/module2" show | sed -n 's/.*counts_per_rev=\([0-9.]*\).*/\1/p')
half=$(awk -v c="$cpr" 'BEGIN { printf "%.2f", c / 2 }')
"$module" "$work/pty/module2" set "counts_per_rev=$half" > /dev/null || fail "could not set module 2's counts"
# Module 2 counts 0.2 turns by its halved setting: the marked screw turned 0.1 (the operator).
set +e
printf '0.1\n' | "$auger" calib --ports "$work/pty/module0,$work/pty/module1,$work/pty/module2,$work/pty/module3" \
  --model "$src/models/robot.toml" --terrain frozen_grass --sensors "$work/sensors.sock" --modules 1 \
  --seconds 1.5 > "$work/calib1.out" 2>&1
code1=$?
printf 'y\n0.1\n' | "$auger" calib --ports "$work/pty/module2" --model "$src/models/robot.toml" \
  --terrain frozen_grass --modules 2 --seconds 0.5 --turns 0.2 > "$work/calib2.out" 2>&1
code2=$?
set -e
cat "$work/calib1.out" "$work/calib2.out"
((code1 == 1)) && grep -q "direction: WRONG (dir_sign -1); wrote dir_sign +1" "$work/calib1.out" ||
  fail "calib did not find module 1's wrong dir_sign (exit $code1)"
"$module" "$work/pty/module1" show | grep -q "dir=+1" || fail "module 1's dir_sign was not written"
((code2 == 1)) && grep -q "counts_per_rev: WRONG; wrote" "$work/calib2.out" ||
  fail "calib did not find module 2's counts per revolution (exit $code2)"
got=$("$module" "$work/pty/module2" show | sed -n 's/.*counts_per_rev=\([0-9.]*\).*/\1/p')
awk -v g="$got" -v c="$cpr" 'BEGIN { d = g - c; if (d < 0) d = -d; exit !(d < 0.02 * c) }' ||
  fail "module 2's counts_per_rev $got, expected about $cpr"
ok "calib: dir_sign of module 1 fixed; counts_per_rev of module 2 $half -> $got (true $cpr)"

# ---- step directly on a port (augerd stopped) ----
"$auger" step 3 -10 --port "$work/pty/module3" --plot "$work/step.svg" > "$work/step2.out" 2>&1 ||
  fail "auger step --port: exit $?: $(cat "$work/step2.out")"
cat "$work/step2.out"
rise=$(sed -n 's/.*rise time (10-90 %) *\([0-9.]*\) s.*/\1/p' "$work/step2.out")
awk -v r="$rise" 'BEGIN { exit !(r > 0 && r <= 0.3) }' || fail "rise time '$rise' on the port"
grep -q "<svg" "$work/step.svg" || fail "no SVG plot"
ok "step on the port: rise time $rise s, plot written"

# ---- a fault: module 3's under-voltage threshold above its 19.9 V pack ----
"$module" "$work/pty/module3" set undervoltage_v=21 > /dev/null || fail "could not set module 3's threshold"
rm -f "$work"/logs/*
augerd_start "$work" frozen_grass "" "" || fail "augerd did not restart"
augerd_pid=$AUGERD_PID
pids+=("$augerd_pid")
T new-session -d -s mon2 -x 170 -y 30 "$auger monitor --socket $sock"
# enable: the module clears its fault, which latches again (the cause persists) and stops the
# robot; the second enable is logged as a re-enable. Retried while a loaded machine stalls the
# simulated modules (then the fault is no-telemetry).
for _ in 1 2 3 4 5; do
  cmd enable > /dev/null || true
  sleep 0.5
  [[ $(status_field fault) == 3:F_UNDERVOLTAGE ]] && break
done
[[ $(status_field fault) == 3:F_UNDERVOLTAGE ]] || fail "augerd's status: fault=$(status_field fault)"
cmd enable > /dev/null || true
sleep 0.5
T capture-pane -p -e -t mon2 > "$work/monitor3.out"
T send-keys -t mon2 q
[[ $(status_field fault) == 3:F_UNDERVOLTAGE ]] || fail "augerd's status: fault=$(status_field fault)"
# Module 3's row in reverse video (SGR 7), with the fault's name; module 0's row plain.
grep -a "/pty/module3 " "$work/monitor3.out" | grep -a "F_UNDERVOLTAGE" | grep -aq $'\e\\[[0-9;]*7[0-9;]*m' ||
  fail "monitor does not highlight module 3's fault: $(grep -a F_UNDER "$work/monitor3.out" | cat -v)"
grep -a "/pty/module0 " "$work/monitor3.out" | grep -aq $'\e\\[[0-9;]*7m' && fail "monitor highlights module 0"
events=$(ls "$work"/logs/*-events.log)
cat "$events"
grep -Eq "Z t_s=[0-9.]+ module=3 port=$work/pty/module3 event=F_UNDERVOLTAGE action=\".*stopped all screws \(was idle\), waiting for enable\"" "$events" ||
  fail "the event log does not record module 3's fault and the action"
grep -Eq "module=3 .*event=re-enabled action=\"fault F_UNDERVOLTAGE cleared by enable from pid [0-9]+ \(auger\)" "$events" ||
  fail "the event log does not say who re-enabled"
ok "fault highlighted in the monitor and recorded in the event log"
