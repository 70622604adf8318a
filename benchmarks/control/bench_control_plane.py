#!/usr/bin/python3
"""Does control-plane traffic disturb forwarding? (benchmarks/control/README.md)

One polyportd runs a busy connection: an in-process ScaleSource writing a 64-byte sample every
millisecond (1 kHz) to a ScaleSink through a buffer of depth 16 (scripts/gen_scale_profile.py,
the scale benchmark's plugin). The run is cut into windows that alternate on / off / on / ...:
during an "on" window `polyportctl stats --watch --interval 0.1` polls the daemon at 10 Hz,
during an "off" window nothing does. Each window gets a fresh connection (disconnected and
connected again through polyportctl before it starts), so its in-to-out histogram (the stats'
latency_ns) holds that window's samples only; the same single stats request reads it at the end
of every window, on or off.

Usage: bench_control_plane.py --polyportd P --polyportctl C --out-dir DIR [--windows 6]
       [--window-s 10] [--warmup-s 2] [--interval 0.1]
Writes DIR/control_plane-<stamp>.json and prints the summary.
"""
import argparse
import datetime
import json
import os
import platform
import signal
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.realpath(os.path.join(HERE, "..", ".."))
SOURCE, TARGET = "src0.out", "sink0.in"


def ctl(args, socket, *rest):
    return subprocess.run([args.polyportctl, "--socket", socket, "--timeout", "30", *rest], check=True,
                          capture_output=True, text=True).stdout


def connection(args, socket):
    stats = json.loads(ctl(args, socket, "--json", "stats"))
    for c in stats["connections"]:
        if c["source"] == SOURCE and c["target"] == TARGET and not c.get("removed") and not c.get("probe"):
            return c
    sys.exit(f"no connection {SOURCE} -> {TARGET} in the stats")


def run(args, work):
    subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "gen_scale_profile.py"), "1", work,
                    "--period-ms", "1"], check=True, capture_output=True)
    socket = os.path.join(work, "admin.sock")
    log = open(os.path.join(work, "polyportd.log"), "w+")
    daemon = subprocess.Popen([args.polyportd, "run", os.path.join(work, "app.xml"), "--admin-socket", socket,
                               "--stats-interval", "0"], stderr=log, stdout=log)
    windows = []
    try:
        t0 = time.monotonic()
        while True:
            if daemon.poll() is not None:
                log.seek(0)
                sys.exit(f"polyportd ended:\n{log.read()}")
            log.seek(0)
            if " running " in log.read() and os.path.exists(socket):
                break
            if time.monotonic() - t0 > 60:
                sys.exit("polyportd did not start in 60 s")
            time.sleep(0.01)
        time.sleep(args.warmup_s)
        for i in range(args.windows):
            polling = i % 2 == 0
            # A fresh connection: its histogram holds this window's samples only.
            ctl(args, socket, "disconnect", SOURCE, TARGET)
            ctl(args, socket, "connect", SOURCE, TARGET, "--policy", "buffer", "--depth", "16")
            watcher = None
            if polling:
                watcher = subprocess.Popen([args.polyportctl, "--socket", socket, "stats", "--watch", "--interval",
                                            str(args.interval)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
            time.sleep(args.window_s)
            c = connection(args, socket)
            tables = None
            if watcher is not None:
                if watcher.poll() is not None:
                    sys.exit(f"polyportctl stats --watch ended: {watcher.stderr.read().decode()}")
                watcher.send_signal(signal.SIGTERM)
                watcher.wait(10)
            h = c["latency_ns"]
            windows.append({"window": i, "polling": polling, "delivered": c["delivered"], "dropped": c["dropped"],
                            "latency_ns": {k: h[k] for k in ("count", "p50", "p90", "p99", "p999", "max", "mean")}})
            print(f"window {i} ({'stats --watch at %g Hz' % (1 / args.interval) if polling else 'no polling'}): "
                  f"{h['count']} samples, p50 {h['p50']} ns, p99 {h['p99']} ns, max {h['max']} ns", flush=True)
    finally:
        daemon.send_signal(signal.SIGINT)
        try:
            daemon.wait(60)
        except subprocess.TimeoutExpired:
            daemon.kill()
        log.close()
    return windows


def summary(windows, polling):
    chosen = [w for w in windows if w["polling"] == polling]
    p50 = [w["latency_ns"]["p50"] for w in chosen]
    p99 = [w["latency_ns"]["p99"] for w in chosen]
    return {"windows": len(chosen), "samples": sum(w["latency_ns"]["count"] for w in chosen),
            "p50_median_ns": statistics.median(p50), "p99_median_ns": statistics.median(p99),
            "p99_max_ns": max(p99), "dropped": sum(w["dropped"] for w in chosen)}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--polyportd", required=True)
    parser.add_argument("--polyportctl", required=True)
    parser.add_argument("--out-dir", required=True)
    parser.add_argument("--windows", type=int, default=6)
    parser.add_argument("--window-s", type=float, default=10.0)
    parser.add_argument("--warmup-s", type=float, default=2.0)
    parser.add_argument("--interval", type=float, default=0.1, help="stats --watch interval (default 0.1: 10 Hz)")
    args = parser.parse_args()
    if args.windows < 2:
        sys.exit("bench_control_plane: at least 2 windows (one with polling, one without)")
    with tempfile.TemporaryDirectory(prefix="polyport-bench-control-") as work:
        windows = run(args, work)
    on, off = summary(windows, True), summary(windows, False)
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    result = {
        "benchmark": "control_plane",
        "date": stamp,
        "git_revision": os.environ.get("POLYPORT_GIT_REVISION", "unknown"),
        "host": {"name": platform.node(), "kernel": platform.release(), "cpus": os.cpu_count(),
                 "machine": platform.machine()},
        "settings": {"connection": f"{SOURCE} -> {TARGET}", "rate_hz": 1000, "sample_bytes": 64,
                     "policy": "buffer", "depth": 16, "windows": args.windows, "window_s": args.window_s,
                     "warmup_s": args.warmup_s, "watch_interval_s": args.interval,
                     "order": "polling, quiet, polling, ... (same daemon run)"},
        "windows": windows,
        "with_polling": on,
        "without_polling": off,
        "p99_ratio": on["p99_median_ns"] / off["p99_median_ns"] if off["p99_median_ns"] else None,
        "p50_ratio": on["p50_median_ns"] / off["p50_median_ns"] if off["p50_median_ns"] else None,
    }
    os.makedirs(args.out_dir, exist_ok=True)
    path = os.path.join(args.out_dir, f"control_plane-{stamp}.json")
    with open(path, "w") as out:
        json.dump(result, out, indent=2)
        out.write("\n")
    print(f"with stats --watch at {1 / args.interval:g} Hz: p50 {on['p50_median_ns']} ns, p99 {on['p99_median_ns']} ns "
          f"(median of {on['windows']} windows; worst {on['p99_max_ns']} ns)")
    print(f"without:                   p50 {off['p50_median_ns']} ns, p99 {off['p99_median_ns']} ns "
          f"(median of {off['windows']} windows; worst {off['p99_max_ns']} ns)")
    print(f"p99 ratio (with / without): {result['p99_ratio']:.3f}")
    print(f"written to {path}")


if __name__ == "__main__":
    main()
