#!/usr/bin/env bash
# The wheelchair benchmark suite, run by hand (never a test; benchmarks/wheelchair/README.md):
# builds polyportd, the bus simulator and the DDS and LCM programs, runs every configuration
# of benchmarks/wheelchair/configurations.json meant for the guest against the simulator on
# vcan0 (inside scripts/vcan-run: the user-mode Linux guest where the host kernel has no
# vcan), then those meant for the host (no CAN, no simulator), then writes
# benchmarks/results/wheelchair-<UTC stamp>.{json,md} and the -steering / -latency PNGs.
#
#   scripts/bench_wheelchair.sh [--duration S] [--repeat N] [--only native_a,mixed] [--scenario "..."]
#     --duration S   seconds of scenario per configuration (default 12: 1200 periods)
#     --repeat N     run the configurations N times, interleaved (default 1)
#     --only NAMES   some configurations (default: all)
#     --scenario T   the simulator's stick ("time_s:angle_deg:magnitude; ...")
# Environment: POLYPORT_BUILD_DIR (default build), POLYPORT_JOBS (2), POLYPORT_WHEELCHAIR_RUN_DIR
# (keep the run's raw files there).
set -euo pipefail
cd "$(dirname "$0")/.."
build="${POLYPORT_BUILD_DIR:-build}"
if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
fi
echo "[wheelchair] building polyportd, wheelchair_sim and the component programs"
cmake --build "$build" -j "${POLYPORT_JOBS:-2}" --target polyportd polyport_wheelchair wheelchair_sim wheelchair_dds_node wheelchair_fastdds_hw wheelchair_lcm_joystick
# The raw files of the run (traces, summaries, logs, polyportd's statistics): kept in
# POLYPORT_WHEELCHAIR_RUN_DIR when set (report.py DIR rebuilds the report from them),
# otherwise in a temporary folder that goes at the end.
if [ -n "${POLYPORT_WHEELCHAIR_RUN_DIR:-}" ]; then
  run_dir="$POLYPORT_WHEELCHAIR_RUN_DIR"
  mkdir -p "$run_dir"
else
  run_dir="$(mktemp -d /tmp/polyport-wheelchair.XXXXXX)"
  trap 'rm -rf "$run_dir"' EXIT
fi
# The guest's watchdog: 900 s a round (five configurations of 12 s take about 90 s).
repeat=1
previous=""
for arg in "$@"; do
  [ "$previous" != --repeat ] || repeat=$arg
  [[ "$arg" != --repeat=* ]] || repeat=${arg#--repeat=}
  previous=$arg
done
[[ "$repeat" =~ ^[1-9][0-9]*$ ]] || { echo "bench_wheelchair.sh: --repeat $repeat: expected 1 or more" >&2; exit 2; }
rc=0
scripts/vcan-run --interfaces 2 --timeout $((900 * repeat)) --rw "$run_dir" -- \
  /usr/bin/python3 benchmarks/wheelchair/run_configs.py --out "$run_dir" --bin "$(cd "$build/bin" && pwd)" "$@" || rc=$?
# The configurations meant for the host (no CAN: their Joystick -> Control hop where clocks
# are cheap), into the same run folder.
/usr/bin/python3 benchmarks/wheelchair/run_configs.py --where host --out "$run_dir" --bin "$(cd "$build/bin" && pwd)" "$@" || rc=$?
# The report also covers a partly failed run: what did run is worth the numbers.
/usr/bin/python3 benchmarks/wheelchair/report.py "$run_dir"
exit "$rc"
