#!/usr/bin/env bash
# Sets up, builds and runs the daemon in the foreground on a profile (default: the shipped
# wheelchair application). Ctrl-C stops it, prints the final statistics and writes them as
# JSON to polyport-stats.json (override with POLYPORT_STATS_JSON).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
./scripts/build.sh
exec ./build/bin/polyportd run "${1:-profiles/wheelchair_inproc.xml}" \
  --stats-json "${POLYPORT_STATS_JSON:-polyport-stats.json}" "${@:2}"
