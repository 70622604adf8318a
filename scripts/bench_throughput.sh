#!/usr/bin/env bash
# DDS forwarding throughput on one core, run by hand (never a test): Cyclone DDS's ddsperf
# publishes, polyportd (alone on CPU 1) bridges passthrough and converting connections, a
# second ddsperf subscribes (benchmarks/throughput/README.md). Runs in a private network
# namespace (root) so that no other DDS traffic meets it. Writes
# benchmarks/results/dds_throughput-<UTC stamp>.{json,md}. In-process throughput on one core
# is bench_inproc_connection's (scripts/bench.sh).
#
#   scripts/bench_throughput.sh [--rates 10kHz,50kHz,inf] [--window-s 5] [--warmup-s 2]
# Environment: POLYPORT_BUILD_DIR (default: build; benchmarks are switched on in it),
# POLYPORT_JOBS (2).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bench_common.sh
build="${POLYPORT_BUILD_DIR:-build}"

if [ "$(id -u)" != 0 ]; then
  echo "bench_throughput: needs root for a private network namespace (unshare --net)" >&2
  exit 1
fi
for target in polyportd polyportctl; do
  bench_build "$build" "$target" "Cyclone DDS (scripts/setup.sh)"
done
bench_revision
bench_run unshare --net /bin/sh -c 'ip link set lo up && exec /usr/bin/python3 "$@"' throughput \
  benchmarks/throughput/bench_dds_throughput.py --polyportd "$build/bin/polyportd" \
  --polyportctl "$build/bin/polyportctl" --out-dir benchmarks/results "$@"
exit "$bench_rc"
