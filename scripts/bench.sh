#!/usr/bin/env bash
# Builds the benchmarks and runs them, writing one JSON file per run into
# benchmarks/results/ (git revision, host, settings, median and p99 per case).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
./scripts/build.sh -DPOLYPORT_BUILD_BENCHMARKS=ON
mkdir -p benchmarks/results
stamp="$(date -u +%Y%m%dT%H%M%SZ)"
export POLYPORT_GIT_REVISION="$(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
for bench in inproc_connection conversion; do
  out="benchmarks/results/${bench}-${stamp}.json"
  ./build/bin/bench_${bench} --benchmark_out="$out" --benchmark_out_format=json --benchmark_min_time=0.05 \
    --benchmark_enable_random_interleaving=true "$@"
  echo "results: $out"
done
# DDS ping-pong: direct vs via polyportd, both vendors, 16 B and 1 KiB (needs both SDKs).
if [ -x ./build/bin/bench_dds_pingpong ]; then
  ./build/bin/bench_dds_pingpong "benchmarks/results/dds_pingpong-${stamp}.json" 10000 1000
else
  echo "bench_dds_pingpong not built (needs Cyclone DDS, Fast DDS, idlc and fastddsgen); skipped" >&2
fi
# LCM ping-pong (a private network namespace: needs root) and CAN ping-pong (in the vcan guest).
if [ -x ./build/bin/bench_lcm_pingpong ]; then
  ./build/bin/bench_lcm_pingpong "benchmarks/results/lcm_pingpong-${stamp}.json" 10000 1000
fi
if [ -x ./build/bin/bench_can_pingpong ]; then
  ./scripts/vcan-run --interfaces 5 --timeout 3600 -- \
    ./build/bin/bench_can_pingpong "benchmarks/results/can_pingpong-${stamp}.json" 10000 1000
fi
