#!/usr/bin/env bash
# The LCM ping-pong latency benchmark, run by hand (never a test): 16 B and 1 KiB messages,
# unpinned and on one core: direct, via polyportd and via a native lcm-gen relay, in a private
# network namespace (run as root). scripts/bench_pingpong.sh does the work and says more.
#
#   scripts/bench_lcm.sh [runner options]   e.g. --placements unpinned --sizes 16
#                                           (benchmarks/lcm/run_pingpong.cpp lists them all)
exec "$(dirname "$0")/bench_pingpong.sh" lcm "$@"
