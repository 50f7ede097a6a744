#!/usr/bin/env bash
# The online estimator and change detector on firmware-in-the-loop logs (docs/benchmarks.md
# "On firmware-in-the-loop logs (`online_fil`)", `make bench-online-fil`): hours of lock-step
# driving by scripts/sim-batch.py (skipped when OUT already holds a finished batch), then
# bench/online_fil's innovation statistics and delay / false-alarm curves, each as the detector
# is now and as it was before (no dropout gate, every window, no prewhitening), and fed the true
# velocity.
#   scripts/bench-online-fil.sh [BUILD (build)] [OUT (BUILD/fil-batch)] [RUNS (6)] [SECONDS (600)]
# About 5 min on the 2-core machine for the default 6 h (the batch, 249 s measured), seconds for the rest.
set -euo pipefail
build=${1:-build}
out=${2:-$build/fil-batch}
runs=${3:-6} seconds=${4:-600}
src=$(cd "$(dirname "$0")/.." && pwd)
bin=$build/bench/online_fil
[[ -x $bin ]] || { echo "bench-online-fil: $bin not built (cmake --build $build --target online_fil)" >&2; exit 1; }
if [[ ! -f $out/manifest.csv ]]; then
  python3 "$src/scripts/sim-batch.py" --out "$out" --build "$build" --runs "$runs" --seconds "$seconds"
fi
before=(--max-pose-age 1e9 --slow-screw-rpm 0)
echo "## The innovation on uniform ground"
for opts in "${before[*]}" "--slow-screw-rpm 0" "" "--truth --slow-screw-rpm 0" "--truth"; do
  echo
  echo "### online_fil stats $out $opts"
  # shellcheck disable=SC2086 # the options are words
  "$bin" stats "$out" $opts
done
echo
echo "## Detection delay and false alarms"
echo
echo "### before: --no-whiten ${before[*]}"
"$bin" curve "$out" --no-whiten "${before[@]}" --thresholds 8,16,24,40,60
echo
echo "### now"
"$bin" curve "$out" --thresholds 2,4,8,12,16,24,40
echo
echo "### now, fed the true velocity"
"$bin" curve "$out" --truth --thresholds 4,8,16,24,40,80
echo
echo "## The estimator's memory, at make demo's setting"
demo=(--velocity-sd 0.002,0.002,0.01 --camera-corr-s 0.3 --drag-prior 0.01)
for memory in 5 2 1; do
  echo
  echo "### --memory-s $memory ${demo[*]}"
  "$bin" curve "$out" "${demo[@]}" --memory-s "$memory" --thresholds 8,12,16,24
done
echo
echo "### --detect-memory-s 1 (the detector's twin; the estimate keeps 5 s) ${demo[*]}"
"$bin" curve "$out" "${demo[@]}" --detect-memory-s 1 --thresholds 8,10,12,16
