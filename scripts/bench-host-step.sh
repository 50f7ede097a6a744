#!/usr/bin/env bash
# Instructions per controller step (callgrind counts instructions, not time: the figure is
# the same on a busy machine) and wall time per step. Usage: scripts/bench-host-step.sh BUILD_DIR
set -euo pipefail
bin=${1:-build}/bench/host_step
[[ -x $bin ]] || { echo "bench-host-step: $bin not built (make host)" >&2; exit 1; }
command -v valgrind >/dev/null || { echo "bench-host-step: valgrind missing (make deps)" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "| estimator | allocator | instructions per step |"
echo "|---|---|---|"
for est in ekf dr; do
  for alloc in nullspace pinv; do
    ir() {  # total instructions of a run of $1 steps
      valgrind --tool=callgrind --callgrind-out-file="$tmp/cg.$1" "$bin" "$1" "$est" "$alloc" >/dev/null 2>&1
      callgrind_annotate "$tmp/cg.$1" 2>/dev/null | awk '/PROGRAM TOTALS/ && !done {gsub(",", "", $1); print $1; done = 1}'
    }
    a=$(ir 1000); b=$(ir 5000)
    echo "| $est | $alloc | $(( (b - a) / 4000 )) |"
  done
done
echo
echo "Wall time per step on this machine (noisy; share of the 10 ms period):"
echo "| estimator | allocator | time per step | share of 10 ms |"
echo "|---|---|---|---|"
"$bin" 20000
