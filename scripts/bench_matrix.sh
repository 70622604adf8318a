#!/usr/bin/env bash
# The cross-model latency matrix, run by hand (never a test): builds bench_matrix (with the
# DDS and LCM ping/pong programs, the native relays between two SDKs and polyportd), runs it
# once and turns its result into the table and the heat map:
#   benchmarks/results/matrix-<UTC stamp>.json   every raw figure, and per pair whether each
#                                                bar holds (or why the pair is not measured)
#   benchmarks/results/matrix-<UTC stamp>-vcan.json  the same of the CAN pairs (vcan guest)
#   benchmarks/results/matrix-<UTC stamp>.md     the table (rows source model, columns target)
#   benchmarks/results/matrix-<UTC stamp>.png    the heat map
# Two parts, one table:
#   host  every ordered pair of Cyclone DDS, Fast DDS and LCM (the diagonal with its direct
#         series), via polyportd and via a native relay, and the in-process pairs (against
#         direct), 16 B and 1 KiB, in a private network namespace (needs root), as the LCM
#         benchmark does;
#   vcan  CAN -> each model and each model -> CAN (in-process included: an in-process pong
#         or ping in polyportd against pingpong_can, beside CAN's direct series), and the CAN
#         diagonal, classic 8-byte frames (the 16 B column's analog) and CAN FD 64-byte frames
#         (the 1 KiB column's), with every program model's diagonal for the direct figures of
#         the second bar, inside scripts/vcan-run (the user-mode Linux guest on a host without
#         vcan: one CPU, every figure inflated, so a CAN pair is compared with its relay and
#         the guest's direct figures from the same run).
#
#   scripts/bench_matrix.sh [--part host|vcan|both] [runner options]
#     --part   which part to run (default both); the report covers what ran
#     runner options: benchmarks/matrix/run_matrix.cpp lists them, e.g. --placements unpinned
#     --sizes 16; they go to both parts (the vcan part runs unpinned unless told otherwise)
# With the defaults below (3000 round trips per series, unpinned and on one core) the host part
# takes about five minutes on a 2-core machine, the vcan part a few more.
# Environment: POLYPORT_BUILD_DIR (default: build; benchmarks are switched on in it),
# POLYPORT_BENCH_ROUNDS (3000 measured round trips per series), POLYPORT_BENCH_WARMUP (500
# per ping process), POLYPORT_BENCH_CHUNKS (4), POLYPORT_JOBS (2).
# The vcan part needs Debian's user-mode-linux (scripts/vcan-run installs it when missing).
#
# Ctrl-C or SIGTERM stops the runner, which stops its ping, pong, relay and polyportd
# processes; an interrupted run writes no result.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bench_common.sh
build="${POLYPORT_BUILD_DIR:-build}"
rounds="${POLYPORT_BENCH_ROUNDS:-3000}"
warmup="${POLYPORT_BENCH_WARMUP:-500}"
chunks="${POLYPORT_BENCH_CHUNKS:-4}"
part=both
if [ "${1:-}" = --part ]; then
  part="${2:-}"
  shift 2 || true
fi
case "$part" in
  host|vcan|both) ;;
  *) echo "usage: $0 [--part host|vcan|both] [runner options]" >&2; exit 2 ;;
esac

echo "== building bench_matrix in $build" >&2
bench_build "$build" bench_matrix "Cyclone DDS, Fast DDS, idlc, fastddsgen, liblcm, lcm-gen and the DDS and LCM models"
if ! /usr/bin/python3 -c 'import matplotlib, numpy' 2>/dev/null; then
  echo "the report needs Debian's python3-matplotlib and python3-numpy (/usr/bin/python3)" >&2
  exit 1
fi

bench_revision

mkdir -p benchmarks/results
stem="benchmarks/results/matrix-$(date -u +%Y%m%dT%H%M%SZ)"
files=()
rc=0
if [ "$part" != vcan ]; then
  out="$stem.json"
  echo "== running the matrix's host part ($rounds round trips per series in $chunks chunks; one line per case)" >&2
  bench_run "$build/bin/bench_matrix" "$out" "$rounds" "$warmup" --chunks "$chunks" "$@"
  [ "$bench_rc" -eq 0 ] || rc=$bench_rc
  if [ -f "$out" ]; then
    files+=("$out")
    [ "$bench_rc" -eq 0 ] || echo "$out: some cases have no targets (see their error fields)" >&2
  else
    echo "no host result written (bench_matrix exited with $bench_rc)" >&2
  fi
fi
if [ "$part" != host ]; then
  out="$stem-vcan.json"
  [ "$part" = vcan ] && out="$stem.json"
  # Five interfaces per CAN pair: CAN -> each of the four other models, each -> CAN, and CAN -> CAN.
  # DDS domains from 100: 16 pairs of five (the host part's 185 leaves room for 9).
  POLYPORT_BENCH_OUTER_HOST="$(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(uname -sr), loadavg $(cut -d' ' -f1-3 /proc/loadavg)"
  export POLYPORT_BENCH_OUTER_HOST
  echo "== running the matrix's CAN pairs in the vcan guest ($rounds round trips per series in $chunks chunks)" >&2
  # --fd: the FD MTU on every interface (classic frames pass there too, as on an FD bus).
  bench_run scripts/vcan-run --interfaces 45 --fd --timeout 7200 -- "$build/bin/bench_matrix" "$out" "$rounds" \
    "$warmup" --chunks "$chunks" --models can,cyclonedds,fastdds,lcm,inprocess --pairs can --placements unpinned \
    --domain-base 100 "$@"
  [ "$bench_rc" -eq 0 ] || rc=$bench_rc
  if [ -f "$out" ]; then
    files+=("$out")
    [ "$bench_rc" -eq 0 ] || echo "$out: some cases have no targets (see their error fields)" >&2
  else
    echo "no vcan result written (bench_matrix exited with $bench_rc)" >&2
  fi
fi
[ "${#files[@]}" -gt 0 ] || exit "$rc"
echo "== report" >&2
/usr/bin/python3 benchmarks/matrix/report.py "${files[@]}"
exit "$rc"
