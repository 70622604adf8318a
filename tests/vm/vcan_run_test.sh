#!/usr/bin/env bash
# scripts/vcan-run, run from the host as a test calls it. One case per ctest:
#   vcan_run_test.sh CASE     runs case_CASE (VCAN_RUN: the runner; VCAN_RUN_TEST_BUILD_DIR:
#                             a writable build tree)
#   vcan_run_test.sh --list   prints the case names (tests/vm/CMakeLists.txt reads them)
set -uo pipefail

runner=${VCAN_RUN:-$(cd "$(dirname "$0")/../.." && pwd)/scripts/vcan-run}
build_dir=${VCAN_RUN_TEST_BUILD_DIR:-$(cd "$(dirname "$0")/../.." && pwd)/build}
if [ "${1:-}" = --list ]; then
  sed -n 's/^case_\([a-z0-9_]*\)() {$/\1/p' "$0"
  exit 0
fi
scratch=$(mktemp -d "$build_dir/vcan-run-test.XXXXXX")
trap 'rm -rf -- "$scratch"' EXIT
failures=0

# check DESCRIPTION COMMAND...: a failure (and the test's) unless COMMAND succeeds.
check() {
  local what=$1
  shift
  if "$@"; then echo "ok: $what"; else echo "FAILED: $what"; failures=$((failures + 1)); fi
}

# run_runner ARGS...: runs the runner; its status in $status, its stdout and stderr in
# $scratch/out and $scratch/err (and the latter shown).
run_runner() {
  "$runner" "$@" > "$scratch/out" 2> "$scratch/err"
  status=$?
  echo "vcan-run $* -> status $status"
  sed 's/^/  stderr: /' "$scratch/err"
}

case_passes_status_output_and_environment() {
  local value=$'two\nlines "and" $quotes\''
  cd "$scratch" || return 1
  # Each check prints one word that the host then looks for.
  TEST_VALUE=$value run_runner --interfaces 2 --if can7 -- bash -c '
    echo "to stdout"; echo "to stderr" >&2
    [ "$TEST_VALUE" = "$(printf "two\nlines \"and\" \$quotes\x27")" ] && echo environment
    [ "$PWD" = "'"$scratch"'" ] && echo directory
    echo written > "'"$scratch"'/from-guest" && echo writable
    # Only the guest mounts the host read-only (elsewhere this would write to /usr).
    [ "$VCAN_RUN_IN" != uml ] || touch /usr/vcan-run-must-not-write 2>/dev/null || echo read-only
    for i in vcan0 vcan1 can7; do ip link show "$i" | grep -q "UP.* mtu 16 " && echo "$i-up"; done
    echo "in=$VCAN_RUN_IN interfaces=$VCAN_RUN_INTERFACES"
    exit 7'
  check "the command's exit status (7)" [ "$status" -eq 7 ]
  check "stdout is the command's" grep -qx "to stdout" "$scratch/out"
  check "stderr is the command's" grep -qx "to stderr" "$scratch/err"
  check "stdout has no stderr line" bash -c '! grep -q "to stderr" "$1"' _ "$scratch/out"
  local word
  for word in environment directory writable vcan0-up vcan1-up can7-up; do
    check "$word" grep -qx "$word" "$scratch/out"
  done
  if grep -qx "in=uml.*" "$scratch/out"; then
    check "the host is read-only in the guest" grep -qx read-only "$scratch/out"
  fi
  check "the file written in the guest is on the host" grep -qx written "$scratch/from-guest"
  check "VCAN_RUN_INTERFACES" grep -q " interfaces=vcan0 vcan1 can7$" "$scratch/out"
}

case_fd_and_named_interfaces() {
  run_runner --fd --if can0 --if can1 -- bash -c 'for i in can0 can1; do ip link show "$i" | grep -q "UP.* mtu 72 " && echo "$i-fd"; done; ip link show vcan0 >/dev/null 2>&1 || echo no-vcan0'
  check "exit status 0" [ "$status" -eq 0 ]
  check "can0 has the FD MTU" grep -qx can0-fd "$scratch/out"
  check "can1 has the FD MTU" grep -qx can1-fd "$scratch/out"
  check "only the named interfaces" grep -qx no-vcan0 "$scratch/out"
}

case_missing_command_gives_127_and_leaves_nothing_behind() {
  run_runner -- /nonexistent/command
  check "status 127" [ "$status" -eq 127 ]
  # bash names the script that tried to run it, in the runner's private directory (the
  # host backend has none: nothing to look for then).
  local run_dir
  run_dir=$(grep -o '/tmp/vcan-run\.[A-Za-z0-9]*' "$scratch/err" | head -n 1)
  if [ -n "$run_dir" ]; then
    check "$run_dir is removed" [ ! -e "$run_dir" ]
  fi
}

case_timeout_gives_124() {
  local start=$SECONDS
  run_runner --timeout 2 -- sleep 60
  check "status 124" [ "$status" -eq 124 ]
  check "stopped well before the command would have ended" [ $((SECONDS - start)) -lt 30 ]
}

case_says_why_it_cannot_run() {
  # A kernel that claims the right version, then fails to boot.
  local fake="$scratch/linux.uml"
  printf '#!/bin/sh\n[ "$1" = --version ] && { %s --version; exit 0; }\necho "fake kernel: no boot"; exit 1\n' \
    "$(command -v linux.uml || echo /usr/bin/linux.uml)" > "$fake"
  chmod +x "$fake"
  VCAN_RUN_UML=$fake run_runner --backend uml -- true
  check "status 3" [ "$status" -eq 3 ]
  check "one line says why" grep -q "^vcan-run: cannot run true: the vcan guest stopped before the command finished" "$scratch/err"
  check "the guest console is shown" grep -q "fake kernel: no boot" "$scratch/err"

  VCAN_RUN_UML=/nonexistent/linux.uml run_runner --backend uml -- true
  check "status 3 without a kernel" [ "$status" -eq 3 ]
  check "it names the missing kernel" grep -q "^vcan-run: cannot run true: VCAN_RUN_UML=/nonexistent/linux.uml is not an executable file" "$scratch/err"

  run_runner --backend host --private -- true
  check "status 2 for a bad command line" [ "$status" -eq 2 ]
}

case_floating_point_state_survives_switches_in_the_guest() {
  # Sums of doubles in two processes at once, and in two threads of one process (threads of
  # one guest process share one host process: UML saves and restores their registers itself),
  # on the guest's one CPU, switched many times: each result is the host's to the last bit.
  # Where the host's XSAVE area is too large for the kernel (scripts/uml-xstate-shim.c) the
  # guest keeps x87 and SSE state only and glibc is told to use no AVX, its hwcaps joined to
  # the caller's.
  local sum='def total():
    s = 0.0
    for i in range(1, 1500000): s += 1.0 / i + 1e-9 * (i % 7)
    return s
import sys, threading
if sys.argv[1] == "threads":
    out = [None, None]
    def run(k): out[k] = total()
    ts = [threading.Thread(target=run, args=(k,)) for k in (0, 1)]
    [t.start() for t in ts]; [t.join() for t in ts]
    print(repr(out[0])); print(repr(out[1]))
else:
    print(repr(total()))'
  local expected
  expected=$(/usr/bin/python3 -c "$sum" one)
  GLIBC_TUNABLES=glibc.malloc.perturb=0:glibc.cpu.hwcaps=-ERMS run_runner -- bash -c '
    /usr/bin/python3 -c "$1" one > "$2/a" & /usr/bin/python3 -c "$1" one > "$2/b" &
    /usr/bin/python3 -c "$1" threads > "$2/c"; wait
    cat "$2/a" "$2/b" "$2/c"; echo "in=$VCAN_RUN_IN"; echo "tunables=$GLIBC_TUNABLES"' _ "$sum" "$scratch"
  check "exit status 0" [ "$status" -eq 0 ]
  check "all four sums are the host's ($expected)" [ "$(grep -cx -- "$expected" "$scratch/out")" -eq 4 ]
  local shim=$scratch/shim
  if grep -qx "in=uml" "$scratch/out" && cc -O2 -o "$shim" "$(dirname "$runner")/uml-xstate-shim.c" &&
     "$shim" --needed; then
    check "the caller's tunables with the guest's hwcaps joined to the caller's" grep -qx \
      "tunables=glibc.malloc.perturb=0:glibc.cpu.hwcaps=-ERMS,-AVX,-AVX2,-AVX512F,-AVX512VL,-AVX512BW,-AVX512DQ,-AVX512CD,-AVX_Fast_Unaligned_Load" \
      "$scratch/out"
  else
    check "the caller's tunables as they are" grep -qx "tunables=glibc.malloc.perturb=0:glibc.cpu.hwcaps=-ERMS" "$scratch/out"
  fi
}

# "pid<TAB>command line" of every process below $1 (its children, theirs, ...).
descendants() {
  local -A children=()
  local proc stat ppid
  for proc in /proc/[0-9]*; do
    { read -r stat < "$proc/stat"; } 2>/dev/null || continue
    read -r _ ppid _ <<< "${stat##*) }"  # after the command name, which may hold spaces
    children[$ppid]+=" ${proc#/proc/}"
  done
  local queue=("$1") pid child args
  while [ ${#queue[@]} -gt 0 ]; do
    pid=${queue[0]}
    queue=("${queue[@]:1}")
    for child in ${children[$pid]:-}; do
      mapfile -d '' -t args 2>/dev/null < "/proc/$child/cmdline" || continue
      printf '%s\t%s\n' "$child" "${args[*]}"
      queue+=("$child")
    done
  done
}

# The pids of the list ($1, as descendants writes it) still running with the same command line.
survivors() {
  local pid line args
  while IFS=$'\t' read -r pid line; do
    mapfile -d '' -t args 2>/dev/null < "/proc/$pid/cmdline" || continue
    [ "${args[*]}" != "$line" ] || echo "$pid"
  done < "$1"
}

# In the user-mode Linux guest (the runner's choice where the host kernel has no vcan) this
# covers the guest's own processes, which leave the runner's process group.
case_a_signal_stops_everything_it_started() {
  cd "$scratch" || return 1
  "$runner" --timeout 120 -- bash -c 'echo "$VCAN_RUN_IN" > "$1/started"; exec sleep 100' _ "$scratch" \
    > "$scratch/out" 2> "$scratch/err" &
  local runner_pid=$! i
  for ((i = 0; i < 600; i++)); do [ -s "$scratch/started" ] && break; sleep 0.1; done
  check "the command started within a minute" [ -s "$scratch/started" ]
  descendants "$runner_pid" > "$scratch/started-processes"
  echo "backend: $(cat "$scratch/started" 2>/dev/null); processes below the runner: $(wc -l < "$scratch/started-processes")"
  check "it started processes" [ -s "$scratch/started-processes" ]
  kill -TERM "$runner_pid"
  wait "$runner_pid"
  status=$?
  check "status 143 after SIGTERM" [ "$status" -eq 143 ]
  # SIGKILL takes effect when the process next runs: give them five seconds.
  for ((i = 0; i < 50; i++)); do [ -n "$(survivors "$scratch/started-processes")" ] || break; sleep 0.1; done
  local left
  left=$(survivors "$scratch/started-processes")
  check "none of them runs any more (the guest's own processes included)" [ -z "$left" ]
  # Whatever survived a failure goes now, not at the guest's own timeout.
  [ -z "$left" ] || kill -KILL $left 2>/dev/null
}

case_netns_backend_on_a_kernel_with_vcan() {
  # Inside the guest the kernel has vcan and the command is root: what a host with vcan
  # gets. The inner interfaces are private: the outer vcan0 is not among them.
  run_runner -- "$runner" --fd --if can5 -- sh -c 'echo "in=$VCAN_RUN_IN"; ip link show can5 | grep -q "UP.* mtu 72 " && echo can5-fd; ip link show vcan0 >/dev/null 2>&1 || echo private; exit 9'
  check "the inner command's status (9)" [ "$status" -eq 9 ]
  check "network-namespace backend" grep -qx "in=netns" "$scratch/out"
  check "can5 with the FD MTU" grep -qx can5-fd "$scratch/out"
  check "private interfaces" grep -qx private "$scratch/out"
}

[ $# -eq 1 ] && declare -F "case_$1" >/dev/null || { echo "usage: $0 --list | CASE" >&2; exit 2; }
"case_$1"
[ "$failures" -eq 0 ] || { echo "$failures check(s) failed"; exit 1; }
