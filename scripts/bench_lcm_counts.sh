#!/usr/bin/env bash
# Counts what polyportd and the native LCM relay each do per round trip of the LCM ping-pong,
# one core (benchmarks/lcm/counts.py says how): system calls (strace) and user-space
# instructions by library (valgrind's callgrind). Run by hand as root (never a test); about
# four minutes for both sizes. Writes benchmarks/results/lcm_counts-<UTC stamp>.{json,md}.
#
#   scripts/bench_lcm_counts.sh [--sizes 16,1024] [--rounds SHORT,LONG]
# Environment: POLYPORT_BUILD_DIR (default: build), POLYPORT_JOBS (2).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bench_common.sh
build="${POLYPORT_BUILD_DIR:-build}"
command -v strace >/dev/null && command -v valgrind >/dev/null || scripts/setup.sh  # installs both
bench_build "$build" bench_lcm_pingpong "liblcm, lcm-gen and the LCM model"
bench_revision
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
# The profiles are the benchmark's own: a short one-core run of its runner keeps them.
"$build/bin/bench_lcm_pingpong" "$work/profiles.json" 20 5 --chunks 1 --placements one-core --keep "$work/profiles" >"$work/profiles.log" 2>&1 ||
  { cat "$work/profiles.log" >&2; echo "bench_lcm_pingpong could not make the profiles" >&2; exit 1; }
mkdir -p benchmarks/results
out="benchmarks/results/lcm_counts-$(date -u +%Y%m%dT%H%M%SZ)"
# A network namespace of its own with loopback's multicast route, as the runner makes; it
# disappears with the command.
unshare -n bash -c 'ip link set lo up && ip link set lo multicast on && ip route add 239.255.76.67/32 dev lo &&
  exec python3 benchmarks/lcm/counts.py "$@"' counts "$work/counts" --bin "$build/bin" --profiles "$work/profiles" "$@"
cp "$work/counts.json" "$out.json"
cp "$work/counts.md" "$out.md"
echo "results: $out.{json,md}"
