#!/usr/bin/env bash
# The DDS ping-pong latency benchmark, run by hand (never a test): both vendors, 16 B and 1 KiB,
# unpinned and on one core: direct, via polyportd and via a native relay; about three minutes on a
# 2-core machine. scripts/bench_pingpong.sh does the work and says more.
#
#   scripts/bench_dds.sh [runner options]   e.g. --placements unpinned --vendors cyclonedds
#                                           (benchmarks/dds/run_pingpong.cpp lists them all)
exec "$(dirname "$0")/bench_pingpong.sh" dds "$@"
