#!/usr/bin/env bash
# The soak, run by hand (never a test, never CI): two polyportd processes forward 10 kHz over
# 100 paths across in-process, Cyclone DDS, Fast DDS and LCM for a given duration, reporting
# loss on the reliable paths, RSS over time and latency percentiles per interval
# (benchmarks/soak/README.md). Runs in a private network namespace (root) whose loopback has
# the multicast route LCM needs, so it meets no other DDS or LCM traffic. Writes
# benchmarks/results/soak-<UTC stamp>.{json,md}; exit status 1 when a reliable path lost a sample.
#
#   scripts/soak.sh [--duration-s 600] [--interval-s 60] [--paths inproc=40,cyclonedds=20,fastdds=20,lcm=20]
# Environment: POLYPORT_BUILD_DIR (default: build; benchmarks are switched on in it),
# POLYPORT_JOBS (2).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bench_common.sh
build="${POLYPORT_BUILD_DIR:-build}"

if [ "$(id -u)" != 0 ]; then
  echo "soak: needs root for a private network namespace (unshare --net)" >&2
  exit 1
fi
for target in polyportd polyport_scale_components; do
  bench_build "$build" "$target" "Cyclone DDS, Fast DDS and LCM (scripts/setup.sh)"
done
bench_revision
bench_run unshare --net /bin/sh -c 'ip link set lo up && ip link set lo multicast on &&
  ip route add 239.255.76.67 dev lo && exec /usr/bin/python3 "$@"' soak \
  benchmarks/soak/soak.py --polyportd "$build/bin/polyportd" --out-dir benchmarks/results "$@"
exit "$bench_rc"
