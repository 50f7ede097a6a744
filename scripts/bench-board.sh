#!/usr/bin/env bash
# The controller's 100 Hz step on the board's CPU class (docs/benchmarks.md, `make bench-board`):
# bench/host_step built like the board's binaries (the board build's compiler, flags and
# libauger_core.a), then
# - on an x86 machine: its aarch64 instructions per step counted under qemu-user, as a mix by
#   instruction class (qemu -d in_asm,exec,nochain: every translated block's instructions, and
#   every execution of a block), beside the x86 count of callgrind; an estimate of the
#   Cortex-A53's cycles from the mix (docs/benchmarks.md explains the model); and qemu's wall
#   time, which is not the board's speed;
# - on an aarch64 machine (the board): the wall time per step, which is the board's figure.
# As in scripts/bench-host-step.sh, a 5 000-step run minus a 1 000-step run, divided by 4 000.
# Usage: scripts/bench-board.sh BOARD_BUILD HOST_BUILD
set -euo pipefail
board=${1:-build-aarch64} host=${2:-build}
src=$(cd "$(dirname "$0")/.." && pwd)
lib=$board/host/libauger_core.a
[[ -r $lib ]] || { echo "bench-board: $lib not built (make board)" >&2; exit 1; }
cache() { sed -n "s/^$1:[A-Z]*=//p" "$board/CMakeCache.txt"; }
cxx=$(sed -n 's/^set(CMAKE_CXX_COMPILER "\(.*\)")$/\1/p' "$board"/CMakeFiles/[0-9]*/CMakeCXXCompiler.cmake | head -1)
[[ -n $cxx ]] || { echo "bench-board: no C++ compiler recorded in $board" >&2; exit 1; }
# shellcheck disable=SC2046 # the flags are words
flags=($(cache CMAKE_CXX_FLAGS) $(cache CMAKE_CXX_FLAGS_RELEASE))
mkdir -p "$board/bench"
bin=$board/bench/host_step
"$cxx" -std=c++17 "${flags[@]}" -Wall -Wextra -Werror -I"$src/host/include" -I/usr/include/eigen3 \
  -DAUGER_MODELS_DIR="\"$src/models\"" "$src/bench/host_step.cpp" "$lib" -o "$bin"
echo "bench-board: $bin built with $cxx ${flags[*]}"

if [[ $(uname -m) == aarch64 ]]; then
  echo "Wall time per step on this aarch64 machine:"
  "$bin" 20000
  exit 0
fi

command -v qemu-aarch64 >/dev/null || { echo "bench-board: qemu-aarch64 missing (make deps)" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# Instruction classes as the A53's pipelines take them (LLVM's AArch64SchedA53.td): one
# load/store unit, one FP multiply/divide/sqrt unit, one FP ALU, two integer ALUs, one branch.
cat > "$tmp/mix.awk" <<'AWK'
function key(s) { sub(/^0x/, "", s); sub(/^0+/, "", s); return s }
function cls(m) {
  if (m == "fdiv") return "fdiv"
  if (m == "fsqrt") return "fsqrt"
  if (m ~ /^fn?m(add|sub)$/ || m ~ /^fml[as]$/) return "fmac"
  if (m ~ /^fn?mul/) return "fmul"
  if (m ~ /^f/ || m ~ /^[su]cvtf$/) return "fp"
  if (m ~ /^ld/) return "load"
  if (m ~ /^st/) return "store"
  if (m ~ /^(b|bl|blr|br|ret|cbn?z|tbn?z)$/ || m ~ /^b\./) return "branch"
  return "int"
}
/^IN:/ { inblk = 1; pc = ""; delete cur; next }
inblk && /^0x[0-9a-f]+:/ { if (pc == "") pc = key(substr($1, 1, length($1) - 1)); cur[cls($3)]++; next }
inblk { if (pc != "") { for (c in classes) tb[pc, c] = 0; for (c in cur) { tb[pc, c] = cur[c]; classes[c] = 1 } } inblk = 0 }
/^Trace / { split($0, a, "/"); p = key(a[2]); if (!((p, "int") in tb) && !((p, "branch") in tb)) unknown++
            for (c in classes) n[c] += tb[p, c]; next }
END { for (c in n) printf "%s %d\n", c, n[c]; printf "unknown_blocks %d\n", unknown }
AWK
mix() {  # mix of a run of $1 steps of case $2 $3, one "class count" a line
  rm -f "$tmp/fifo"; mkfifo "$tmp/fifo"
  awk -f "$tmp/mix.awk" "$tmp/fifo" > "$tmp/mix.$1" &
  local ap=$!
  qemu-aarch64 -L /usr/aarch64-linux-gnu -d in_asm,exec,nochain -D "$tmp/fifo" "$bin" "$1" "$2" "$3" > /dev/null
  wait "$ap"
  grep -q '^unknown_blocks 0$' "$tmp/mix.$1" || { echo "bench-board: blocks executed but never seen translated" >&2; exit 1; }
}
x86_ir() {  # x86 instructions of a run, as scripts/bench-host-step.sh counts them
  valgrind --tool=callgrind --callgrind-out-file="$tmp/cg" "$host/bench/host_step" "$1" "$2" "$3" >/dev/null 2>&1
  callgrind_annotate "$tmp/cg" 2>/dev/null | awk '/PROGRAM TOTALS/ && !done {gsub(",", "", $1); print $1; done = 1}'
}
have_x86=0
[[ -x $host/bench/host_step ]] && command -v valgrind >/dev/null && have_x86=1

echo
echo "| estimator | allocator | x86-64 instr./step | aarch64 instr./step | int | branch | load | store | FP add/cmp/cvt | FP mul | FP mul-add | FP div | FP sqrt | A53 cycles: bound from below | from above | A53 at 1.152 GHz | share of 10 ms |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
for est in ekf dr; do
  for alloc in nullspace pinv; do
    mix 1000 "$est" "$alloc"; mix 5000 "$est" "$alloc"
    x86=-
    ((have_x86)) && x86=$(( ($(x86_ir 5000 "$est" "$alloc") - $(x86_ir 1000 "$est" "$alloc")) / 4000 ))
    join <(sort "$tmp/mix.1000") <(sort "$tmp/mix.5000") | awk -v est="$est" -v alloc="$alloc" -v x86="$x86" '
      $1 != "unknown_blocks" { d[$1] = ($3 - $2) / 4000; total += d[$1] }
      END {
        # From below: what the pipelines can sustain at best (LLVM A53 model: 2 instructions
        # issued per cycle; one load/store unit; one FP multiply/divide unit, a double FDIV
        # holding it 29 cycles and FSQRT 28).
        issue = total / 2
        ldst = d["load"] + d["store"]
        fpmds = d["fmul"] + d["fmac"] + 29 * d["fdiv"] + 28 * d["fsqrt"]
        lo = issue; if (ldst > lo) lo = ldst; if (fpmds > lo) lo = fpmds
        # From above: no two instructions overlap, each waits out its full latency (integer 3,
        # load 4, store 1, FP ALU and FP multiply 6, FP multiply-add 10, FDIV 33, FSQRT 32,
        # branch 1 plus a 9-cycle mispredict for one in ten).
        hi = 3 * d["int"] + 4 * d["load"] + d["store"] + 6 * (d["fp"] + d["fmul"]) + 10 * d["fmac"] \
             + 33 * d["fdiv"] + 32 * d["fsqrt"] + 1.9 * d["branch"]
        printf "| %s | %s | %s | %.0f | %.0f | %.0f | %.0f | %.0f | %.0f | %.0f | %.0f | %.1f | %.1f | %.0f | %.0f | %.1f-%.1f us | %.3f-%.3f %% |\n",
          est, alloc, x86, total, d["int"], d["branch"], d["load"], d["store"], d["fp"], d["fmul"], d["fmac"],
          d["fdiv"], d["fsqrt"], lo, hi, lo / 1152, hi / 1152, lo / 1152 / 100, hi / 1152 / 100
      }'
  done
done
echo
echo "qemu-user wall time per step on this machine (binary translation: NOT the board's speed):"
qemu-aarch64 -L /usr/aarch64-linux-gnu "$bin" 20000
