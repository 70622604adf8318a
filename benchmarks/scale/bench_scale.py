#!/usr/bin/python3
"""The scale benchmark (benchmarks/scale/README.md): polyportd on N in-process source -> sink
pairs (scripts/gen_scale_profile.py) for each N, measuring

  start-up     spawn until the daemon logs that every component runs
  RSS          the daemon's resident set after the warm-up
  cost         the daemon's CPU time (utime + stime) per delivered sample, over W windows
  latency      each connection's in-to-out p50 / p99 (the stats' latency_ns), median over them
  drops        samples the connections dropped (a full buffer)

Usage: bench_scale.py --polyportd P --polyportctl C --out-dir DIR [--n 10,100,1000]
       [--period-ms 10] [--windows 5] [--window-s 2] [--warmup-s 2]
Writes DIR/scale-<stamp>.json and .md, and prints the table.
"""
import argparse
import datetime
import json
import os
import platform
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.realpath(os.path.join(HERE, "..", ".."))
TICKS = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS  # utime, stime (fields 14, 15)


def rss_kib(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def stats(ctl, socket):
    out = subprocess.run([ctl, "--socket", socket, "--json", "--timeout", "30", "stats"], check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out)


def delivered(s):
    return sum(c.get("delivered", 0) for c in s["connections"] if not c.get("removed"))


def measure(args, n, work):
    folder = os.path.join(work, f"n{n}")
    subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "gen_scale_profile.py"), str(n), folder,
                    "--period-ms", str(args.period_ms)], check=True, capture_output=True)
    socket = os.path.join(folder, "admin.sock")
    log = open(os.path.join(folder, "polyportd.log"), "w+")
    t0 = time.monotonic()
    daemon = subprocess.Popen([args.polyportd, "run", os.path.join(folder, "app.xml"), "--admin-socket", socket,
                               "--stats-interval", "0"], stderr=log, stdout=log)
    try:
        startup = None
        while startup is None:
            if daemon.poll() is not None:
                log.seek(0)
                sys.exit(f"polyportd ended at N={n}:\n{log.read()}")
            log.seek(0)
            if " running " in log.read():
                startup = time.monotonic() - t0
            else:
                time.sleep(0.002)
            if time.monotonic() - t0 > 120:
                sys.exit(f"polyportd did not start in 120 s at N={n}")
        time.sleep(args.warmup_s)
        costs, rates = [], []
        before_cpu, before = cpu_seconds(daemon.pid), delivered(stats(args.polyportctl, socket))
        for _ in range(args.windows):
            time.sleep(args.window_s)
            cpu, count = cpu_seconds(daemon.pid), delivered(stats(args.polyportctl, socket))
            if count > before:
                costs.append((cpu - before_cpu) * 1e9 / (count - before))
                rates.append((count - before) / args.window_s)
            before_cpu, before = cpu, count
        rss = rss_kib(daemon.pid)
        final = stats(args.polyportctl, socket)
    finally:
        daemon.send_signal(signal.SIGINT)
        try:
            daemon.wait(60)
        except subprocess.TimeoutExpired:
            daemon.kill()
        log.close()
    connections = [c for c in final["connections"] if not c.get("removed")]
    p50s = [c["latency_ns"]["p50"] for c in connections if c["latency_ns"]["count"]]
    p99s = [c["latency_ns"]["p99"] for c in connections if c["latency_ns"]["count"]]
    contexts = final.get("execution_contexts", [])
    return {
        "n": n,
        "components": 2 * n,
        "connections": len(connections),
        "startup_s": startup,
        "rss_kib": rss,
        "samples_per_s": statistics.median(rates) if rates else 0,
        "cpu_ns_per_sample": {"median": statistics.median(costs) if costs else None, "windows": costs},
        "latency_ns_p50_median": statistics.median(p50s) if p50s else None,
        "latency_ns_p99_median": statistics.median(p99s) if p99s else None,
        "latency_ns_p99_max": max(p99s) if p99s else None,
        "dropped": sum(c.get("dropped", 0) for c in connections),
        "overruns": sum(e.get("overruns", 0) for e in contexts),
    }


def markdown(result):
    rows = ["| N connections | components | start-up (s) | RSS (MiB) | samples/s | CPU ns / sample (median) | "
            "in-to-out p50 (ns, median) | p99 (ns, median / max) | dropped | overruns |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for r in result["runs"]:
        cost = r["cpu_ns_per_sample"]["median"]
        rows.append(f"| {r['n']} | {r['components']} | {r['startup_s']:.3f} | {r['rss_kib'] / 1024:.1f} | "
                    f"{r['samples_per_s']:.0f} | {cost:.0f} | {r['latency_ns_p50_median']} | "
                    f"{r['latency_ns_p99_median']} / {r['latency_ns_p99_max']} | {r['dropped']} | {r['overruns']} |")
    return "\n".join(rows) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--polyportd", required=True)
    parser.add_argument("--polyportctl", required=True)
    parser.add_argument("--out-dir", required=True)
    parser.add_argument("--n", default="10,100,1000")
    parser.add_argument("--period-ms", type=float, default=10.0)
    parser.add_argument("--windows", type=int, default=5)
    parser.add_argument("--window-s", type=float, default=2.0)
    parser.add_argument("--warmup-s", type=float, default=2.0)
    args = parser.parse_args()
    sizes = [int(x) for x in args.n.split(",")]
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    result = {"benchmark": "scale", "date": stamp, "host": platform.node(), "cpus": os.cpu_count(),
              "revision": os.environ.get("POLYPORT_GIT_REVISION", "unknown"), "period_ms": args.period_ms,
              "windows": args.windows, "window_s": args.window_s, "runs": []}
    work = tempfile.mkdtemp(prefix="polyport-scale-")
    try:
        for n in sizes:
            print(f"scale: N = {n} ...", flush=True)
            run = measure(args, n, work)
            result["runs"].append(run)
            print(f"scale: N = {n}: start-up {run['startup_s']:.3f} s, "
                  f"{run['cpu_ns_per_sample']['median']:.0f} CPU ns per sample", flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    base = result["runs"][0]["cpu_ns_per_sample"]["median"]
    for r in result["runs"]:
        r["cost_vs_smallest"] = r["cpu_ns_per_sample"]["median"] / base if base else None
    os.makedirs(args.out_dir, exist_ok=True)
    path = os.path.join(args.out_dir, f"scale-{stamp}")
    with open(path + ".json", "w") as f:
        json.dump(result, f, indent=2)
    table = markdown(result)
    with open(path + ".md", "w") as f:
        f.write(f"Scale benchmark {stamp}, {result['host']}, {result['cpus']} CPUs, revision {result['revision']}, "
                f"period {args.period_ms:g} ms, {args.windows} windows of {args.window_s:g} s\n\n" + table)
    print(table)
    print(f"written {path}.json and {path}.md")


if __name__ == "__main__":
    main()
