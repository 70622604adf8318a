#!/usr/bin/env bash
# Counts what polyportd and the native relay each do per round trip of a ping-pong path, on one
# core (benchmarks/common/counts.py says how): system calls (strace) and user-space
# instructions by library (valgrind's callgrind). Run by hand as root (never a test). Writes
# benchmarks/results/<lcm|matrix>_counts-<UTC stamp>.{json,md}.
#
#   scripts/bench_counts.sh lcm [--sizes 16,1024] [--rounds SHORT,LONG]     about a minute
#   scripts/bench_counts.sh matrix [--models fastdds,lcm] [--sizes 16] [--rounds SHORT,LONG]
#       every cross pair of --models (cyclonedds, fastdds, lcm), a few minutes a pair
#   --keep DIR  also keeps the raw strace tables and callgrind profiles there (for
#               callgrind_annotate by function)
# Environment: POLYPORT_BUILD_DIR (default: build), POLYPORT_JOBS (2).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bench_common.sh
benchmark="${1:-}"
case "$benchmark" in
  lcm | matrix) shift ;;
  *) echo "usage: $0 lcm|matrix [--models LIST] [--sizes LIST] [--rounds SHORT,LONG] [--keep DIR]" >&2; exit 2 ;;
esac
models=fastdds,lcm
sizes=$([ "$benchmark" = lcm ] && echo 16,1024 || echo 16)
rounds=1000,3000
keep=
while [ $# -gt 0 ]; do
  case "$1" in
    --models) models="$2"; shift 2 ;;
    --sizes) sizes="$2"; shift 2 ;;
    --rounds) rounds="$2"; shift 2 ;;
    --keep) keep="$2"; shift 2 ;;
    *) echo "$0: unknown option $1" >&2; exit 2 ;;
  esac
done
build="${POLYPORT_BUILD_DIR:-build}"
command -v strace >/dev/null && command -v valgrind >/dev/null || scripts/setup.sh  # installs both
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
# The profiles are the benchmark's own: a short one-core run of its runner keeps them.
if [ "$benchmark" = lcm ]; then
  bench_build "$build" bench_lcm_pingpong "liblcm, lcm-gen and the LCM model"
  made=("$build/bin/bench_lcm_pingpong" "$work/result.json" 20 5 --chunks 1 --placements one-core --sizes "$sizes")
else
  bench_build "$build" bench_matrix "Cyclone DDS, Fast DDS, LCM and their generators"
  made=("$build/bin/bench_matrix" "$work/result.json" 20 5 --chunks 1 --placements one-core --sizes "$sizes"
    --models "$models" --pairs cross)
fi
bench_revision
"${made[@]}" --keep "$work/profiles" >"$work/profiles.log" 2>&1 ||
  { cat "$work/profiles.log" >&2; echo "${made[0]} could not make the profiles" >&2; exit 1; }
mkdir -p benchmarks/results
out="benchmarks/results/${benchmark}_counts-$(date -u +%Y%m%dT%H%M%SZ)"
# A network namespace of its own with loopback's multicast route, as the runners make; it
# disappears with the command.
unshare -n bash -c 'ip link set lo up && ip link set lo multicast on && ip route add 239.255.76.67/32 dev lo &&
  exec python3 benchmarks/common/counts.py "$@"' counts "$benchmark" "$work/counts" --bin "$build/bin" \
  --profiles "$work/profiles" --result "$work/result.json" --rounds "$rounds"
cp "$work/counts.json" "$out.json"
cp "$work/counts.md" "$out.md"
if [ -n "$keep" ]; then
  mkdir -p "$keep" && cp "$work"/counts.*.strace "$work"/counts.*.callgrind "$keep"/ && echo "raw counts: $keep"
fi
echo "results: $out.{json,md}"
