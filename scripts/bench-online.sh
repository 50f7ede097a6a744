#!/usr/bin/env bash
# The online estimator and change detector (docs/benchmarks.md "Online identification",
# `make bench-online`):
# 1. cost per 10 ms cycle of OnlineEstimator::step on this machine: wall time, and x86-64
#    instructions from callgrind (a 60 000-cycle run minus a 20 000-cycle run, over 40 000), the
#    terrain alone and with three effect parameters online (online_bench cost N effects), and of
#    the kinematic velocity augerd feeds it, with and without the accelerometer (cost N kinematic,
#    cost N kinematic-acc);
# 2. the same instruction count for the board's CPU class: bench/online_bench.cpp built with the
#    board's compiler and flags (cmake/toolchain-aarch64.cmake) and run under qemu-user, which
#    logs every translated block (in_asm) and every execution of one (exec, nochain);
# 3. the detection delay / false-alarm curve over the detector's threshold (online_bench curve).
# Usage: scripts/bench-online.sh [BUILD (build)] [RUNS (40)] [HOURS (1)] [VELOCITY_SD_MPS ...]
set -euo pipefail
build=${1:-build} runs=${2:-40} hours=${3:-1}
shift $(( $# < 3 ? $# : 3 ))
noises=("${@:-0.0005 0.002}")
# shellcheck disable=SC2206 # the default is two words
noises=(${noises[*]})
src=$(cd "$(dirname "$0")/.." && pwd)
bin=$build/bench/online_bench
[[ -x $bin ]] || { echo "bench-online: $bin not built (cmake --build $build --target online_bench)" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

echo "## Cost per cycle"
"$bin" cost 200000
"$bin" cost 200000 effects
"$bin" cost 200000 twin
"$bin" cost 200000 kinematic
"$bin" cost 200000 kinematic-acc
if command -v valgrind >/dev/null; then
  ir() {
    valgrind --tool=callgrind --callgrind-out-file="$tmp/cg" "$bin" cost "$1" ${2:-} >/dev/null 2>&1
    callgrind_annotate "$tmp/cg" 2>/dev/null | awk '/PROGRAM TOTALS/ && !d {gsub(",", "", $1); print $1; d = 1}'
  }
  echo "x86-64 instructions per cycle (callgrind): $(( ($(ir 60000) - $(ir 20000)) / 40000 ))"
  echo "  with three effect parameters online: $(( ($(ir 60000 effects) - $(ir 20000 effects)) / 40000 ))"
  echo "  with the detector's twin (detect_memory_s = 1): $(( ($(ir 60000 twin) - $(ir 20000 twin)) / 40000 ))"
  echo "  KinematicVelocity (velocity = \"kinematic\"): $(( ($(ir 60000 kinematic) - $(ir 20000 kinematic)) / 40000 ))"
  echo "  KinematicVelocity with the accelerometer: $(( ($(ir 60000 kinematic-acc) - $(ir 20000 kinematic-acc)) / 40000 ))"
else
  echo "x86-64 instructions: valgrind missing (make deps)"
fi

if command -v qemu-aarch64 >/dev/null && command -v aarch64-linux-gnu-g++ >/dev/null; then
  # The core's sources and the bench, as the board build compiles them (Release: -O3 -DNDEBUG).
  # (zstd: the core's MCAP writer compresses its chunks.)
  aarch64-linux-gnu-g++ -std=c++17 -O3 -DNDEBUG -mcpu=cortex-a53 -ffp-contract=off -Wall -Wextra -Werror \
    -I"$src/host/include" -I"$src/bench" -isystem /usr/include/eigen3 -isystem /usr/include \
    -DAUGER_MODELS_DIR="\"$src/models\"" -DAUGER_VERSION="\"bench\"" \
    "$src/bench/online_bench.cpp" "$src"/host/src/*.cpp "$src"/host/src/effects/*.cpp -lzstd -o "$tmp/online_bench_a64"
  # Instructions of a run: each executed block times its size (blocks are logged translated once).
  a64() {
    rm -f "$tmp/fifo"; mkfifo "$tmp/fifo"
    awk 'function key(s) { sub(/^0x/, "", s); sub(/^0+/, "", s); return s }
         /^IN:/ {blk = 1; pc = ""; n = 0; next}
         blk && /^0x[0-9a-f]+:/ {if (pc == "") pc = key(substr($1, 1, length($1) - 1)); n++; next}
         blk {if (pc != "") size[pc] = n; blk = 0}
         /^Trace / {split($0, a, "/"); total += size[key(a[2])]}
         END {printf "%.0f\n", total}' "$tmp/fifo" > "$tmp/count" &
    local ap=$!
    qemu-aarch64 -L /usr/aarch64-linux-gnu -d in_asm,exec,nochain -D "$tmp/fifo" "$tmp/online_bench_a64" cost "$1" ${2:-} \
      >/dev/null
    wait "$ap"
    cat "$tmp/count"
  }
  echo "aarch64 instructions per cycle (qemu-user, Cortex-A53 flags): $(( ($(a64 6000) - $(a64 2000)) / 4000 ))"
  echo "  with three effect parameters online: $(( ($(a64 6000 effects) - $(a64 2000 effects)) / 4000 ))"
  echo "  KinematicVelocity: $(( ($(a64 6000 kinematic) - $(a64 2000 kinematic)) / 4000 ))"
  echo "  KinematicVelocity with the accelerometer: $(( ($(a64 6000 kinematic-acc) - $(a64 2000 kinematic-acc)) / 4000 ))"
else
  echo "aarch64 instructions: qemu-aarch64 or aarch64-linux-gnu-g++ missing (make deps)"
fi

echo
echo "## Detection delay and false alarms over the threshold"
for sd in "${noises[@]}"; do
  echo
  "$bin" curve "$runs" "$hours" "$sd"
done
