#!/usr/bin/env bash
# Builds the benchmarks and runs them, writing one JSON file per run into
# benchmarks/results/ (git revision, host, settings, median and p99 per case).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
./scripts/build.sh -DPOLYPORT_BUILD_BENCHMARKS=ON
mkdir -p benchmarks/results
out="benchmarks/results/inproc_connection-$(date -u +%Y%m%dT%H%M%SZ).json"
POLYPORT_GIT_REVISION="$(git rev-parse --short HEAD 2>/dev/null || echo unknown)" \
  ./build/bin/bench_inproc_connection --benchmark_out="$out" --benchmark_out_format=json \
  --benchmark_min_time=0.05 "$@"
echo "results: $out"
