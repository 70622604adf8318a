#!/usr/bin/env bash
# A ping-pong benchmark run N times over, and the verdicts over the runs (run by hand, never a
# test). One run's paired chunks leave out what moves between its chunks, not what a case's
# start fixes for the whole run (thread placement, pool slots): a bar near its limit can hold
# in one run and miss in the next. Each run here starts every process anew, so the N runs'
# figures decide it (benchmarks/common/runs.py: the sign test over runs, given at 95 % or
# more, i.e. from six runs).
#
#   scripts/bench_runs.sh N lcm|can|dds|matrix [options of that benchmark's script]
#     N        runs (6 or more for a verdict)
#     matrix   scripts/bench_matrix.sh; give it --part host or --part vcan (one part per series
#              of runs), e.g. scripts/bench_runs.sh 6 matrix --part host --models lcm,fastdds
# Placements and sizes take turns: where the options name neither, every other run measures
# them in reverse order, so no case always runs first or last (the order of the DDS vendors
# and of the matrix's pairs stays the runner's). Ctrl-C or SIGTERM stops the running benchmark
# and the series; a run that writes no result ends the series, and the verdicts cover the runs
# before it.
# Writes benchmarks/results/<benchmark>_runs-<UTC stamp>.json and .md beside the runs' own
# files, and prints the table. The environment of the benchmark's script applies
# (POLYPORT_BENCH_ROUNDS, ...).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bench_common.sh
usage() {
  echo "usage: $0 N lcm|can|dds|matrix [options of scripts/bench_<benchmark>.sh]" >&2
  exit 2
}
[ $# -ge 2 ] || usage
runs="$1"
kind="$2"
shift 2
[[ "$runs" =~ ^[1-9][0-9]*$ ]] || usage
case "$kind" in
  lcm|can|dds) script=(scripts/bench_pingpong.sh "$kind"); pattern="${kind}_pingpong" ;;
  matrix)
    if [ "${1:-}" != --part ] || { [ "${2:-}" != host ] && [ "${2:-}" != vcan ]; }; then
      echo "$0: matrix runs need --part host or --part vcan first" >&2
      exit 2
    fi
    script=(scripts/bench_matrix.sh); pattern=matrix ;;
  *) usage ;;
esac

# The runner's defaults, in reverse, for the even runs (only for what the options leave open).
reversed=()
case " $* " in *" --placements "*) ;; *)
  case "$kind" in
    can) ;;  # the guest runs unpinned only
    matrix) [ "${2:-}" = vcan ] || reversed+=(--placements "one-core,unpinned") ;;
    *) reversed+=(--placements "one-core,unpinned") ;;
  esac ;;
esac
case " $* " in *" --sizes "*) ;; *)
  case "$kind" in
    lcm|dds|matrix) reversed+=(--sizes "1024,16") ;;  # the matrix's CAN pairs: FD 64 B, then classic 8 B
  esac ;;
esac

files=()
for ((i = 1; i <= runs; i++)); do
  extra=()
  [ $((i % 2)) -eq 1 ] || extra=("${reversed[@]}")
  echo "== run $i of $runs${extra:+ (${extra[*]})}" >&2
  before=$(ls benchmarks/results 2>/dev/null || true)
  # bench_run: SIGINT / SIGTERM to this script stop the running benchmark too.
  bench_run "${script[@]}" "$@" "${extra[@]}"
  rc=$bench_rc
  case $rc in 130|143) echo "interrupted in run $i: no summary" >&2; exit "$rc" ;; esac
  # This run's results: the runner's new JSON files (not the report's .md/.png; runs.py
  # refuses anything else).
  found=0
  for path in benchmarks/results/"$pattern"-*.json; do
    name=${path##*/}
    [[ "$name" =~ ^${pattern}-[0-9]{8}T[0-9]{6}Z(-vcan)?\.json$ ]] || continue
    grep -qxF "$name" <<< "$before" && continue
    files+=("$path")
    found=1
  done
  if [ "$found" -eq 0 ]; then
    echo "run $i wrote no result (exit status $rc): the series stops here" >&2
    break
  fi
  [ "$rc" -eq 0 ] || echo "run $i exited with $rc: its cases without targets are left out of the verdicts" >&2
done
[ "${#files[@]}" -gt 0 ] || { echo "no run wrote a result" >&2; exit 1; }
name=$kind
[ "$kind" = matrix ] && name="matrix-$2"
out="benchmarks/results/${name}_runs-$(date -u +%Y%m%dT%H%M%SZ)"
/usr/bin/python3 benchmarks/common/runs.py --out "$out" "${files[@]}"
echo "written: $out.json, $out.md" >&2
