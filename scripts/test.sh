#!/usr/bin/env bash
# Sets up, builds and runs the whole test suite (labels unit, integration, vm and package).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
./scripts/build.sh
ctest --test-dir build --output-on-failure -j "${POLYPORT_JOBS:-2}" --timeout 300 "$@"
