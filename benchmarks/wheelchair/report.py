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


def arrival_clock(folder, config):
    """The clock figures (ClockStats) of the process that stamps Joystick -> Control's arrival:
    its wall time minus the kernel's over the run (the TSC clock only), or None."""
    how = config.get("joystick_to_control", {})
    summary = load_json(os.path.join(folder, (how["process"] if "process" in how else "polyportd") + ".json")) or {}
    return summary.get("clock") if "wall_checks" in (summary.get("clock") or {}) else None


def figures(folder, config, run, name):
    """One repetition of one configuration: (its figures, its simulator trace)."""
    trace = load_trace(os.path.join(folder, "sim_trace.csv"))
    end_to_end, share, source = joystick_to_control(folder, config)
    sim = load_json(os.path.join(folder, "sim.json")) or {}
    stats = load_json(os.path.join(folder, "polyportd.json")) or {}
    hops = {c["name"]: {k: c[k] for k in ("latency_ns", "transit_ns", "sink_ns") if k in c}
            for c in stats.get("connections", [])}
    cpu = load_json(os.path.join(folder, "cpu.json")) or {}
    cpu["sim"] = sim.get("cpu_s")
    threads = load_json(os.path.join(folder, "threads.json"))
    # Periods of the run: the simulator's, or (host runs, no simulator) the duration's.
    periods = sim.get("periods") or int(round((run.get("duration_s") or 0) / 0.01))
    return {
        "description": config.get("description", ""),
        "ran_in": run.get("environments", {}).get(name),
        "compare_with": config.get("compare_with"),
        "paired_in": config.get("paired_in"),
        "joystick_to_control_ns": end_to_end,
        "joystick_to_control_source": source,
        "arrival_clock": arrival_clock(folder, config),
        "polyport_share_ns": share,
        "sensor_to_actuator_ns": sim.get("step_to_motor_ns"),
        "period_lateness_ns": jitter(folder, config),
        "cpu_s": cpu,
        "cpu_us_per_period": {k: (v * 1e6 / periods if v is not None and periods else None) for k, v in cpu.items()},
        "polyport_hops": hops,
        "threads": threads,
        "per_period": per_period(threads, periods),
        "simulator": sim,
        "trace_periods": len(trace),
    }, trace


def per_period(threads, periods):
    """Per process, its threads' figures over the scenario summed and divided by the periods
    (wakes: voluntary context switches; wait_us: time runnable but waiting for the CPU)."""
    if not threads or not periods:
        return None
    out = {}
    for process, rows in threads.items():
        total = lambda key: sum(r.get(key, 0) for r in rows)
        out[process] = {"threads": len(rows),
                        "wakes": total("voluntary_switches") / periods,
                        "preemptions": total("nonvoluntary_switches") / periods,
                        "minor_faults": total("minor_faults") / periods,
                        "run_us": total("run_ns") / 1e3 / periods,
                        "wait_us": total("wait_ns") / 1e3 / periods,
                        "slices": total("slices") / periods}
    return out


def mean_of(stats):
    return (stats or {}).get("mean")


def median(values):
    values = sorted(v for v in values if v is not None)
    if not values:
        return None
    middle = len(values) // 2
    return values[middle] if len(values) % 2 else (values[middle - 1] + values[middle]) / 2


def representative(reps):
    """The repetition whose Joystick -> Control mean (else polyport's share) is the median of
    the repetitions' (the lower of the two middle ones for an even count): its figures stand
    for the configuration in the tables, as measured, not averaged."""
    for key in ("joystick_to_control_ns", "polyport_share_ns"):
        measured = [(mean_of(r[key]), k) for k, r in reps.items() if mean_of(r[key]) is not None]
        if measured:
            measured.sort()
            return measured[(len(measured) - 1) // 2][1]
    return min(reps)


def build(run_dir):
    run = load_json(os.path.join(run_dir, "run.json")) or {}
    configurations = run.get("configurations", {})
    result = {"suite": "wheelchair", "git_revision": git("rev-parse", "HEAD"), "git_dirty": bool(git("status", "--porcelain", "--untracked-files=no")),
              "host": host(), "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
              "duration_s": run.get("duration_s"), "repetitions": run.get("repetitions", 1),
              "scenario": run.get("scenario") or "wheelchair_sim default", "configurations": {}}
    # Every repetition's figures and traces: {name: {k: figures}}, {k: {name: trace}}.
    by_rep = {}
    traces_by_rep = {}
    for name, config in configurations.items():
        folder = os.path.join(run_dir, name)
        ks = sorted(int(d) for d in (os.listdir(folder) if os.path.isdir(folder) else []) if d.isdigit())
        # A run folder from before repetitions: one, in the configuration's folder.
        rounds = {k: os.path.join(folder, str(k)) for k in ks} or {1: folder}
        by_rep[name] = {}
        for k, path in rounds.items():
            by_rep[name][k], traces_by_rep.setdefault(k, {})[name] = figures(path, config, run, name)
    for name, reps in by_rep.items():
        k = representative(reps)
        c = dict(reps[k])
        c["repetition"] = k
        c["repetitions"] = len(reps)
        c["joystick_to_control_mean_ns_by_repetition"] = {str(j): mean_of(r["joystick_to_control_ns"]) for j, r in reps.items()}
        c["polyport_share_mean_ns_by_repetition"] = {str(j): mean_of(r["polyport_share_ns"]) for j, r in reps.items()}
        result["configurations"][name] = c
    # The traces on the charts: the first repetition's (all configurations closest in time).
    traces = traces_by_rep[min(traces_by_rep)] if traces_by_rep else {}
    # The bars, over every repetition.
    pairs = {}
    for k, rep_traces in sorted(traces_by_rep.items()):
        # Pairs' members (paired_in) are left out: their runs repeat the configurations'.
        names = [n for n in rep_traces if rep_traces[n] and not configurations.get(n, {}).get("paired_in")]
        for i, a in enumerate(names):
            for b in names[i + 1:]:
                c = compare(rep_traces[a], rep_traces[b])
                if c and (pairs.get(f"{a} vs {b}") is None or c["rms_deg"] > pairs[f"{a} vs {b}"]["rms_deg"]):
                    pairs[f"{a} vs {b}"] = dict(c, repetition=k)
    result["steering_difference"] = pairs  # the largest RMS of each pair over the repetitions
    diverged = {}
    for k, rep_traces in sorted(traces_by_rep.items()):
        for n, trace in rep_traces.items():
            if not trace:
                continue
            steps = scenario_step_times(trace)
            turn = steps[1] if len(steps) > 1 else None  # the second move of the stick: the 20 deg step
            end = steps[2] if len(steps) > 2 else trace[-1]["t_s"] + 1
            before = divergence(trace, 0.0, turn) if turn is not None else None
            after = divergence(trace, turn + 0.5, end) if turn is not None else None
            d = {"repetition": k, "step_s": turn, "mean_abs_left_minus_right_before_rad_s": before,
                 "mean_abs_left_minus_right_after_rad_s": after, "diverged": after is not None and after > DIVERGED_RAD_S}
            # The least divergent repetition of each configuration stands for it.
            if n not in diverged or (after or 0) < (diverged[n]["mean_abs_left_minus_right_after_rad_s"] or 0):
                diverged[n] = d
    result["wheel_speed_divergence"] = diverged
    bars = []
    conf = result["configurations"]
    differences = {}  # Joystick -> Control, a compared configuration's median difference
    within = f"Joystick -> Control within {E2E_MEAN_VS_NATIVE_NS / 1000:g} us of"
    ran_in = lambda c: f" ({c['ran_in']})" if c.get("ran_in") else ""
    for name, c in conf.items():
        native = c.get("compare_with")
        where = ran_in(c)
        reps = by_rep[name]
        shares = [mean_of(r["polyport_share_ns"]) for r in reps.values() if mean_of(r["polyport_share_ns"]) is not None]
        if native and shares:
            v = max(shares)
            bars.append({"bar": f"{name}{where}: polyport's share of Joystick -> Control <= {SHARE_MEAN_NS / 1000:g} us mean "
                                f"(the largest of {len(shares)} repetitions)", "measured_ns": v, "holds": v <= SHARE_MEAN_NS,
                         "by_repetition_ns": shares})
        if native and native not in by_rep:
            bars.append({"bar": f"{name}{where}: {within} "
                                f"{native}: {native} did not run", "measured_ns": None, "holds": False})
        elif native:
            # Each repetition against the native configuration's of the same repetition (run
            # next to it); the bar is on the median of these differences.
            diffs = {str(k): mean_of(r["joystick_to_control_ns"]) - mean_of(by_rep[native][k]["joystick_to_control_ns"])
                     for k, r in reps.items() if k in by_rep[native] and mean_of(r["joystick_to_control_ns"]) is not None
                     and mean_of(by_rep[native][k]["joystick_to_control_ns"]) is not None}
            if not diffs:
                bars.append({"bar": f"{name}{where}: {within} "
                                    f"{native}: no round measured both", "measured_ns": None, "holds": False})
            else:
                d = median(diffs.values())
                # Beside it, not in it: how much of each difference the two arrival stamps'
                # clocks account for (this one's wall error minus the native one's, each its
                # process's mean over the run; None where either read clock_gettime itself).
                wall_error = lambda r: (r["arrival_clock"] or {}).get("wall_error_mean_ns")
                clock_part = {str(k): wall_error(r) - wall_error(by_rep[native][k]) for k, r in reps.items()
                              if str(k) in diffs and wall_error(r) is not None and wall_error(by_rep[native][k]) is not None}
                what = ("; the pairing's own check: two native configurations at the same time"
                        if configurations.get(name, {}).get("check_of_pairing") else "")
                bars.append({"bar": f"{name}{where}: {within} "
                                    f"{native} (mean; the median over {len(diffs)} repetitions of the difference{what})",
                             "measured_ns": d, "holds": abs(d) <= E2E_MEAN_VS_NATIVE_NS, "by_repetition_ns": diffs,
                             "clock_part_by_repetition_ns": clock_part})
                differences[name] = d
    # A pair's member whose place in the period differs from its native one's (native_b_shifted
    # runs 4.5 ms later): its difference less the pairing's own check at the same two places
    # (`position_check`, an A/A pair: native B at this member's place against the same shifted
    # native), so that what the place in the period adds cancels.
    for name, c in conf.items():
        check = configurations.get(name, {}).get("position_check")
        if not check or name not in differences:
            continue
        where = ran_in(c)
        if check not in differences:
            bars.append({"bar": f"{name}{where}: {within} native "
                                f"at the same place in the period: {check} did not run", "measured_ns": None, "holds": False})
            continue
        d = differences[name] - differences[check]
        bars.append({"bar": f"{name}{where}: {within} native at "
                            f"the same place in the period ({name} - {c['compare_with']} less {check} - "
                            f"{conf[check]['compare_with']}, the medians over their repetitions)",
                     "measured_ns": d, "holds": abs(d) <= E2E_MEAN_VS_NATIVE_NS,
                     "paired_ns": differences[name], "position_check_ns": differences[check]})
    for pair, c in pairs.items():
        bars.append({"bar": f"steering RMS difference {pair} < {STEERING_RMS_DEG} deg (the largest over the repetitions)",
                     "measured_deg": c["rms_deg"], "max_abs_deg": c["max_abs_deg"], "holds": c["rms_deg"] < STEERING_RMS_DEG})
    for n, d in diverged.items():
        bars.append({"bar": f"{n}: wheel speeds diverge after the 20 deg step (every repetition)", "measured_rad_s":
                     d["mean_abs_left_minus_right_after_rad_s"], "holds": d["diverged"]})
    for n, reps in by_rep.items():
        for k, r in reps.items():
            periods = r["trace_periods"] if r["trace_periods"] else (r["joystick_to_control_ns"] or {}).get("count", 0)
            if periods < 1000:
                bars.append({"bar": f"{n} (repetition {k}): at least 1000 periods", "measured": periods, "holds": False})
    result["bars"] = bars
    return result, traces


def table(result):
    conf = result["configurations"]
    lines = [f"# Wheelchair suite, {result['date']}", "",
             f"Machine: {result['host']['cpu']} ({result['host']['cpus']} CPUs), kernel {result['host']['kernel']}, "
             f"git {result['git_revision'][:12]}{' (modified)' if result['git_dirty'] else ''}; "
             f"scenario {result['scenario']}, {result['duration_s']} s per configuration, "
             f"{result['repetitions']} repetition(s) interleaved.", "",
             "## Joystick -> Control latency (Table 1 analog), µs", "",
             "Each row is one repetition's figures as measured: the repetition whose mean is the median of the "
             "configuration's repetitions (`rep`); `means` lists every repetition's mean.", "",
             "| configuration | ran in | rep | count | mean | SD | min | max | p50 | p99 | means | measured at |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for n, c in conf.items():
        rep = f"{c['repetition']} of {c['repetitions']}"
        for label, s, means, source in (
                (n, c["joystick_to_control_ns"], c["joystick_to_control_mean_ns_by_repetition"], c["joystick_to_control_source"]),
                (f"{n}: polyport's share", c.get("polyport_share_ns"), c["polyport_share_mean_ns_by_repetition"],
                 "polyportd, in to out")):
            if label != n and not s:
                continue
            s = s or {}
            means_text = ", ".join(us(v) for v in means.values())
            lines.append(f"| {label} | {c.get('ran_in') or '–'} | {rep} | {s.get('count', 0)} | {us(s.get('mean'))} | {us(s.get('sd'))} | "
                         f"{us(s.get('min'))} | {us(s.get('max'))} | {us(s.get('p50'))} | {us(s.get('p99'))} | {means_text} | {source} |")
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
    lines += ["", "## Bars", "", "| bar | measured | by repetition (µs) | holds |", "|---|---|---|---|"]
    units = {"measured_ns": (1e-3, " µs"), "measured_deg": (1, "°"), "measured_rad_s": (1, " rad/s")}
    for b in result["bars"]:
        key, measured = next(((k, v) for k, v in b.items() if k.startswith("measured")), (None, None))
        scale, unit = units.get(key, (1, ""))
        text = f"{measured * scale:.3f}{unit}" if isinstance(measured, (int, float)) and key in units else str(measured)
        by = b.get("by_repetition_ns")
        by_text = ", ".join(f"{v / 1000:.2f}" for v in (by.values() if isinstance(by, dict) else by)) if by else "–"
        lines.append(f"| {b['bar']} | {text} | {by_text} | {'yes' if b['holds'] else '**no**'} |")
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
    # Each mark at its own place on the axis: a summary without p90 (a program's) leaves a gap.
    place = {k: i for i, (k, _) in enumerate(marks)}
    for n in names:
        s = result["configurations"][n]["joystick_to_control_ns"]
        ks = [k for k, _ in marks if k in s]
        ax.plot([place[k] for k in ks], [s[k] / 1000 for k in ks], marker="o", label=f"{n} (n={s.get('count')})")
        share = result["configurations"][n].get("polyport_share_ns")
        if share:
            ks = [k for k, _ in marks if k in share]
            ax.plot([place[k] for k in ks], [share[k] / 1000 for k in ks], marker="x", linestyle=":",
                    label=f"{n}: polyport's share")
    ax.set_xticks(range(len(marks)))
    ax.set_xticklabels([label for _, label in marks])
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
