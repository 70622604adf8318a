#!/usr/bin/env bash
# The jitter and load benchmark, run by hand (never a test): the wheelchair application in
# polyportd, idle and under stress-ng, with its profile's default scheduling and with
# SCHED_FIFO, one case after the other (benchmarks/stress/README.md). Writes
# benchmarks/results/stress-<UTC stamp>.{json,md,png}. Real-time cases need root or
# CAP_SYS_NICE (without, polyportd warns and runs SCHED_OTHER: the JSON keeps the warning).
#
#   scripts/bench_stress.sh [--duration-s 60] [--priority 80] [--stressor "stress-ng ..."] [--cases idle/default,...]
# Environment: POLYPORT_BUILD_DIR (default: build; benchmarks are switched on in it),
# POLYPORT_JOBS (2).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bench_common.sh
build="${POLYPORT_BUILD_DIR:-build}"

for target in polyportd polyport_wheelchair; do
  bench_build "$build" "$target" "only polyport's core"
done
bench_revision
bench_run /usr/bin/python3 benchmarks/stress/bench_stress.py --polyportd "$build/bin/polyportd" \
  --out-dir benchmarks/results "$@"
exit "$bench_rc"
