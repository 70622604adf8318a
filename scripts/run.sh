#!/usr/bin/env bash
# Sets up, builds and runs the daemon in the foreground on a profile (default: the shipped
# wheelchair application). Ctrl-C stops it and prints the final statistics.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
./scripts/build.sh
exec ./build/bin/polyportd run "${1:-profiles/wheelchair_inproc.xml}" "${@:2}"
