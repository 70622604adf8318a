#!/usr/bin/env bash
# The DDS ping-pong latency benchmark, run by hand (never a test): builds bench_dds_pingpong
# (with its ping/pong programs and polyportd) and runs it once, writing
# benchmarks/results/dds_pingpong-<UTC stamp>.json. Both vendors, 16 B and 1 KiB, unpinned and on
# one core: direct, via polyportd and via a native relay; about three minutes on a 2-core machine.
#
#   scripts/bench_dds.sh [runner options]   e.g. --placements unpinned --vendors cyclonedds
#                                           (benchmarks/dds/run_pingpong.cpp lists them all)
# Environment: POLYPORT_BUILD_DIR (default: build; benchmarks are switched on in it),
# POLYPORT_BENCH_ROUNDS (10000 measured round trips per series), POLYPORT_BENCH_WARMUP (1000
# per ping process), POLYPORT_JOBS (2).
#
# Ctrl-C or SIGTERM stops the runner, which stops its ping, pong and polyportd processes (they
# also die with it if it is killed outright); an interrupted run writes no result.
set -euo pipefail
cd "$(dirname "$0")/.."
build="${POLYPORT_BUILD_DIR:-build}"
rounds="${POLYPORT_BENCH_ROUNDS:-10000}"
warmup="${POLYPORT_BENCH_WARMUP:-1000}"

if ! grep -qs '^POLYPORT_BUILD_BENCHMARKS:BOOL=ON$' "$build/CMakeCache.txt"; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPOLYPORT_BUILD_BENCHMARKS=ON >/dev/null
fi
if ! cmake --build "$build" -j "${POLYPORT_JOBS:-2}" --target bench_dds_pingpong; then
  echo "bench_dds_pingpong did not build; it needs Cyclone DDS, Fast DDS, idlc, fastddsgen and both DDS models" >&2
  exit 1
fi

# Which sources were measured: the commit, and whether tracked files differed from it.
revision="$(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
if [ "$revision" != unknown ] && [ -n "$(GIT_OPTIONAL_LOCKS=0 git status --porcelain --untracked-files=no 2>/dev/null)" ]; then
  revision="${revision}+dirty"
fi
export POLYPORT_GIT_REVISION="$revision"

mkdir -p benchmarks/results
out="benchmarks/results/dds_pingpong-$(date -u +%Y%m%dT%H%M%SZ).json"
# In the background so that the traps run while it works (bash runs a trap only once a
# foreground command has returned).
"$build/bin/bench_dds_pingpong" "$out" "$rounds" "$warmup" "$@" &
runner=$!
stop() {
  kill -TERM "$runner" 2>/dev/null || true
  wait "$runner" 2>/dev/null || true
}
trap 'stop; exit 130' INT TERM HUP
trap stop EXIT
rc=0
wait "$runner" || rc=$?
trap - EXIT
if [ "$rc" -ne 0 ] && [ -f "$out" ]; then
  echo "$out: some cases have no targets (see their error fields)" >&2
fi
exit "$rc"
