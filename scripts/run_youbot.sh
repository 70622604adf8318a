#!/usr/bin/env bash
# Runs the youBot case of the JOrocos paper (seed 000, section 5) in one of three
# configurations and shows what the monitor sees:
#
#   scripts/run_youbot.sh [inproc|dds-monitor|dds-driver] [SECONDS]
#
#   inproc       both components in polyportd (profiles/youbot.xml)
#   dds-monitor  the driver in polyportd, the monitor a Cyclone DDS program
#                (profiles/youbot_dds_monitor.xml + youbot_dds_node --role monitor)
#   dds-driver   the monitor in polyportd, the driver a Cyclone DDS program
#                (profiles/youbot_dds_driver.xml + youbot_dds_node --role driver)
#
# Runs for SECONDS (default 8), or until Ctrl-C, then stops every process it started and
# prints polyportd's final statistics line. Builds first when the build is missing.
set -euo pipefail
cd "$(dirname "$0")/.."
mode="${1:-inproc}"
seconds="${2:-8}"
bin=build/bin
if [[ ! -x $bin/polyportd || ! -e build/lib/libpolyport_youbot.so ]]; then ./scripts/build.sh; fi
export CYCLONEDDS_URI="file://$PWD/config/cyclonedds-loopback.xml"

case "$mode" in
  inproc) profile=profiles/youbot.xml; node_role= ;;
  dds-monitor) profile=profiles/youbot_dds_monitor.xml; node_role=monitor ;;
  dds-driver) profile=profiles/youbot_dds_driver.xml; node_role=driver ;;
  *) echo "usage: $0 [inproc|dds-monitor|dds-driver] [seconds]" >&2; exit 2 ;;
esac
if [[ -n $node_role && ! -x $bin/youbot_dds_node ]]; then
  echo "youbot_dds_node was not built (it needs cyclonedds-dev and idlc: apt install cyclonedds-dev cyclonedds-tools)" >&2
  exit 1
fi

pids=()
stop_all() {
  for pid in "${pids[@]}"; do kill -INT "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null || true; done
  pids=()
}
trap stop_all EXIT INT TERM

echo "== youBot, $mode: $profile${node_role:+ + youbot_dds_node --role $node_role} for ${seconds} s"
# A DDS driver runs before polyport's monitor commands it; a DDS monitor waits for polyport's
# driver by itself (it starts its script once every topic matched).
if [[ $node_role == driver ]]; then
  "$bin/youbot_dds_node" --role driver > >(sed -u 's/^/[dds driver] /') &
  pids+=($!)
fi
"$bin/polyportd" run "$profile" --stats-interval 0 --admin-socket none --duration "$seconds" \
  > >(sed -u 's/^/[polyportd] /') 2>&1 &
daemon=$!
pids+=($daemon)
if [[ $node_role == monitor ]]; then
  "$bin/youbot_dds_node" --role monitor --duration "$seconds" > >(sed -u 's/^/[dds monitor] /') &
  pids+=($!)
fi
wait "$daemon" || true
stop_all
