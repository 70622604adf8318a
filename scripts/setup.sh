#!/usr/bin/env bash
# Installs everything polyport needs to build and test, from Debian 12 packages only.
# Safe to run again: apt-get skips what is installed already.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config   # toolchain (g++ 12, CMake 3.25)
  libeigen3-dev          # fixed-size linear algebra for control components and mappings
  libpugixml-dev         # XML profiles, with byte offsets for file:line:col diagnostics
  libspdlog-dev          # the daemon's logging (never on the forwarding path)
  nlohmann-json3-dev     # statistics, traces and `check --json`
  libcli11-dev           # the daemon's command line
  libcpp-httplib-dev     # the HTTP server of the Prometheus endpoint (polyportd run --metrics-port)
  libgtest-dev libgmock-dev  # tests
  libbenchmark-dev       # micro-benchmarks (built with -DPOLYPORT_BUILD_BENCHMARKS=ON)
  libxml2-utils          # xmllint: shipped profiles are validated against config/polyport.xsd
  cyclonedds-dev cyclonedds-tools   # Cyclone DDS 0.10 and idlc: reference CDR peers in the tests
  libfastrtps-dev libfastcdr-dev fastddsgen  # Fast DDS 2.9, Fast CDR and fastddsgen: reference peers
  liblcm-dev liblcm-bin  # LCM 1.3 (the lcm model) and lcm-gen: test peers, reference fingerprints
  clang libclang-rt-14-dev  # libFuzzer for the parser and decoder fuzz targets
  python3-matplotlib python3-numpy  # the wheelchair suite's report: tables and PNG plots
  liburing-dev           # io_uring: the CAN receive thread sends what it forwards with its next wait
  libsystemd-dev         # sd_notify: polyportd under a Type=notify unit with the watchdog
  debootstrap            # scripts/test_deb.sh: a clean Debian 12 root to install the .deb in
  python3-prometheus-client  # the reference parser of the metrics test (Prometheus text format); the benchmarks read /metrics with it
  strace valgrind        # scripts/bench_counts.sh: system calls and instructions per round trip of a path's middles
  stress-ng              # scripts/bench_stress.sh: the CPU and memory stressor of the jitter benchmark
  # The vm tests (scripts/vcan-run installs these itself when missing; here CI has them up front):
  user-mode-linux        # a Linux kernel run as a process, with CAN modules: the host kernel has no CAN
  busybox-static         # the UML guest's init: mounts, insmod and ip without dynamic execs
  can-utils              # candump and cansend: reference peers on vcan
  iproute2               # ip: vcan links, the interface tests, and the LCM tests' loopback multicast route
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present"
  exit 0
fi
sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
