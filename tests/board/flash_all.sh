#!/usr/bin/env bash
# scripts/flash-all.sh without hardware, as tests/fil/test_fil_flash.cpp tests `make flash`: four
# simulated ATmega328Ps start in Debian's Optiboot with an image that is not the auger firmware
# (tests/sim/fx_echo.elf), reset when a host opens their pty (DTR), paced to real time
# (avrdude's timeouts are wall-clock); the real avrdude flashes each, auger-module sets the ids,
# and the script checks each answers with its id and the firmware version of firmware/config.h.
# The ports are given out of the simulator's order, so id n must land on the n-th port given.
# Usage: flash_all.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$1 src=$2
optiboot=/usr/share/arduino/hardware/arduino/avr/bootloaders/optiboot/optiboot_atmega328.hex
work=$(mktemp -d /tmp/auger-flash-all-XXXXXX)
sim_pid=
cleanup() {
  [[ -z $sim_pid ]] || { kill "$sim_pid" 2>/dev/null || true; wait "$sim_pid" 2>/dev/null || true; }
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "flash_all: $*" >&2; for f in "$work"/*.out; do echo "--- $f" >&2; tail -20 "$f" >&2; done; exit 1; }
[[ -r $optiboot ]] || fail "$optiboot missing (arduino-core-avr, scripts/install-deps.sh)"
export AUGER_MODULE=$build/host/tools/auger-module
flash_all=$src/scripts/flash-all.sh

# Bad usage is refused before anything is opened.
rc=0; bash "$flash_all" /dev/null > "$work/usage.out" 2>&1 || rc=$?
((rc == 2)) || fail "one port: exit $rc, expected 2"
rc=0; bash "$flash_all" "$work/none0" "$work/none1" "$work/none2" "$work/none3" > "$work/missing.out" 2>&1 || rc=$?
((rc == 1)) && grep -q "none0 (id 0): no such port" "$work/missing.out" || fail "a missing port: exit $rc"

"$build/sim/auger-sim-modules" --elf "$build/tests/sim/fx_echo.elf" --count 4 --realtime \
  --reset-on-open --bootloader "$optiboot" --battery-v 18 --pty-dir "$work/pty" > "$work/sim.out" 2>&1 &
sim_pid=$!
for i in 0 1 2 3; do
  for ((t = 0; t < 100; t++)); do [[ -e $work/pty/module$i ]] && break; sleep 0.1; done
  [[ -e $work/pty/module$i ]] || fail "simulated module $i did not appear"
done
rc=0; bash "$flash_all" "$work/pty/module0" "$work/pty/module0" "$work/pty/module1" "$work/pty/module2" \
  > "$work/twice.out" 2>&1 || rc=$?
((rc == 2)) || fail "the same port twice: exit $rc, expected 2"

# Before: not the auger firmware, so no identity.
"$AUGER_MODULE" --timeout 1.5 "$work/pty/module1" identify > "$work/before.out" 2>&1 &&
  fail "the simulated module answers before it was flashed: the test would prove nothing"

order=(2 0 3 1)  # simulated module order[n] is given as PORTn: it must become id n
start=$(date +%s.%N)
bash "$flash_all" "$work/pty/module2" "$work/pty/module0" "$work/pty/module3" "$work/pty/module1" \
  > "$work/flash-all.out" 2>&1 || fail "flash-all.sh failed"
end=$(date +%s.%N)
grep -q "flash-all: modules 0-3 answer with their ids, firmware 0.2.0" "$work/flash-all.out" ||
  fail "no final check line"
# Independently of the script: a fresh open of each simulated module finds its new id.
for n in 0 1 2 3; do
  out=$("$AUGER_MODULE" "$work/pty/module${order[$n]}" identify 2>&1) || fail "module ${order[$n]}: $out"
  [[ $out == *": module $n, firmware 0.2.0, protocol 2, settings from EEPROM"* ]] ||
    fail "simulated module ${order[$n]} (PORT$n): $out"
done
grep -c "flashed" "$work/flash-all.out" | grep -qx 4 || fail "expected 4 'flashed' lines"
awk -v a="$start" -v b="$end" 'BEGIN { printf "flash_all: four modules flashed, ids set and checked in %.1f s\n", b - a }'
