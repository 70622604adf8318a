#!/usr/bin/env bash
# The cross-model latency matrix, run by hand (never a test): builds bench_matrix (with the
# DDS and LCM ping/pong programs, the native relays between two SDKs and polyportd), runs it
# once and turns its result into the table and the heat map:
#   benchmarks/results/matrix-<UTC stamp>.json   every raw figure, and per pair whether each
#                                                bar holds (or why the pair is not measured)
#   benchmarks/results/matrix-<UTC stamp>.md     the table (rows source model, columns target)
#   benchmarks/results/matrix-<UTC stamp>.png    the heat map
# Measured on the host: every ordered pair of Cyclone DDS, Fast DDS and LCM (the diagonal with
# its direct series), via polyportd and via a native relay, 16 B and 1 KiB. The CAN diagonal
# is taken from the newest benchmarks/results/can_pingpong-*.json (scripts/bench_pingpong.sh
# can, in the vcan guest); CAN cross pairs and in-process pairs are listed as not measured
# (README.md, "Benchmarks").
#
#   scripts/bench_matrix.sh [runner options]   (benchmarks/matrix/run_matrix.cpp lists them,
#                                               e.g. --placements unpinned --sizes 16)
# Runs in a private network namespace (needs root), as the LCM benchmark does. With the
# defaults below (3000 round trips per series, unpinned and on one core) about five minutes on a
# 2-core machine.
# Environment: POLYPORT_BUILD_DIR (default: build; benchmarks are switched on in it),
# POLYPORT_BENCH_ROUNDS (3000 measured round trips per series), POLYPORT_BENCH_WARMUP (500
# per ping process), POLYPORT_BENCH_CHUNKS (4), POLYPORT_JOBS (2).
#
# Ctrl-C or SIGTERM stops the runner, which stops its ping, pong, relay and polyportd
# processes; an interrupted run writes no result.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bench_common.sh
build="${POLYPORT_BUILD_DIR:-build}"
rounds="${POLYPORT_BENCH_ROUNDS:-3000}"
warmup="${POLYPORT_BENCH_WARMUP:-500}"
chunks="${POLYPORT_BENCH_CHUNKS:-4}"

echo "== building bench_matrix in $build" >&2
bench_build "$build" bench_matrix "Cyclone DDS, Fast DDS, idlc, fastddsgen, liblcm, lcm-gen and the DDS and LCM models"
if ! /usr/bin/python3 -c 'import matplotlib, numpy' 2>/dev/null; then
  echo "the report needs Debian's python3-matplotlib and python3-numpy (/usr/bin/python3)" >&2
  exit 1
fi

bench_revision

mkdir -p benchmarks/results
out="benchmarks/results/matrix-$(date -u +%Y%m%dT%H%M%SZ).json"
echo "== running the matrix ($rounds round trips per series in $chunks chunks; one line per case)" >&2
bench_run "$build/bin/bench_matrix" "$out" "$rounds" "$warmup" --chunks "$chunks" "$@"
rc=$bench_rc
if [ ! -f "$out" ]; then
  echo "no result written (bench_matrix exited with $rc)" >&2
  exit "$rc"
fi
[ "$rc" -eq 0 ] || echo "$out: some cases have no targets (see their error fields)" >&2
echo "== report" >&2
/usr/bin/python3 benchmarks/matrix/report.py "$out"
exit "$rc"
