#!/usr/bin/env bash
# Sets up, builds and runs the whole test suite (labels unit, integration, vm and package).
# The benchmark programs are built too: their tests (the cross-model matrix's in-process
# plugin and CAN relays, checked working, never timed) are part of the suite.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
./scripts/build.sh -DPOLYPORT_BUILD_BENCHMARKS=ON
ctest --test-dir build --output-on-failure -j "${POLYPORT_JOBS:-2}" --timeout 300 "$@"
