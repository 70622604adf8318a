#!/usr/bin/python3
"""What the middle of a ping-pong path costs per round trip, counted rather than timed.

The LCM and matrix benchmarks time polyportd's CPU per round trip against the native relay's;
on a 2-vCPU VM a round trip is tens of us of CPU, nearly all in the kernel, and runs differ
by more than what polyport does. This counts instead, for the same two middles between the
same ping and pong programs: the system calls each middle makes per round trip (strace -f -c)
and the user-space instructions it executes per round trip (valgrind --tool=callgrind), by
library. Both are the difference of a short and a long run, (long - short) / (extra round
trips), so start-up and shutdown cancel out. Instruction counts repeat run to run for the same
binary and inputs, whatever else the machine does: they can decide an A/B of the forwarding
path's code where the timed CPU bar cannot. (A middle's periodic work, DDS heartbeats and
announcements, polyportd's status line, is counted by the time it runs, and valgrind makes
that time longer: a DDS middle's figures carry a little of it.)

  counts.py lcm OUT_PREFIX --bin BUILD/bin --profiles DIR --result LCM.json [--rounds 1000,3000]
    --profiles  a directory bench_lcm_pingpong --keep wrote, LCM.json its result: every one-core
                case of it (one-core-<size>/app.xml), with its ports
  counts.py matrix OUT_PREFIX --bin BUILD/bin --profiles DIR --result MATRIX.json [--rounds 1000,3000]
    --profiles  a directory bench_matrix --keep wrote, MATRIX.json its result: every cross case
                of it (one-core-<from>-<to>-<size>/app.xml), with its domains and relay
  Both write OUT_PREFIX.json (every count) and OUT_PREFIX.md (the table).

Run as root inside a network namespace with loopback's multicast route (scripts/bench_counts.sh
does both). Every process runs on CPU 0 (the one-core placement); the DDS programs get the
loopback configurations polyport's DDS models default to. Exit 0, or 1 when a run fails."""
import argparse
import json
import os
import re
import signal
import subprocess
import sys
import time

PROGRAMS = {"cyclonedds": "pingpong_cyclone", "fastdds": "pingpong_fastdds", "lcm": "pingpong_lcm"}
SOURCE_DIR = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DDS_ENV = {"CYCLONEDDS_URI": "file://" + os.path.join(SOURCE_DIR, "config/cyclonedds-loopback.xml"),
           "FASTRTPS_DEFAULT_PROFILES_FILE": os.path.join(SOURCE_DIR, "config/fastdds-loopback.xml")}


def lcm_cases(args):
    """The LCM result's one-core cases, from their recorded ports (run_pingpong.cpp: polyportd
    between via_ping and via_pong, the relay between relay_ping and relay_pong)."""
    prog = os.path.join(args.bin, "pingpong_lcm")
    with open(args.result) as f:
        result = json.load(f)
    for c in result["cases"]:
        if c.get("placement") != "one-core" or "ports" not in c:
            continue
        size, p = c["size_bytes"], c["ports"]
        folder = os.path.join(args.profiles, f"one-core-{size}")
        yield {"label": "lcm", "size_bytes": size, "cwd": folder, "middles": {
            "polyportd": ([prog, "ping", str(p["via_ping"]), str(size)], [prog, "pong", str(p["via_pong"]), str(size)],
                          [os.path.join(args.bin, "polyportd"), "run", os.path.join(folder, "app.xml")]),
            "relay": ([prog, "ping", str(p["relay_ping"]), str(size)], [prog, "pong", str(p["relay_pong"]), str(size)],
                      [prog, "relay", str(p["relay_ping"]), str(p["relay_pong"]), str(size)])}}


def matrix_cases(args):
    """The matrix result's one-core cross cases, from its recorded domains (run_matrix.cpp
    cross_commands: polyportd on via_ping / via_pong, the relay on relay_ping / relay_pong)."""
    with open(args.result) as f:
        result = json.load(f)
    for c in result["cases"]:
        if c.get("placement") != "one-core" or c["from"] == c["to"] or c["from"] not in PROGRAMS \
                or c["to"] not in PROGRAMS or "relay_program" not in c:
            continue
        size, d = c["size_bytes"], c["domains"]
        ping, pong = os.path.join(args.bin, PROGRAMS[c["from"]]), os.path.join(args.bin, PROGRAMS[c["to"]])
        folder = os.path.join(args.profiles, f"one-core-{c['from']}-{c['to']}-{size}")
        yield {"label": f"{c['from']} -> {c['to']}", "size_bytes": size, "cwd": folder, "middles": {
            "polyportd": ([ping, "ping", str(d["via_ping"]), str(size)], [pong, "pong", str(d["via_pong"]), str(size)],
                          [os.path.join(args.bin, "polyportd"), "run", os.path.join(folder, "app.xml")]),
            "relay": ([ping, "ping", str(d["relay_ping"]), str(size)], [pong, "pong", str(d["relay_pong"]), str(size)],
                      [os.path.join(args.bin, c["relay_program"]), c["from"], str(d["relay_ping"]),
                       str(d["relay_pong"]), str(size)])}}


def run_path(cwd, ping, pong, middle, rounds, wrapper, out):
    """One ping-pong of `rounds` through `middle` (under `wrapper`); returns once all ended."""
    pin = ["taskset", "-c", "0"]
    env = dict(os.environ, **DDS_ENV)
    with open(out + ".log", "w") as logs:
        pong_process = subprocess.Popen(pin + pong, stdout=logs, stderr=logs, env=env)
        mid = subprocess.Popen(pin + wrapper + middle, stdout=logs, stderr=logs, cwd=cwd, env=env)
        try:
            # The ping programs wait for their path (LCM: probes until answered; DDS: until
            # matched), so they need no head start.
            pinged = subprocess.run(pin + ping + [str(rounds), "10"], capture_output=True, text=True, timeout=900,
                                    env=env)
            if pinged.returncode != 0:
                raise RuntimeError(f"{' '.join(ping)} {rounds}: status {pinged.returncode}: {pinged.stderr.strip()}")
        finally:
            stop_middle(mid)
            pong_process.send_signal(signal.SIGTERM)
            pong_process.wait()


def stop_middle(mid):
    """SIGINT to the middle itself (under strace: the tracee, strace's child), then wait."""
    children = subprocess.run(["pgrep", "-P", str(mid.pid)], capture_output=True, text=True).stdout.split()
    for pid in [int(c) for c in children] or [mid.pid]:
        try:
            os.kill(pid, signal.SIGINT)
        except ProcessLookupError:
            pass
    try:
        mid.wait(timeout=120)
    except subprocess.TimeoutExpired:
        mid.kill()
        mid.wait()


def syscalls(path):
    """strace -c's table: {name: calls}."""
    counts = {}
    with open(path) as f:
        lines = f.read().splitlines()
    for line in lines:
        m = re.match(r"\s*[\d.]+\s+[\d.]+\s+\d+\s+(\d+)\s+(?:\d+\s+)?(\w+)\s*$", line)
        if m and m.group(2) != "total":
            counts[m.group(2)] = int(m.group(1))
    return counts


def instructions(path):
    """callgrind's instructions by library: {library: Ir}, summed from callgrind_annotate's
    per-function table (self cost, every function)."""
    out = subprocess.run(["callgrind_annotate", "--inclusive=no", "--threshold=100", "--auto=no", path],
                         capture_output=True, text=True, check=True).stdout
    by_library = {}
    for line in out.splitlines():
        m = re.match(r"\s*([\d,]+)\s+\([^)]*\)\s+(.*?)(?:\s+\[([^\]]*)\])?\s*$", line)
        if not m or "PROGRAM TOTALS" in line:
            continue
        library = library_of(m.group(3)) if m.group(3) else owner_of(m.group(2))
        by_library[library] = by_library.get(library, 0) + int(m.group(1).replace(",", ""))
    return by_library


# Object file name prefixes and what the table calls them; polyport's own code is polyportd and
# its libpolyport_* libraries, a relay's is its program (relay_*, pingpong_lcm) with its
# generated types.
LIBRARIES = (("polyportd", "polyport"), ("libpolyport", "polyport"), ("pingpong_", "program"), ("relay_", "program"),
             ("liblcm", "liblcm"), ("libglib", "glib"), ("libfastrtps", "fastdds"), ("libfastcdr", "fastcdr"),
             ("libddsc", "cyclonedds"), ("libc.so", "libc"), ("ld-linux", "ld.so"), ("libstdc++", "libstdc++"),
             ("libspdlog", "spdlog"), ("libfmt", "fmt"))
# The SDKs' own libraries, one column of the table.
SDKS = ("liblcm", "glib", "fastdds", "fastcdr", "cyclonedds")


def owner_of(function):
    """A line without an object file: code inlined into a function of the program's own."""
    if "polyport::" in function:
        return "polyport"
    own = ("bench_lcm", "pingpong", "bench::", "relay")
    return "program" if any(o in function for o in own) else "other"


def library_of(obj):
    base = os.path.basename(obj)
    for prefix, name in LIBRARIES:
        if base.startswith(prefix):
            return name
    return "other"


def per_round_trip(short, long_, extra):
    keys = set(short) | set(long_)
    return {k: round((long_.get(k, 0) - short.get(k, 0)) / extra, 2) for k in sorted(keys)
            if abs(long_.get(k, 0) - short.get(k, 0)) / extra >= 0.01}


def count(case, short, long_, out):
    """Both middles of `case`, each counted per round trip."""
    rows = []
    for middle, (ping, pong, command) in case["middles"].items():
        print(f"{case['label']} {case['size_bytes']} B, {middle} ...", file=sys.stderr, flush=True)
        counted = {}
        for rounds in (short, long_):
            tag = f"{out}.{case['label'].replace(' -> ', '-')}-{case['size_bytes']}-{middle}-{rounds}"
            run_path(case["cwd"], ping, pong, command, rounds, ["strace", "-f", "-c", "-o", tag + ".strace"], tag)
            run_path(case["cwd"], ping, pong, command, rounds,
                     ["valgrind", "--tool=callgrind", "--callgrind-out-file=" + tag + ".callgrind"], tag)
            counted[rounds] = (syscalls(tag + ".strace"), instructions(tag + ".callgrind"))
        calls = per_round_trip(counted[short][0], counted[long_][0], long_ - short)
        instr = per_round_trip(counted[short][1], counted[long_][1], long_ - short)
        rows.append({"case": case["label"], "middle": middle, "size_bytes": case["size_bytes"],
                     "middle_command": [os.path.basename(command[0])] + command[1:2],
                     "syscalls_per_round_trip": calls,
                     "syscalls_per_round_trip_total": round(sum(calls.values()), 2),
                     "instructions_per_round_trip": instr,
                     "instructions_per_round_trip_total": round(sum(instr.values()))})
    return rows


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("benchmark", choices=("lcm", "matrix"))
    p.add_argument("out")
    p.add_argument("--bin", required=True)
    p.add_argument("--profiles", required=True)
    p.add_argument("--result", required=True, help="the result the runner wrote beside --profiles")
    p.add_argument("--rounds", default="1000,3000")
    args = p.parse_args()
    args.bin, args.profiles = os.path.abspath(args.bin), os.path.abspath(args.profiles)  # the middles run in the profiles' folders
    short, long_ = (int(r) for r in args.rounds.split(","))
    result = {"benchmark": f"{args.benchmark}_counts", "revision": os.environ.get("POLYPORT_GIT_REVISION", "unknown"),
              "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "host": os.uname().nodename,
              "rounds": [short, long_], "placement": "one-core", "cases": []}
    for case in (lcm_cases(args) if args.benchmark == "lcm" else matrix_cases(args)):
        result["cases"] += count(case, short, long_, args.out)
    with open(args.out + ".json", "w") as f:
        json.dump(result, f, indent=1)
    with open(args.out + ".md", "w") as f:
        f.write(table(result))
    print(table(result))
    return 0


def table(result):
    lines = [f"Middles counted per round trip ({result['benchmark']}, {result['date']}, {result['revision']}, one core, "
             f"{result['rounds'][1] - result['rounds'][0]} round trips of difference)", "",
             "| case | middle | size | system calls | user instructions | its own code | SDKs | libc | libstdc++ |",
             "|---|---|---|---|---|---|---|---|---|"]
    for c in result["cases"]:
        i = c["instructions_per_round_trip"]
        own = i.get("polyport", 0) + i.get("program", 0)
        sdks = sum(i.get(k, 0) for k in SDKS)
        calls = ", ".join(f"{k} {v:g}" for k, v in sorted(c["syscalls_per_round_trip"].items(), key=lambda kv: -kv[1])
                          if v >= 0.5)
        lines.append(f"| {c['case']} | {c['middle']} | {c['size_bytes']} B | {c['syscalls_per_round_trip_total']:g} "
                     f"({calls}) | {c['instructions_per_round_trip_total']} | {own:.0f} | {sdks:.0f} | "
                     f"{i.get('libc', 0):.0f} | {i.get('libstdc++', 0):.0f} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    try:
        sys.exit(main())
    except (RuntimeError, subprocess.SubprocessError) as e:
        print(f"counts.py: {e}", file=sys.stderr)
        sys.exit(1)
