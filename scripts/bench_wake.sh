#!/usr/bin/env bash
# The wake-lateness benchmark, run by hand (never a test): builds bench_wake_lateness and runs
# it once, writing benchmarks/results/wake_lateness-<UTC stamp>.json. It measures wake -
# deadline of a clock_nanosleep loop (timer slack 1 ns), of an ExecutionContext at its
# defaults and of ExecutionContexts with spin tails, taking turns in chunks (docs/BENCHMARKS.md,
# "Jitter and load" and the wake-lateness runs before it; benchmarks/bench_wake_lateness.cpp).
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
source scripts/bench_common.sh
build="${POLYPORT_BUILD_DIR:-build}"

bench_build "$build" bench_wake_lateness "only polyport's core"

bench_revision

mkdir -p benchmarks/results
out="benchmarks/results/wake_lateness-$(date -u +%Y%m%dT%H%M%SZ).json"
exec "$build/bin/bench_wake_lateness" "$out" "$@"
