#!/usr/bin/env bash
# The control-plane benchmark, run by hand (never a test): the in-to-out p99 of a busy
# connection (1 kHz, in-process) in windows with and without `polyportctl stats --watch`
# polling at 10 Hz, alternating in one daemon run (benchmarks/control/README.md). Writes
# benchmarks/results/control_plane-<UTC stamp>.json.
#
#   scripts/bench_control.sh [--windows 6] [--window-s 10] [--warmup-s 2] [--interval 0.1]
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
bench_run /usr/bin/python3 benchmarks/control/bench_control_plane.py --polyportd "$build/bin/polyportd" \
  --polyportctl "$build/bin/polyportctl" --out-dir benchmarks/results "$@"
exit "$bench_rc"
