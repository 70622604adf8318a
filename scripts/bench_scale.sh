#!/usr/bin/env bash
# The scale benchmark, run by hand (never a test): polyportd on N in-process source -> sink
# pairs of 64-byte samples (scripts/gen_scale_profile.py) for N = 10, 100, 1000, measuring
# start-up time, RSS, the daemon's CPU time per delivered sample over several windows, each
# connection's in-to-out latency and drops (benchmarks/scale/README.md). Writes
# benchmarks/results/scale-<UTC stamp>.{json,md}.
#
#   scripts/bench_scale.sh [--n 10,100,1000] [--period-ms 10] [--windows 5] [--window-s 2] [--warmup-s 2]
# Environment: POLYPORT_BUILD_DIR (default: build; benchmarks are switched on in it),
# POLYPORT_JOBS (2).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bench_common.sh
build="${POLYPORT_BUILD_DIR:-build}"

for target in polyportd polyportctl polyport_scale_components; do
  bench_build "$build" "$target" "only polyport's core"
done
bench_revision
bench_run /usr/bin/python3 benchmarks/scale/bench_scale.py --polyportd "$build/bin/polyportd" \
  --polyportctl "$build/bin/polyportctl" --out-dir benchmarks/results "$@"
exit "$bench_rc"
