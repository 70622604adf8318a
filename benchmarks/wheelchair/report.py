#!/usr/bin/python3
"""Turns a run folder of run_configs.py into the wheelchair suite's results:

  RESULTS/wheelchair-STAMP.json            every raw figure, the bars and whether they hold
  RESULTS/wheelchair-STAMP.md              the tables (Table 1 of the seed paper, and more)
  RESULTS/wheelchair-STAMP-steering.png    steering angle and wheel speeds over time, all
                                           configurations on one chart (the Fig. 14 analog)
  RESULTS/wheelchair-STAMP-latency.png     Joystick -> Control latency distribution per configuration

Nothing is smoothed or hard-coded: every number comes from the files the run wrote.
Plots use matplotlib (Debian: python3-matplotlib)."""
import argparse
import csv
import datetime
import json
import math
import os
import platform
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# The bars of the suite (issue text; README "Benchmarks" repeats them).
SHARE_MEAN_NS = 2000          # polyport's own share of Joystick -> Control in mixed, mean
E2E_MEAN_VS_NATIVE_NS = 5000  # mixed's Joystick -> Control mean within this of native B's
STEERING_RMS_DEG = 0.5        # pairwise RMS difference of the steering traces
DIVERGED_RAD_S = 0.5          # |left - right| wheel speed that counts as diverged after the step


def load_json(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def load_trace(path):
    rows = []
    try:
        with open(path) as f:
            for row in csv.DictReader(f):
                rows.append({k: float(v) for k, v in row.items()})
    except OSError:
        pass
    return rows


def connection(stats, name):
    for c in (stats or {}).get("connections", []):
        if c.get("name") == name:
            return c
    return None


def joystick_to_control(folder, config):
    """(end-to-end stats, polyport's share stats or None, where it came from)."""
    how = config.get("joystick_to_control", {})
    if "process" in how:
        summary = load_json(os.path.join(folder, how["process"] + ".json")) or {}
        return summary.get(how["field"]), None, f"{how['process']} program, {how['field']}"
    if "connection" in how:
        c = connection(load_json(os.path.join(folder, "polyportd.json")), how["connection"])
        if c is None:
            return None, None, "polyportd statistics missing"
        share = c.get(how["polyport_share"]) if "polyport_share" in how else None
        source = f"polyportd {how['connection']}, {how['histogram']}"
        if how["histogram"] not in c:
            source += " (not recorded" + (f": {how['note']}" if "note" in how else "") + ")"
        return c.get(how["histogram"]), share, source
    return None, None, "not measured"


def jitter(folder, config):
    """Wake lateness of every periodic component: {name: stats}."""
    out = {}
    sim = load_json(os.path.join(folder, "sim.json")) or {}
    if "lateness_ns" in sim:
        out["sim"] = sim["lateness_ns"]
    for p in config.get("processes", []):
        s = load_json(os.path.join(folder, p["name"] + ".json")) or {}
        if "lateness_ns" in s:
            out[p["name"]] = s["lateness_ns"]
    stats = load_json(os.path.join(folder, "polyportd.json")) or {}
    for ec in stats.get("execution_contexts", []):
        out["polyportd:" + "+".join(ec.get("members", []))] = ec.get("wake_jitter_ns")
    return out


def compare(a, b):
    n = min(len(a), len(b))
    if n == 0:
        return None
    diffs = [a[i]["steering_deg"] - b[i]["steering_deg"] for i in range(n)]
    return {"rms_deg": math.sqrt(sum(d * d for d in diffs) / n), "max_abs_deg": max(abs(d) for d in diffs), "samples": n}


def divergence(trace, start_s, end_s):
    window = [abs(r["left_rad_s"] - r["right_rad_s"]) for r in trace if start_s <= r["t_s"] < end_s]
    return sum(window) / len(window) if window else None


def scenario_step_times(trace):
    """Times where the stick moves in the trace (the scenario's steps as played)."""
    times = []
    for prev, row in zip(trace, trace[1:]):
        if (row["joy_x"], row["joy_y"]) != (prev["joy_x"], prev["joy_y"]):
            times.append(row["t_s"])
    return times


def us(v):
    return "–" if v is None else f"{v / 1000:.1f}"


def git(*args):
    try:
        return subprocess.run(["git", "-C", ROOT, *args], capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return ""


def host():
    model = ""
    try:
        with open("/proc/cpuinfo") as f:
            model = next((l.split(":", 1)[1].strip() for l in f if l.startswith("model name")), "")
    except OSError:
        pass
    return {"name": platform.node(), "kernel": platform.release(), "cpu": model, "cpus": os.cpu_count()}


def build(run_dir):
    run = load_json(os.path.join(run_dir, "run.json")) or {}
    configurations = run.get("configurations", {})
    result = {"suite": "wheelchair", "git_revision": git("rev-parse", "HEAD"), "git_dirty": bool(git("status", "--porcelain", "--untracked-files=no")),
              "host": host(), "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
              "duration_s": run.get("duration_s"),
              "scenario": run.get("scenario") or "wheelchair_sim default", "configurations": {}}
    traces = {}
    for name, config in configurations.items():
        folder = os.path.join(run_dir, name)
        trace = load_trace(os.path.join(folder, "sim_trace.csv"))
        traces[name] = trace
        end_to_end, share, source = joystick_to_control(folder, config)
        sim = load_json(os.path.join(folder, "sim.json")) or {}
        stats = load_json(os.path.join(folder, "polyportd.json")) or {}
        hops = {c["name"]: {k: c[k] for k in ("latency_ns", "transit_ns", "sink_ns") if k in c}
                for c in stats.get("connections", [])}
        cpu = load_json(os.path.join(folder, "cpu.json")) or {}
        cpu["sim"] = sim.get("cpu_s")
        # Periods of the run: the simulator's, or (host runs, no simulator) the duration's.
        periods = sim.get("periods") or int(round((run.get("duration_s") or 0) / 0.01))
        result["configurations"][name] = {
            "description": config.get("description", ""),
            "ran_in": run.get("environments", {}).get(name),
            "compare_with": config.get("compare_with"),
            "joystick_to_control_ns": end_to_end,
            "joystick_to_control_source": source,
            "polyport_share_ns": share,
            "sensor_to_actuator_ns": sim.get("step_to_motor_ns"),
            "period_lateness_ns": jitter(folder, config),
            "cpu_s": cpu,
            "cpu_us_per_period": {k: (v * 1e6 / periods if v is not None and periods else None) for k, v in cpu.items()},
            "polyport_hops": hops,
            "simulator": sim,
            "trace_periods": len(trace),
        }
    # The bars.
    names = [n for n in traces if traces[n]]
    pairs = {}
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            pairs[f"{a} vs {b}"] = compare(traces[a], traces[b])
    result["steering_difference"] = pairs
    diverged = {}
    for n in names:
        steps = scenario_step_times(traces[n])
        turn = steps[1] if len(steps) > 1 else None  # the second move of the stick: the 20 deg step
        end = steps[2] if len(steps) > 2 else traces[n][-1]["t_s"] + 1
        before = divergence(traces[n], 0.0, turn) if turn is not None else None
        after = divergence(traces[n], turn + 0.5, end) if turn is not None else None
        diverged[n] = {"step_s": turn, "mean_abs_left_minus_right_before_rad_s": before,
                       "mean_abs_left_minus_right_after_rad_s": after,
                       "diverged": after is not None and after > DIVERGED_RAD_S}
    result["wheel_speed_divergence"] = diverged
    bars = []
    conf = result["configurations"]
    for name, c in conf.items():
        native = conf.get(c.get("compare_with") or "")
        where = f" ({c['ran_in']})" if c.get("ran_in") else ""
        if c.get("compare_with") and c.get("polyport_share_ns"):
            v = c["polyport_share_ns"]["mean"]
            bars.append({"bar": f"{name}{where}: polyport's share of Joystick -> Control <= {SHARE_MEAN_NS / 1000:g} us mean",
                         "measured_ns": v, "holds": v <= SHARE_MEAN_NS})
        if native and c.get("joystick_to_control_ns") and native.get("joystick_to_control_ns"):
            d = c["joystick_to_control_ns"]["mean"] - native["joystick_to_control_ns"]["mean"]
            bars.append({"bar": f"{name}{where}: Joystick -> Control within {E2E_MEAN_VS_NATIVE_NS / 1000:g} us of "
                                f"{c['compare_with']} (mean)", "measured_ns": d, "holds": abs(d) <= E2E_MEAN_VS_NATIVE_NS})
    for pair, c in pairs.items():
        if c:
            bars.append({"bar": f"steering RMS difference {pair} < {STEERING_RMS_DEG} deg", "measured_deg": c["rms_deg"],
                         "max_abs_deg": c["max_abs_deg"], "holds": c["rms_deg"] < STEERING_RMS_DEG})
    for n, d in diverged.items():
        bars.append({"bar": f"{n}: wheel speeds diverge after the 20 deg step", "measured_rad_s":
                     d["mean_abs_left_minus_right_after_rad_s"], "holds": d["diverged"]})
    for n, c in conf.items():
        periods = c["trace_periods"] if traces.get(n) else (c["joystick_to_control_ns"] or {}).get("count", 0)
        if periods < 1000:
            bars.append({"bar": f"{n}: at least 1000 periods", "measured": periods, "holds": False})
    result["bars"] = bars
    return result, traces


def table(result):
    conf = result["configurations"]
    lines = [f"# Wheelchair suite, {result['date']}", "",
             f"Machine: {result['host']['cpu']} ({result['host']['cpus']} CPUs), kernel {result['host']['kernel']}, "
             f"git {result['git_revision'][:12]}{' (modified)' if result['git_dirty'] else ''}; "
             f"scenario {result['scenario']}, {result['duration_s']} s per configuration.", "",
             "## Joystick -> Control latency (Table 1 analog), µs", "",
             "| configuration | ran in | count | mean | SD | min | max | p50 | p99 | measured at |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for n, c in conf.items():
        s = c["joystick_to_control_ns"] or {}
        lines.append(f"| {n} | {c.get('ran_in') or '–'} | {s.get('count', 0)} | {us(s.get('mean'))} | {us(s.get('sd'))} | {us(s.get('min'))} | "
                     f"{us(s.get('max'))} | {us(s.get('p50'))} | {us(s.get('p99'))} | {c['joystick_to_control_source']} |")
        if c.get("polyport_share_ns"):
            s = c["polyport_share_ns"]
            lines.append(f"| {n}: polyport's share | {c.get('ran_in') or '–'} | {s.get('count', 0)} | {us(s.get('mean'))} | {us(s.get('sd'))} | "
                         f"{us(s.get('min'))} | {us(s.get('max'))} | {us(s.get('p50'))} | {us(s.get('p99'))} | polyportd, in to out |")
    lines += ["", "## Sensor to actuator (stick step in the joystick frame -> first motor frame responding, kernel stamps), ms", "",
              "| configuration | steps | mean | min | max |", "|---|---|---|---|---|"]
    for n, c in conf.items():
        s = c["sensor_to_actuator_ns"] or {}
        ms = lambda v: "–" if v is None else f"{v / 1e6:.2f}"
        lines.append(f"| {n} | {s.get('count', 0)} | {ms(s.get('mean'))} | {ms(s.get('min'))} | {ms(s.get('max'))} |")
    lines += ["", "## Period lateness (wake - deadline) and CPU time", "",
              "| configuration | component | p50 µs | p99 µs | max µs | CPU µs / period |", "|---|---|---|---|---|---|"]
    for n, c in conf.items():
        for comp, s in c["period_lateness_ns"].items():
            proc = comp.split(":")[0]
            cpu = c["cpu_us_per_period"].get(proc)
            lines.append(f"| {n} | {comp} | {us((s or {}).get('p50'))} | {us((s or {}).get('p99'))} | {us((s or {}).get('max'))} | "
                         f"{'–' if cpu is None else f'{cpu:.1f}'} |")
    lines += ["", "## polyport's hops (in to out), µs", "", "| configuration | connection | p50 | p99 | transit p50 |",
              "|---|---|---|---|---|"]
    for n, c in conf.items():
        for hop, h in c["polyport_hops"].items():
            t = h.get("transit_ns", {})
            lines.append(f"| {n} | {hop} | {us(h['latency_ns'].get('p50'))} | {us(h['latency_ns'].get('p99'))} | {us(t.get('p50'))} |")
    lines += ["", "## Bars", "", "| bar | measured | holds |", "|---|---|---|"]
    for b in result["bars"]:
        measured = next((v for k, v in b.items() if k.startswith("measured")), None)
        text = f"{measured:.3f}" if isinstance(measured, float) else str(measured)
        lines.append(f"| {b['bar']} | {text} | {'yes' if b['holds'] else '**no**'} |")
    return "\n".join(lines) + "\n"


def plots(result, traces, prefix):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    for n, trace in traces.items():
        if not trace:
            continue
        t = [r["t_s"] for r in trace]
        ax1.plot(t, [r["steering_deg"] for r in trace], label=n, linewidth=1)
        ax2.plot(t, [r["left_rad_s"] for r in trace], label=f"{n} left", linewidth=1)
        ax2.plot(t, [r["right_rad_s"] for r in trace], label=f"{n} right", linewidth=1, linestyle="--")
    ax1.set_ylabel("steering angle (deg)")
    ax1.set_title("Wheelchair steering (simulator's view), all configurations")
    ax1.legend()
    ax1.grid(True, alpha=0.3)
    ax2.set_ylabel("wheel speed (rad/s)")
    ax2.set_xlabel("time (s)")
    ax2.legend(fontsize=7, ncol=2)
    ax2.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(prefix + "-steering.png", dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(9, 4.5))
    marks = [("min", "min"), ("p50", "p50"), ("p90", "p90"), ("p99", "p99"), ("max", "max")]
    names = [n for n, c in result["configurations"].items() if c["joystick_to_control_ns"]]
    for i, n in enumerate(names):
        s = result["configurations"][n]["joystick_to_control_ns"]
        xs = [k for k, _ in marks if k in s]
        ax.plot(xs, [s[k] / 1000 for k in xs], marker="o", label=f"{n} (n={s.get('count')})")
        share = result["configurations"][n].get("polyport_share_ns")
        if share:
            xs = [k for k, _ in marks if k in share]
            ax.plot(xs, [share[k] / 1000 for k in xs], marker="x", linestyle=":", label=f"{n}: polyport's share")
    ax.set_yscale("log")
    ax.set_ylabel("Joystick -> Control latency (µs)")
    ax.set_title("Latency distribution per configuration")
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(prefix + "-latency.png", dpi=110)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run", help="the run folder run_configs.py filled")
    parser.add_argument("--results", default=os.path.join(ROOT, "benchmarks", "results"))
    parser.add_argument("--no-plots", action="store_true")
    args = parser.parse_args()
    result, traces = build(args.run)
    if not result["configurations"]:
        print(f"report: no configurations in {args.run}", file=sys.stderr)
        return 1
    os.makedirs(args.results, exist_ok=True)
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    prefix = os.path.join(args.results, f"wheelchair-{stamp}")
    with open(prefix + ".json", "w") as f:
        json.dump(result, f, indent=1)
    text = table(result)
    with open(prefix + ".md", "w") as f:
        f.write(text)
    if not args.no_plots:
        plots(result, traces, prefix)
    print(text)
    print(f"report: wrote {prefix}.json, .md{'' if args.no_plots else ', -steering.png, -latency.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
