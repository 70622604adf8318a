#!/usr/bin/env bash
# The CAN ping-pong latency benchmark, run by hand (never a test): classic frames on vcan, direct,
# via polyportd and via a native raw-socket relay, inside scripts/vcan-run --interfaces 5.
# scripts/bench_pingpong.sh does the work and says more.
#
#   scripts/bench_can.sh [runner options]   e.g. --chunks 3
#                                           (benchmarks/can/run_pingpong.cpp lists them all)
exec "$(dirname "$0")/bench_pingpong.sh" can "$@"
