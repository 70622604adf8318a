#!/usr/bin/python3
"""The jitter and load benchmark (benchmarks/stress/README.md): the wheelchair application
(profiles/wheelchair_inproc.xml: Joystick, Control, HW at 10 ms in one execution context) run
by polyportd in four cases, one after the other in one run:

  idle    / default     the profile as shipped (SCHED_OTHER), nothing else running
  idle    / realtime    the same components under SCHED_FIFO (memory locked by the daemon)
  stress  / default     as shipped, with stress-ng loading every CPU and memory beside it
  stress  / realtime    SCHED_FIFO with the same stressor

For each case: the execution context's wake lateness (wake - deadline) and every connection's
in-to-out latency as p50 / p99 / p99.9 / max (the daemon's own histograms, --stats-json),
overruns and missed periods; the distributions from the Prometheus histograms at the end of
the case (--metrics-port) for the PNG.

Usage: bench_stress.py --polyportd P --out-dir DIR [--duration-s 60] [--priority 80]
       [--stressor "stress-ng --cpu 0 --vm 2 --vm-bytes 256M"] [--cases idle/default,...]
Writes DIR/stress-<stamp>.json, .md and .png, and prints the table.
"""
import argparse
import datetime
import json
import os
import platform
import re
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.request

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.realpath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "benchmarks", "common"))
from bench_results import free_port, write_results  # noqa: E402
PROFILE = "wheelchair_inproc.xml"
CASES = ["idle/default", "idle/realtime", "stress/default", "stress/realtime"]
MARKS = ("p50", "p99", "p999", "max")


def application(work, realtime, priority):
    """Copies the shipped wheelchair profiles into WORK (the component profiles' relative
    type paths kept working through a link to config/), switching the components to SCHED_FIFO
    at PRIORITY for the real-time cases."""
    folder = os.path.join(work, "realtime" if realtime else "default")
    profiles = os.path.join(folder, "profiles")
    os.makedirs(os.path.join(profiles, "components"), exist_ok=True)
    if not os.path.exists(os.path.join(folder, "config")):
        os.symlink(os.path.join(ROOT, "config"), os.path.join(folder, "config"))
    shutil.copy(os.path.join(ROOT, "profiles", PROFILE), profiles)
    for name in ("JoystickComp.xml", "ControlComp.xml", "HWComp.xml"):
        with open(os.path.join(ROOT, "profiles", "components", name)) as f:
            text = f.read()
        if realtime:
            text, n = re.subn(r"<priority>\s*0\s*</priority>(\s*)<policy>\s*SCHED_OTHER\s*</policy>",
                              rf"<priority>{priority}</priority>\1<policy>SCHED_FIFO</policy>", text)
            if n != 1:
                sys.exit(f"bench_stress: cannot switch {name} to SCHED_FIFO (execution_semantics changed?)")
        with open(os.path.join(profiles, "components", name), "w") as f:
            f.write(text)
    return os.path.join(profiles, PROFILE)


def histograms(port):
    """The cumulative bucket counts of every histogram at /metrics: {(metric, label): [(le, count)]}."""
    from prometheus_client.parser import text_string_to_metric_families
    text = urllib.request.urlopen(f"http://127.0.0.1:{port}/metrics", timeout=10).read().decode()
    out = {}
    for family in text_string_to_metric_families(text):
        if family.type != "histogram":
            continue
        for s in family.samples:
            if s.name.endswith("_bucket"):
                label = ",".join(f"{k}={v}" for k, v in sorted(s.labels.items()) if k != "le")
                out.setdefault(f"{family.name} {label}", []).append((float(s.labels["le"]), s.value))
    return {k: sorted(v) for k, v in out.items()}


def summary(h):
    return {k: h.get(k) for k in ("count", "mean", "min") + MARKS}


def run_case(args, case, profile, work):
    load, settings = case.split("/")
    stressor = None
    if load == "stress":
        stressor = subprocess.Popen(shlex.split(args.stressor), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                    start_new_session=True)
        time.sleep(2)  # the stressor's workers are running before the daemon starts
        if stressor.poll() is not None:
            sys.exit(f"bench_stress: the stressor ended at once ({args.stressor})")
    port = free_port()
    stats_file = os.path.join(work, case.replace("/", "-") + ".json")
    log_path = os.path.join(work, case.replace("/", "-") + ".log")
    log = open(log_path, "w+")
    daemon = subprocess.Popen([args.polyportd, "run", profile, "--admin-socket", "none", "--stats-interval", "0",
                               "--metrics-port", str(port), "--stats-json", stats_file,
                               "--duration", str(args.duration_s + 1)], stdout=log, stderr=log)
    try:
        t0 = time.monotonic()
        while " running " not in open(log_path).read():
            if daemon.poll() is not None or time.monotonic() - t0 > 60:
                sys.exit(f"bench_stress: polyportd did not run ({case}):\n{open(log_path).read()}")
            time.sleep(0.05)
        time.sleep(args.duration_s)
        buckets = histograms(port)
        daemon.wait(60)
    finally:
        if daemon.poll() is None:
            daemon.kill()
        if stressor is not None:
            os.killpg(stressor.pid, signal.SIGTERM)
            stressor.wait(30)
        log.close()
    if daemon.returncode != 0:
        sys.exit(f"bench_stress: polyportd exited with {daemon.returncode} ({case}):\n{open(log_path).read()}")
    with open(stats_file) as f:
        stats = json.load(f)
    warnings = [line.strip() for line in open(log_path) if "warn" in line.lower()]
    contexts = [{"name": e["name"], "members": e["members"], "realtime": e["realtime"],
                 "wake_lateness_ns": summary(e["wake_jitter_ns"]), "cycles": e["cycles"],
                 "overruns": e["overruns"], "missed_periods": e["missed_periods"]}
                for e in stats["execution_contexts"]]
    connections = [{"name": c["name"], "latency_ns": summary(c["latency_ns"]), "dropped": c["dropped"]}
                   for c in stats["connections"]]
    # The final statistics are written after the contexts stopped and memory was unlocked: the
    # log says whether it was locked (a warning when not).
    realtime = any(e["realtime"] for e in contexts)
    return {"case": case, "load": load, "settings": settings, "duration_s": args.duration_s,
            "memory_locked": realtime and not any("memory not locked" in w for w in warnings), "contexts": contexts, "connections": connections,
            "warnings": warnings, "buckets": buckets}


def us(ns):
    return "—" if ns is None else f"{ns / 1000:.1f}"


def markdown(result):
    rows = ["| case | wake lateness p50 / p99 / p99.9 / max (µs) | cycles | overruns | missed | "
            "in-to-out p50 / p99 / p99.9 / max (ns, worst connection by p99) |",
            "|---|---|---|---|---|---|"]
    for r in result["cases"]:
        for e in r["contexts"]:
            w = e["wake_lateness_ns"]
            worst = max(r["connections"], key=lambda c: c["latency_ns"]["p99"] or 0)
            lat = worst["latency_ns"]
            rows.append(f"| {r['case']} | {' / '.join(us(w[k]) for k in MARKS)} | {e['cycles']} | {e['overruns']} | "
                        f"{e['missed_periods']} | {' / '.join(str(lat[k]) for k in MARKS)} ({worst['name']}) |")
    return "\n".join(rows) + "\n"


def plot(result, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.5))
    for r in result["cases"]:
        for key, values in r["buckets"].items():
            if not values or values[-1][1] == 0:
                continue
            total = values[-1][1]
            xs = [le * 1e6 for le, _ in values if le != float("inf")]
            ys = [1 - c / total for le, c in values if le != float("inf")]
            if "wake_jitter" in key:
                ax1.step(xs, [max(y, 1e-5) for y in ys], where="post", label=r["case"])
            elif "latency" in key and "Control.voltages" in key:
                ax2.step(xs, [max(y, 1e-5) for y in ys], where="post", label=r["case"])
    for ax, title in ((ax1, "execution context wake lateness"), (ax2, "Control.voltages -> HW in-to-out")):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("µs (histogram bucket bounds)")
        ax.set_ylabel("fraction above")
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"wheelchair, 10 ms, {result['host']} {result['date']}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--polyportd", required=True)
    parser.add_argument("--out-dir", required=True)
    parser.add_argument("--duration-s", type=float, default=60.0)
    parser.add_argument("--priority", type=int, default=80)
    parser.add_argument("--stressor", default="stress-ng --cpu 0 --vm 2 --vm-bytes 256M")
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--no-plot", action="store_true")
    args = parser.parse_args()
    cases = args.cases.split(",")
    for c in cases:
        if c not in CASES:
            sys.exit(f"bench_stress: unknown case {c!r} (known: {', '.join(CASES)})")
    if any(c.startswith("stress/") for c in cases) and not shutil.which(shlex.split(args.stressor)[0]):
        sys.exit(f"bench_stress: {shlex.split(args.stressor)[0]} not found (scripts/setup.sh installs stress-ng)")
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    result = {"benchmark": "stress", "date": stamp, "host": platform.node(), "kernel": platform.release(),
              "cpus": os.cpu_count(), "revision": os.environ.get("POLYPORT_GIT_REVISION", "unknown"),
              "euid": os.geteuid(), "stressor": args.stressor, "priority": args.priority, "cases": []}
    work = tempfile.mkdtemp(prefix="polyport-stress-")
    try:
        for i, case in enumerate(cases):
            print(f"stress: case {i + 1}/{len(cases)} {case}, {args.duration_s:g} s ...", flush=True)
            profile = application(work, case.endswith("realtime"), args.priority)
            r = run_case(args, case, profile, work)
            result["cases"].append(r)
            w = r["contexts"][0]["wake_lateness_ns"] if r["contexts"] else {}
            print(f"stress: {case}: wake lateness p99 {us(w.get('p99'))} µs, "
                  f"overruns {sum(e['overruns'] for e in r['contexts'])}", flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    table = markdown(result)
    path = write_results(args.out_dir, "stress", stamp, result,
                         f"Jitter and load benchmark {stamp}, {result['host']}, {result['cpus']} CPUs, kernel "
                         f"{result['kernel']}, revision {result['revision']}, {args.duration_s:g} s per case, stressor "
                         f"`{args.stressor}`, real-time = SCHED_FIFO {args.priority}\n\n" + table)
    if not args.no_plot:
        plot(result, path + ".png")
    print(table)
    print(f"written {path}.json, .md{'' if args.no_plot else ', .png'}")


if __name__ == "__main__":
    main()
