#!/usr/bin/env bash
# The board's binaries proven to work, not only to link: the aarch64 augerd, auger and
# auger-module of `make board` run under qemu-user (qemu-aarch64 -L /usr/aarch64-linux-gnu, no
# binfmt registration; natively on an aarch64 machine) against the simulated robot of
# scripts/sim-robot.sh (x86 build: four simulated modules running the real firmware on ptys,
# the simulated camera and IMU). auger-module (aarch64) commissions the ids; augerd must
# identify all four modules, listed out of order, on the right ports; `auger cmd` (aarch64)
# sends a goto, and the robot must arrive, judged on the simulator's true pose, with augerd's
# estimate agreeing. Also: the installed augerd accepts the installed configuration.
# Usage: qemu_augerd.sh BUILD_DIR SOURCE_DIR BOARD_BUILD_DIR (AUGER_BOARD_BUILD, if set, overrides it)
# AUGER_BOARD_CLI=host (make test): `auger` is the workstation's, as make test builds only augerd
# and auger-module for the board; otherwise (make test-full, or by hand after `make board`) the
# board's.
set -euo pipefail
build=$1 src=$2 board=${AUGER_BOARD_BUILD:-$3}
cli=${AUGER_BOARD_CLI:-board}
[[ $cli == host || $cli == board ]] || { echo "qemu_augerd: AUGER_BOARD_CLI=$cli: expected host or board" >&2; exit 2; }
work=$(mktemp -d /tmp/auger-board-XXXXXX)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "qemu_augerd: $*" >&2; for f in "$work"/*.out; do echo "--- $f" >&2; tail -8 "$f" >&2; done; exit 1; }

board_bins=(host/augerd/augerd host/tools/auger-module)
[[ $cli == host ]] || board_bins+=(host/auger/auger)
for b in "${board_bins[@]}"; do
  [[ -x $board/$b ]] || fail "$board/$b missing: build it with \`make board\` (BOARD_BUILD=$board)"
  readelf -h "$board/$b" | grep -q 'Machine:.*AArch64' || fail "$board/$b is not an aarch64 program"
done

# A fake build tree for scripts/sim-robot.sh: the simulator from the x86 build, augerd and
# auger-module from the board build, run through qemu.
mkdir -p "$work/bin/host/augerd" "$work/bin/host/auger" "$work/bin/host/tools" "$work/bin/sim/robot"
ln -s "$build/sim/robot/auger-sim-robot" "$work/bin/sim/robot/auger-sim-robot"
if [[ $(uname -m) == aarch64 ]]; then
  run=()
else
  command -v qemu-aarch64 >/dev/null || fail "qemu-aarch64 missing (qemu-user, scripts/install-deps.sh)"
  aarch64-linux-gnu-gcc -std=c99 -O2 -Wall -Wextra -Werror -shared -fPIC \
    "$src/tests/board/qemu_termios2.c" -o "$work/qemu_termios2.so" -ldl
  # LD_LIBRARY_PATH: the cross toolchain's ld.so must load its own libc. With arm64 multiarch
  # installed (ncurses for auger), ld.so.cache points libc.so.6 at /lib/aarch64-linux-gnu's, a
  # later build of glibc 2.36 whose internals differ from that ld.so's: the first
  # pthread_create then spun for ever (augerd writes its logs from a thread).
  run=(qemu-aarch64 -L /usr/aarch64-linux-gnu -E "LD_PRELOAD=$work/qemu_termios2.so"
       -E "LD_LIBRARY_PATH=/usr/aarch64-linux-gnu/lib")
fi
for t in "${board_bins[@]}"; do
  # exec: the pid sim-robot.sh records is the program's (qemu passes signals to it).
  printf '#!/bin/sh\nexec %s %q "$@"\n' "${run[*]}" "$board/$t" > "$work/bin/$t"
  chmod +x "$work/bin/$t"
done
[[ $cli == board ]] || ln -s "$build/host/auger/auger" "$work/bin/host/auger/auger"
auger=$work/bin/host/auger/auger

# Runs at all (the board's under qemu): a usage error exits 2 from the program itself.
rc=0; "$auger" cmd > "$work/usage.out" 2>&1 || rc=$?
((rc == 2)) || fail "$cli's auger with bad usage: exit $rc, expected 2"

# The installed configuration is valid for the installed augerd: make install's layout with
# these binaries into a scratch PREFIX/SYSCONFDIR (no DESTDIR, so the paths written into the
# configuration are the scratch ones), then augerd --check. This machine is not the robot: the
# check then lists what start-up would miss here (the module ports, /run/augerd, /var/log/auger,
# the group auger-sensors) and exits non-zero, but the file and the model must be valid.
from=$board
if [[ $cli == host ]]; then  # the layout make install expects, auger from the workstation
  from=$work/from
  mkdir -p "$from/host/augerd" "$from/host/tools" "$from/host/auger"
  ln -s "$board/host/augerd/augerd" "$from/host/augerd/augerd"
  ln -s "$board/host/tools/auger-module" "$from/host/tools/auger-module"
  ln -s "$build/host/auger/auger" "$from/host/auger/auger"
fi
PREFIX=$work/prefix SYSCONFDIR=$work/etc FROM=$from bash "$src/packaging/install.sh" install > "$work/install.out" ||
  fail "install of the board binaries failed"
"${run[@]}" "$work/prefix/bin/augerd" --config "$work/etc/auger/augerd.toml" --check > "$work/check.out" 2>&1 || true
grep -q "augerd.toml: the configuration and the model are valid" "$work/check.out" ||
  fail "the installed augerd refuses the installed configuration"
! grep -q "augerd.toml:[0-9]*:[0-9]*:" "$work/check.out" || fail "augerd --check: an error in the installed file"

AUGER_BUILD=$work/bin AUGER_SRC=$src
# shellcheck source=../../scripts/sim-robot.sh
. "$src/scripts/sim-robot.sh"
sim_start "$work" frozen_grass 30 || fail "the simulated robot did not start (or aarch64 auger-module failed)"
sim_pid=$SIM_PID
pids+=($sim_pid)
augerd_start "$work" frozen_grass "gamma_per_s = [0.5, 0.5, 0.5]" "" || fail "aarch64 augerd did not start"
augerd_pid=$AUGERD_PID
pids+=($augerd_pid)

# Identified: each id on the port of the simulated module that got it, whatever the port order
# of the configuration (module2, module0, module3, module1).
for i in 0 1 2 3; do
  grep -q "^augerd: module $i on $work/pty/module$i (firmware 0.2.0" "$work/augerd.out" ||
    fail "augerd did not identify module $i on $work/pty/module$i"
done

"$auger" cmd --socket "$work/commands.sock" enable "goto 0.2 0.1 0" > "$work/cmd.out" || fail "commands refused"
status=
for ((t = 0; t < 30; t++)); do  # up to 15 s; the reference is within 5 mm of the goal after ~8 s
  sleep 0.5
  status=$("$auger" cmd --socket "$work/commands.sock" status) || fail "status refused"
  awk -v s="$status" 'BEGIN { n = split(s, f, " "); for (i = 1; i <= n; i++) { split(f[i], kv, "="); v[kv[1]] = kv[2] }
    exit !((v["xd_m"] - 0.2) ^ 2 + (v["yd_m"] - 0.1) ^ 2 < 0.005 ^ 2 &&
           (v["x_m"] - 0.2) ^ 2 + (v["y_m"] - 0.1) ^ 2 < 0.01 ^ 2 || v["fault"] != "none") }' && break
done
echo "$status"
"$auger" cmd --socket "$work/commands.sock" stop > /dev/null || fail "stop refused"
sleep 1  # the truth log records the robot at rest after the stop
kill -TERM "$sim_pid"
wait "$sim_pid" || true
awk -F, -v s="$status" -v gx=0.2 -v gy=0.1 -v name=qemu_augerd -f "$src/tests/support/check_arrival.awk" \
  "$work/truth.csv" || fail "the robot did not arrive"

# SIGTERM through qemu: augerd stops cleanly (exit 0) and prints its loop statistics.
kill -TERM "$augerd_pid"
rc=0; wait "$augerd_pid" || rc=$?
((rc == 0)) || fail "augerd exit $rc on SIGTERM, expected 0"
grep -q "^augerd: stopped" "$work/augerd.out" || fail "augerd did not report its stop"
grep -i "period" "$work/augerd.out" | sed 's/^/qemu_augerd: /' || true
ls "$work"/logs/augerd-*.csv > /dev/null || fail "augerd wrote no log"
