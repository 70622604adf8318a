# What the benchmark scripts share (sourced by bench_pingpong.sh, bench_matrix.sh and
# bench_wake.sh, from the repository root with `set -euo pipefail`):
#   bench_build DIR TARGET NEEDS   configures DIR with benchmarks on (once), builds TARGET, or
#                                  says what TARGET needs and exits 1
#   bench_revision                 exports POLYPORT_GIT_REVISION: the commit measured, "+dirty"
#                                  when tracked files differ from it
#   bench_run COMMAND...           runs COMMAND in the background so that SIGINT / SIGTERM /
#                                  SIGHUP to the script stop it (bash runs a trap only once a
#                                  foreground command has returned); sets bench_rc to its status

bench_build() {
  local build="$1" target="$2" needs="$3"
  if ! grep -qs '^POLYPORT_BUILD_BENCHMARKS:BOOL=ON$' "$build/CMakeCache.txt"; then
    cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPOLYPORT_BUILD_BENCHMARKS=ON >/dev/null
  fi
  if ! cmake --build "$build" -j "${POLYPORT_JOBS:-2}" --target "$target"; then
    echo "$target did not build; it needs $needs" >&2
    exit 1
  fi
}

bench_revision() {
  local revision
  revision="$(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
  if [ "$revision" != unknown ] && [ -n "$(GIT_OPTIONAL_LOCKS=0 git status --porcelain --untracked-files=no 2>/dev/null)" ]; then
    revision="${revision}+dirty"
  fi
  export POLYPORT_GIT_REVISION="$revision"
}

bench_run() {
  "$@" &
  bench_pid=$!
  bench_stop() {
    kill -TERM "$bench_pid" 2>/dev/null || true
    wait "$bench_pid" 2>/dev/null || true
  }
  trap 'bench_stop; exit 130' INT TERM HUP
  trap bench_stop EXIT
  bench_rc=0
  wait "$bench_pid" || bench_rc=$?
  trap - EXIT INT TERM HUP
}
