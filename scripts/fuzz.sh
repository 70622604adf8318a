#!/usr/bin/env bash
# Builds the libFuzzer targets with clang into ./build-fuzz and runs each for SECONDS
# (default 60), starting from the seeds in tests/fuzz/corpus/<target>/. A crash, a leak or
# a sanitizer report fails the run and leaves the input in build-fuzz/artifacts/.
#   ./scripts/fuzz.sh [SECONDS] [TARGET...]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
shift || true
CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPOLYPORT_FUZZ=ON >/dev/null
cmake --build build-fuzz -j "${POLYPORT_JOBS:-2}"
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  shopt -s nullglob
  for f in tests/fuzz/*.cpp; do targets+=("$(basename "$f" .cpp)"); done
fi
mkdir -p build-fuzz/artifacts
for t in "${targets[@]}"; do
  corpus="build-fuzz/corpus/$t"
  mkdir -p "$corpus"
  if [ -d "tests/fuzz/corpus/$t" ]; then cp -n tests/fuzz/corpus/"$t"/* "$corpus"/ 2>/dev/null || true; fi
  echo "fuzz: $t for ${seconds}s"
  log="build-fuzz/$t.log"
  if ./build-fuzz/bin/"$t" -max_total_time="$seconds" -print_final_stats=1 \
      -artifact_prefix=build-fuzz/artifacts/"$t"- "$corpus" >"$log" 2>&1; then
    grep -E '^stat::number_of_executed_units' "$log" || true
  else
    tail -40 "$log"
    echo "fuzz: $t FAILED (input in build-fuzz/artifacts/)"
    exit 1
  fi
done
echo "fuzz: ${#targets[@]} target(s) ran ${seconds}s each without a finding"
