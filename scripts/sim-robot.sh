# The simulated robot and augerd on its ptys, as `make demo` and the end-to-end test run them.
# Source this file with AUGER_BUILD (the CMake build directory) and AUGER_SRC (the source tree)
# set; the functions report on stderr and return non-zero on failure.

# sim_wait_for PATH... : wait up to 10 s until every path exists.
sim_wait_for() {
  local p t=0
  for p in "$@"; do
    while [[ ! -e $p ]]; do
      sleep 0.1
      t=$((t + 1))
      ((t < 100)) || { echo "sim-robot: $p did not appear" >&2; return 1; }
    done
  done
}

# sim_work TAG : a fresh directory $work (/tmp/auger-TAG-XXXXXX) and an empty $pids; at exit
# every process in $pids is killed and the directory removed (a test appends what it starts).
sim_work() {
  work=$(mktemp -d "/tmp/auger-$1-XXXXXX")
  pids=()
  trap 'for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; rm -rf "$work"' EXIT
}

# sim_start DIR TERRAIN SECONDS [FIELD] : the simulated robot on TERRAIN (or, given a FIELD file,
# on its patches: docs/robot-sim.md "Fields") with four modules running the
# firmware on ptys DIR/pty/module0..3, its camera and IMU sent to DIR/sensors.sock, its true
# trajectory logged to DIR/truth.csv; then each module commissioned with its id (screw position
# n gets id n), as `make flash ID=n` does on the robot: a fresh module boots with id 0.
# Sets SIM_PID.
sim_start() {
  local d=$1 terrain=$2 seconds=$3 i field=()
  [[ -z ${4:-} ]] || field=(--field "$4")
  mkdir -p "$d/pty"
  "$AUGER_BUILD/sim/robot/auger-sim-robot" --pty-dir "$d/pty" --terrain "$terrain" "${field[@]}" \
    --model "$AUGER_SRC/models/robot.toml" --elf "$AUGER_SRC/firmware/build/auger-module.elf" \
    --sensor-socket "$d/sensors.sock" --log "$d/truth.csv" --seconds "$seconds" \
    > "$d/sim.out" 2>&1 &
  SIM_PID=$!
  sim_wait_for "$d/pty/module0" "$d/pty/module1" "$d/pty/module2" "$d/pty/module3" || return 1
  for i in 0 1 2 3; do
    "$AUGER_BUILD/host/tools/auger-module" "$d/pty/module$i" set "id=$i" > "$d/commission.out" 2>&1 ||
      { echo "sim-robot: could not set the id of module $i:" >&2; cat "$d/commission.out" >&2; return 1; }
  done
}

# augerd_config DIR TERRAIN CONTROL_LINES LOG_LINES [SECTIONS] : writes DIR/augerd.toml for the
# ptys of sim_start, listed in another order than the ids (augerd maps modules by the id they
# report), with the given extra lines in [control] and [log] and extra SECTIONS at the end (e.g.
# [ros2]); its sensors socket is DIR/sensors.sock (where sim_start sends the camera and IMU)
# unless AUGERD_SENSORS_SOCKET names another; AUGERD_TELEMETRY_TIMEOUT_S, when set, is its
# [serial] telemetry_timeout_s.
augerd_config() {
  local d=$1 terrain=$2 control=$3 log=$4 sections=${5:-}
  mkdir -p "$d/logs"
  cat > "$d/augerd.toml" <<CONF
schema = 1
[serial]
ports = ["$d/pty/module2", "$d/pty/module0", "$d/pty/module3", "$d/pty/module1"]
${AUGERD_TELEMETRY_TIMEOUT_S:+telemetry_timeout_s = $AUGERD_TELEMETRY_TIMEOUT_S}
[model]
file = "$AUGER_SRC/models/robot.toml"
terrain = "$terrain"
[control]
$control
[sockets]
commands = "$d/commands.sock"
sensors = "${AUGERD_SENSORS_SOCKET:-$d/sensors.sock}"
[log]
dir = "$d/logs"
$log
$sections
CONF
}

# augerd_start DIR TERRAIN CONTROL_LINES LOG_LINES [SECTIONS] : augerd on augerd_config's file.
# Waits for its commands socket DIR/commands.sock. Sets AUGERD_PID.
augerd_start() {
  local d=$1
  augerd_config "$@"
  "$AUGER_BUILD/host/augerd/augerd" --config "$d/augerd.toml" > "$d/augerd.out" 2>&1 &
  AUGERD_PID=$!
  sim_wait_for "$d/commands.sock" || { cat "$d/augerd.out" >&2; return 1; }
}

# follow_run DIR COURSE_CSV SECONDS FIELD SECTIONS : the simulated robot (on FIELD, or on sand
# when FIELD is "") and augerd configured for sand as `make demo` runs it (null-space allocator,
# gamma 0.2 1/s) with SECTIONS at the end of its configuration (e.g. [online]); augerd follows
# COURSE_CSV for SECONDS, then `status all` and `stop` (answers in DIR/commands.out), and both
# stop. Needs AUGER_BUILD's host/auger/auger.
follow_run() {
  local d=$1 course=$2 seconds=$3 field=$4 sections=$5 sim_pid augerd_pid
  mkdir -p "$d"
  local rc=0 stop_rc
  sim_start "$d" sand $((seconds + 20)) "$field" || return 1
  sim_pid=$SIM_PID
  augerd_start "$d" sand 'allocator = "nullspace"
gamma_per_s = [0.2, 0.2, 0.2]
omega_min_rpm = 3.0
engage_rpm = 1.5' "" "$sections" || rc=$?
  if ((rc == 0)); then
    augerd_pid=$AUGERD_PID
    # A refused command (or any failure) still stops augerd and the robot below: under set -e a
    # bare failing command here left both running.
    "$AUGER_BUILD/host/auger/auger" cmd --socket "$d/commands.sock" enable "follow $course" \
      > "$d/commands.out" || rc=$?
    ((rc != 0)) || sleep "$seconds"
    "$AUGER_BUILD/host/auger/auger" cmd --socket "$d/commands.sock" "status all" stop \
      >> "$d/commands.out" || { stop_rc=$?; ((rc != 0)) || rc=$stop_rc; }
    kill -TERM "$augerd_pid" 2>/dev/null || true
    wait "$augerd_pid" || true
  fi
  kill -TERM "$sim_pid" 2>/dev/null || true
  wait "$sim_pid" || true
  return "$rc"
}
