#!/usr/bin/python3
"""What the middle of an LCM ping-pong path costs per round trip, counted rather than timed.

The LCM benchmark (run_pingpong.cpp) times polyportd's CPU per round trip against the native
relay's; on a 2-vCPU VM both are ~80 us a round trip, nearly all in the kernel, and runs
differ by more than what polyport does. This counts instead, for the same two middles on the
same generated profiles: the system calls each makes per round trip (strace -f -c) and the
user-space instructions it executes per round trip (valgrind --tool=callgrind), by library.
Both are taken as the difference of a short and a long run, (long - short) / (extra round
trips), so start-up and shutdown cancel out. Instruction counts repeat run to run for the
same binary and inputs, whatever else the machine does: an A/B of the forwarding path's code
can be read from them where the timed CPU bar cannot decide.

  counts.py OUT_PREFIX --bin BUILD/bin --profiles DIR [--sizes 16,1024] [--rounds 1000,3000]
    --profiles  a directory bench_lcm_pingpong --keep wrote (one-core-16/app.xml, ...)
    writes OUT_PREFIX.json (every count) and OUT_PREFIX.md (the table)

Run as root inside a network namespace with loopback's multicast route (scripts/bench_lcm_counts.sh
does both). Every process runs on CPU 0 (the one-core placement). Exit 0, or 1 when a run fails."""
import argparse
import json
import os
import re
import signal
import subprocess
import sys
import time

# Ports of the generated profiles (run_pingpong.cpp: via 1, 2; relay 3, 4 above the size's base).
PORTS = {"via": (1, 2), "relay": (3, 4)}
BASES = {16: 7700, 1024: 7705}


def run_path(args, middle, size, rounds, wrapper, out):
    """One ping-pong of `rounds` through `middle`, the middle under `wrapper`; returns once it ended."""
    base = BASES[size]
    port_a, port_b = base + PORTS[middle][0], base + PORTS[middle][1]
    pin = ["taskset", "-c", "0"]
    prog = os.path.join(args.bin, "pingpong_lcm")
    profile_dir = os.path.join(args.profiles, f"one-core-{size}")
    logs = open(out + ".log", "w")
    pong = subprocess.Popen(pin + [prog, "pong", str(port_b), str(size)], stdout=logs, stderr=logs)
    if middle == "via":
        target = [os.path.join(args.bin, "polyportd"), "run", os.path.join(profile_dir, "app.xml")]
    else:
        target = [prog, "relay", str(port_a), str(port_b), str(size)]
    mid = subprocess.Popen(pin + wrapper + target, stdout=logs, stderr=logs, cwd=profile_dir)
    try:
        # The ping probes until the path answers (pingpong_lcm.cpp), so it needs no head start.
        ping = subprocess.run(pin + [prog, "ping", str(port_a), str(size), str(rounds), "10"],
                              capture_output=True, text=True, timeout=900)
        if ping.returncode != 0:
            raise RuntimeError(f"ping {middle} {size} B {rounds}: status {ping.returncode}: {ping.stderr.strip()}")
    finally:
        stop_middle(mid)
        pong.send_signal(signal.SIGTERM)
        pong.wait()
        logs.close()


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
# its libpolyport_* libraries, the relay's is pingpong_lcm with its lcm-gen types.
LIBRARIES = (("polyportd", "polyport"), ("libpolyport", "polyport"), ("pingpong_lcm", "program"),
             ("liblcm", "liblcm"), ("libglib", "glib"), ("libc.so", "libc"), ("ld-linux", "ld.so"),
             ("libstdc++", "libstdc++"), ("libspdlog", "spdlog"), ("libfmt", "fmt"))


def owner_of(function):
    """A line without an object file: code inlined into a function of the program's own."""
    if "polyport::" in function:
        return "polyport"
    return "program" if "bench_lcm" in function or "pingpong" in function else "other"


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


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("out")
    p.add_argument("--bin", required=True)
    p.add_argument("--profiles", required=True)
    p.add_argument("--sizes", default="16,1024")
    p.add_argument("--rounds", default="1000,3000")
    args = p.parse_args()
    args.bin, args.profiles = os.path.abspath(args.bin), os.path.abspath(args.profiles)  # the middle runs in its profile's folder
    short, long_ = (int(r) for r in args.rounds.split(","))
    extra = long_ - short
    result = {"benchmark": "lcm_counts", "revision": os.environ.get("POLYPORT_GIT_REVISION", "unknown"),
              "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "host": os.uname().nodename,
              "rounds": [short, long_], "placement": "one-core", "cases": []}
    for size in (int(s) for s in args.sizes.split(",")):
        for middle in ("via", "relay"):
            print(f"{middle} {size} B ...", file=sys.stderr, flush=True)
            counted = {}
            for rounds in (short, long_):
                tag = f"{args.out}.{middle}-{size}-{rounds}"
                run_path(args, middle, size, rounds, ["strace", "-f", "-c", "-o", tag + ".strace"], tag)
                run_path(args, middle, size, rounds,
                         ["valgrind", "--tool=callgrind", "--callgrind-out-file=" + tag + ".callgrind"], tag)
                counted[rounds] = (syscalls(tag + ".strace"), instructions(tag + ".callgrind"))
            calls = per_round_trip(counted[short][0], counted[long_][0], extra)
            instr = per_round_trip(counted[short][1], counted[long_][1], extra)
            result["cases"].append({"middle": "polyportd" if middle == "via" else "relay", "size_bytes": size,
                                    "syscalls_per_round_trip": calls,
                                    "syscalls_per_round_trip_total": round(sum(calls.values()), 2),
                                    "instructions_per_round_trip": instr,
                                    "instructions_per_round_trip_total": round(sum(instr.values()))})
    with open(args.out + ".json", "w") as f:
        json.dump(result, f, indent=1)
    with open(args.out + ".md", "w") as f:
        f.write(table(result))
    print(table(result))
    return 0


def table(result):
    lines = [f"LCM middles counted per round trip ({result['date']}, {result['revision']}, one core, "
             f"{result['rounds'][1] - result['rounds'][0]} round trips of difference)", "",
             "| middle | size | system calls | user instructions | of which polyport / program | liblcm | glib | libc |",
             "|---|---|---|---|---|---|---|---|"]
    for c in result["cases"]:
        i = c["instructions_per_round_trip"]
        own = i.get("polyport", 0) + i.get("program", 0)
        calls = ", ".join(f"{k} {v:g}" for k, v in sorted(c["syscalls_per_round_trip"].items(), key=lambda kv: -kv[1])
                          if v >= 0.5)
        lines.append(f"| {c['middle']} | {c['size_bytes']} B | {c['syscalls_per_round_trip_total']:g} ({calls}) | "
                     f"{c['instructions_per_round_trip_total']} | {own:.0f} | {i.get('liblcm', 0):.0f} | "
                     f"{i.get('glib', 0):.0f} | {i.get('libc', 0):.0f} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    try:
        sys.exit(main())
    except (RuntimeError, subprocess.SubprocessError) as e:
        print(f"counts.py: {e}", file=sys.stderr)
        sys.exit(1)
