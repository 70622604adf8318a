#!/usr/bin/env bash
# The wake-lateness benchmark, run by hand (never a test): builds bench_wake_lateness and runs
# it once, writing benchmarks/results/wake_lateness-<UTC stamp>.json. It measures wake -
# deadline of a clock_nanosleep loop (timer slack 1 ns), of an ExecutionContext at its
# defaults and of ExecutionContexts with spin tails, taking turns in chunks (README.md,
# "Benchmarks"; benchmarks/bench_wake_lateness.cpp).
#
#   scripts/bench_wake.sh [--periods N] [--chunks C] [--period-ms P[,P...]] [--spin-us S[,S...]] [--fifo PRIO]
#     defaults: 1000 periods per case (10 s each at 10 ms), 10 chunks, 10 ms, spin 100,300 us,
#     SCHED_OTHER (--fifo PRIO: every case under SCHED_FIFO at PRIO; needs CAP_SYS_NICE)
# Environment: POLYPORT_BUILD_DIR (default: build; benchmarks are switched on in it),
# POLYPORT_JOBS (2).
#
# Ctrl-C or SIGTERM stops it without writing a result.
set -euo pipefail
cd "$(dirname "$0")/.."
build="${POLYPORT_BUILD_DIR:-build}"

if ! grep -qs '^POLYPORT_BUILD_BENCHMARKS:BOOL=ON$' "$build/CMakeCache.txt"; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPOLYPORT_BUILD_BENCHMARKS=ON >/dev/null
fi
cmake --build "$build" -j "${POLYPORT_JOBS:-2}" --target bench_wake_lateness

# Which sources were measured: the commit, and whether tracked files differed from it.
revision="$(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
if [ "$revision" != unknown ] && [ -n "$(GIT_OPTIONAL_LOCKS=0 git status --porcelain --untracked-files=no 2>/dev/null)" ]; then
  revision="${revision}+dirty"
fi
export POLYPORT_GIT_REVISION="$revision"

mkdir -p benchmarks/results
out="benchmarks/results/wake_lateness-$(date -u +%Y%m%dT%H%M%SZ).json"
exec "$build/bin/bench_wake_lateness" "$out" "$@"
