#!/usr/bin/env bash
# A ping-pong latency benchmark, run by hand (never a test): builds its runner (with its
# ping/pong programs and polyportd) and runs it once, writing
# benchmarks/results/<model>_pingpong-<UTC stamp>.json. Each runs direct, via polyportd and
# via a native relay, and reports median and p99 per series, polyport's in-to-out time and the
# CPU time per round trip (docs/BENCHMARKS.md).
#
#   scripts/bench_pingpong.sh dds|lcm|can [runner options]
#     dds  both DDS vendors, 16 B and 1 KiB, unpinned and on one core (about three minutes on
#          a 2-core machine); scripts/bench_dds.sh
#     lcm  16 B and 1 KiB LCM messages, unpinned and on one core, in a private network
#          namespace (needs root; under a minute); scripts/bench_lcm.sh
#     can  classic CAN frames on vcan0..vcan4, inside scripts/vcan-run (the user-mode Linux
#          guest where the host kernel has no vcan; about a minute); scripts/bench_can.sh
#   Runner options: benchmarks/<model>/run_pingpong.cpp lists them (e.g. --placements unpinned).
# Environment: POLYPORT_BUILD_DIR (default: build; benchmarks are switched on in it),
# POLYPORT_BENCH_ROUNDS (10000 measured round trips per series), POLYPORT_BENCH_WARMUP (1000
# per ping process), POLYPORT_JOBS (2).
#
# Ctrl-C or SIGTERM stops the runner, which stops its ping, pong and polyportd processes (they
# also die with it if it is killed outright); an interrupted run writes no result.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bench_common.sh
model="${1:-}"
case "$model" in
  dds) needs="Cyclone DDS, Fast DDS, idlc, fastddsgen and both DDS models" ;;
  lcm) needs="liblcm, lcm-gen and the LCM model" ;;
  can) needs="the SocketCAN model" ;;
  *) echo "usage: $0 dds|lcm|can [runner options]" >&2; exit 2 ;;
esac
shift
build="${POLYPORT_BUILD_DIR:-build}"
rounds="${POLYPORT_BENCH_ROUNDS:-10000}"
warmup="${POLYPORT_BENCH_WARMUP:-1000}"
runner="bench_${model}_pingpong"

bench_build "$build" "$runner" "$needs"

bench_revision

mkdir -p benchmarks/results
out="benchmarks/results/${model}_pingpong-$(date -u +%Y%m%dT%H%M%SZ).json"
command=("$build/bin/$runner" "$out" "$rounds" "$warmup" "$@")
if [ "$model" = can ]; then
  # Five interfaces: direct, via polyportd (two), via the relay (two). The guest sees one CPU
  # and its own load, so the result also records the machine it runs on.
  POLYPORT_BENCH_OUTER_HOST="$(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(uname -sr), loadavg $(cut -d' ' -f1-3 /proc/loadavg)"
  export POLYPORT_BENCH_OUTER_HOST
  command=(scripts/vcan-run --interfaces 5 --timeout 3600 -- "${command[@]}")
fi
bench_run "${command[@]}"
rc=$bench_rc
if [ "$rc" -ne 0 ] && [ -f "$out" ]; then
  echo "$out: some cases have no targets (see their error fields)" >&2
fi
exit "$rc"
