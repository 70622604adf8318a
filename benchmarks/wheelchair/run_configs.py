#!/usr/bin/python3
"""Runs the wheelchair suite's configurations, one after the other, where vcan0 exists (in
the vcan guest: scripts/bench_wheelchair.sh starts it). For each configuration it starts
polyportd and the configuration's programs, waits until each says it runs, then runs the
bus simulator for the scenario, stops everything and keeps what each wrote. With --repeat N
the configurations run N times, interleaved (all of them, then all of them in reverse order,
and so on), so that each repetition of one configuration has its neighbours' conditions and
no configuration always runs first; repetition K of a configuration writes

  OUT/<config>/<K>/sim_trace.csv, sim.json     the simulator's trace and figures
  OUT/<config>/<K>/<process>.json              each program's summary
  OUT/<config>/<K>/polyportd.json              polyportd's statistics (--stats-json)
  OUT/<config>/<K>/cpu.json                    CPU seconds of every process (from /proc)
  OUT/<config>/<K>/threads.json                every thread's figures over the scenario (/proc)
  OUT/<config>/<K>/*.log                       their stderr

Every periodic loop runs on a grid of CLOCK_MONOTONIC at the phase the configuration gives
it (the programs' --phase-ms, the profiles' <phase>; the simulator at its sim_phase_ms, 0 by
default), so that the loops' order in the period is the same in every run and configuration.

A pair (a configuration with `together`) runs its members at the same time, each with a
simulator of its own on its own interface, into OUT/<pair>/<member>/<K>: a difference between
them is measured under the same conditions, which change from second to second on these
machines (in the guest, one configuration's 3 s medians moved between 80 and 172 µs in one
run). The guest needs vcan1 for them (scripts/vcan-run --interfaces 2).

report.py turns a run folder into the JSON, the table and the plots. Exit status 0 when every
configuration produced a full trace; 1 otherwise (the failing step is printed)."""
import argparse
import json
import os
import signal
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


def progress(text):
    print(f"[wheelchair] {text}", flush=True)


def cpu_seconds(pid):
    """utime + stime of a live process, all its threads."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS
    except (OSError, IndexError, ValueError):
        return None


def thread_figures(pid):
    """Every thread of a live process, by thread id: its name, CPU seconds, page faults,
    context switches and (where the kernel keeps them) scheduler figures: time run, time
    waited runnable for a CPU, and the number of times it was put on one (schedstat)."""
    threads = {}
    try:
        tids = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return threads
    for tid in tids:
        task = f"/proc/{pid}/task/{tid}"
        try:
            with open(f"{task}/stat") as f:
                head, tail = f.read().rsplit(")", 1)
            fields = tail.split()
            figures = {"name": head.split("(", 1)[1],
                       "cpu_s": (int(fields[11]) + int(fields[12])) / CLOCK_TICKS,
                       "minor_faults": int(fields[7]), "major_faults": int(fields[9])}
            with open(f"{task}/status") as f:
                for line in f:
                    key, _, value = line.partition(":")
                    if key in ("voluntary_ctxt_switches", "nonvoluntary_ctxt_switches"):
                        figures[key.replace("_ctxt", "")] = int(value)
        except (OSError, IndexError, ValueError):
            continue  # the thread ended meanwhile
        try:
            with open(f"{task}/schedstat") as f:
                run_ns, wait_ns, slices = (int(v) for v in f.read().split()[:3])
            figures.update(run_ns=run_ns, wait_ns=wait_ns, slices=slices)
        except (OSError, ValueError):
            pass  # a kernel without CONFIG_SCHED_INFO
        threads[tid] = figures
    return threads


def thread_deltas(before, after):
    """Per process, every thread's figures at `after` less those at `before` (a thread that
    started meanwhile counts from zero), largest CPU first."""
    out = {}
    for name, threads in after.items():
        rows = []
        for tid, now in threads.items():
            then = before.get(name, {}).get(tid, {})
            row = {"tid": int(tid), "name": now["name"]}
            row.update({k: v - then.get(k, 0) for k, v in now.items() if k != "name"})
            rows.append(row)
        out[name] = sorted(rows, key=lambda r: -r["cpu_s"])
    return out


class Process:
    def __init__(self, name, argv, log_path, env):
        self.name = name
        self.log_path = log_path
        self.log = open(log_path, "w")
        self.popen = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=self.log, stderr=subprocess.STDOUT, env=env)

    def wait_for(self, text, deadline):
        while time.monotonic() < deadline:
            with open(self.log_path) as f:
                if text in f.read():
                    return True
            if self.popen.poll() is not None:
                return False
            time.sleep(0.05)
        return False

    def stop(self, timeout_s=10.0):
        """SIGINT, then SIGKILL after timeout_s; returns the exit status."""
        if self.popen.poll() is None:
            self.popen.send_signal(signal.SIGINT)
            try:
                self.popen.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait()
        self.log.close()
        return self.popen.returncode

    def tail(self, lines=15):
        with open(self.log_path) as f:
            return "".join(f.readlines()[-lines:])


def start(name, config, args, folder, started):
    """Starts the configuration's programs and polyportd, each once it says it runs; appends
    them to `started`. False (with the reason printed) when one did not come up."""
    os.makedirs(folder, exist_ok=True)
    env = dict(os.environ)
    env.setdefault("CYCLONEDDS_URI", "file://" + os.path.join(ROOT, "config", "cyclonedds-loopback.xml"))
    # A Fast DDS program's transports: the file polyport's Fast DDS model defaults to.
    env.setdefault("FASTRTPS_DEFAULT_PROFILES_FILE", os.path.join(ROOT, "config", "fastdds-loopback.xml"))
    bin_dir = args.bin
    for p in config.get("processes", []):
        argv = [a.replace("{bin}", bin_dir).replace("{root}", ROOT) for a in p["argv"]]
        argv += ["--summary", os.path.join(folder, p["name"] + ".json")]
        proc = Process(p["name"], argv, os.path.join(folder, p["name"] + ".log"), env)
        started.append(proc)
        if not proc.wait_for(p.get("ready", "running"), time.monotonic() + args.start_timeout):
            progress(f"{name}: {p['name']} did not start:\n{proc.tail()}")
            return False
    if config.get("profile"):
        argv = [os.path.join(bin_dir, "polyportd"), "run", "--admin-socket", "none", "--stats-json",
                os.path.join(folder, "polyportd.json"), os.path.join(ROOT, config["profile"])]
        proc = Process("polyportd", argv, os.path.join(folder, "polyportd.log"), env)
        started.append(proc)
        if not proc.wait_for(" running ", time.monotonic() + args.start_timeout):
            progress(f"{name}: polyportd did not start:\n{proc.tail()}")
            return False
    return True


def record_cpu(folder, started):
    with open(os.path.join(folder, "cpu.json"), "w") as f:
        json.dump({p.name: cpu_seconds(p.popen.pid) for p in started}, f)


def record_threads(folder, started, before):
    after = {p.name: thread_figures(p.popen.pid) for p in started}
    with open(os.path.join(folder, "threads.json"), "w") as f:
        json.dump(thread_deltas(before, after), f, indent=1)


def stop(name, started):
    ok = True
    for proc in reversed(started):
        status = proc.stop()
        if status not in (0, -signal.SIGINT):
            progress(f"{name}: {proc.name} exited with {status}:\n{proc.tail()}")
            ok = False
    return ok


def run_config(members, args):
    """A guest configuration, or a pair's members at the same time: for each (name, config,
    folder), its programs against a bus simulator of its own (on its `interface`, at its
    `sim_phase_ms`) for the scenario."""
    started = {name: [] for name, _, _ in members}
    sims = []
    ok = False
    try:
        for name, config, folder in members:
            if not start(name, config, args, folder, started[name]):
                return False
        for name, _, _ in members:
            progress(f"{name}: {', '.join(p.name for p in started[name])} up; simulator runs {args.duration} s")
        threads_before = {name: {p.name: thread_figures(p.popen.pid) for p in started[name]} for name, _, _ in members}
        for name, config, folder in members:
            sim_argv = [os.path.join(args.bin, "wheelchair_sim"), "--if", config.get("interface", args.interface),
                        "--duration-s", str(args.duration), "--phase-ms", str(config.get("sim_phase_ms", 0)),
                        "--trace", os.path.join(folder, "sim_trace.csv"), "--summary", os.path.join(folder, "sim.json")]
            if args.scenario:
                sim_argv += ["--scenario", args.scenario]
            sims.append((name, Process("sim", sim_argv, os.path.join(folder, "sim.log"), os.environ)))
        ok = True
        for name, sim in sims:
            try:
                status = sim.popen.wait(timeout=args.duration + args.start_timeout + 30)
            except subprocess.TimeoutExpired:
                sim.popen.kill()
                status = "timed out"
            sim.log.close()
            if status != 0:
                progress(f"{name}: simulator failed ({status}):\n{sim.tail()}")
                ok = False
        for name, _, folder in members:
            record_cpu(folder, started[name])
            record_threads(folder, started[name], threads_before[name])
    finally:
        for _, sim in sims:
            if sim.popen.poll() is None:
                sim.stop()
        for name, _, _ in members:
            ok = stop(name, started[name]) and ok
    progress(f"{' + '.join(name for name, _, _ in members)}: {'done' if ok else 'FAILED'}")
    return ok


def run_together(names, configurations, args, out_dir, repetition):
    """Host configurations: all at once (each on DDS domains of its own), so that they share
    the machine's load, for the duration; no simulator. Returns the names that failed."""
    started = {n: [] for n in names}
    up = []
    try:
        for n in names:
            if start(n, configurations[n], args, folder_of(out_dir, n, repetition), started[n]):
                up.append(n)
        progress(f"{', '.join(up)} up together; running {args.duration} s (no simulator)")
        threads_before = {n: {p.name: thread_figures(p.popen.pid) for p in started[n]} for n in up}
        time.sleep(args.duration)  # the run's length: the programs measure meanwhile
        for n in up:
            record_cpu(folder_of(out_dir, n, repetition), started[n])
            record_threads(folder_of(out_dir, n, repetition), started[n], threads_before[n])
    finally:
        stopped = {n: stop(n, started[n]) for n in names}
    failed = [n for n in names if n not in up or not stopped[n]]
    for n in names:
        progress(f"{n}: {'FAILED' if n in failed else 'done'}")
    return failed


def folder_of(out_dir, name, repetition):
    return os.path.join(out_dir, name, str(repetition))


def reported(configurations, names):
    """What running `names` reports, by name: each configuration that runs on its own, and
    each pair's members as `<pair>/<member>`, their compare_with the member the pair's
    `compare` names (configurations.json, "Paired runs")."""
    out = {}
    for name in names:
        config = configurations[name]
        if "together" not in config:
            out[name] = config
            continue
        for member in config["together"]:
            c = {k: v for k, v in configurations[member].items() if k not in ("compare_with", "beside_only")}
            c["paired_in"] = name
            if member in config.get("compare", {}):
                c["compare_with"] = f"{name}/{config['compare'][member]}"
                if config.get("check_of_pairing"):
                    c["check_of_pairing"] = True
                if config.get("position_check"):
                    check = configurations[config["position_check"]]
                    compared = next(iter(check.get("compare", {})), None)
                    c["position_check"] = f"{config['position_check']}/{compared}"
            out[f"{name}/{member}"] = c
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", required=True, help="the run folder to fill")
    parser.add_argument("--bin", default=os.path.join(ROOT, "build", "bin"), help="where the programs are")
    parser.add_argument("--configurations", default=os.path.join(ROOT, "benchmarks", "wheelchair", "configurations.json"))
    parser.add_argument("--only", default="", help="comma-separated configuration names (default: all)")
    parser.add_argument("--duration", type=float, default=12.0, help="seconds of scenario per configuration")
    parser.add_argument("--scenario", default="", help="the simulator's scenario (default: its own)")
    parser.add_argument("--interface", default="vcan0")
    parser.add_argument("--where", choices=("guest", "host"), default="guest",
                        help="run the configurations meant for this place (their `where`, default guest)")
    parser.add_argument("--repeat", type=int, default=1,
                        help="run the configurations this many times, interleaved (default 1)")
    parser.add_argument("--start-timeout", type=float, default=20.0)
    args = parser.parse_args()

    with open(args.configurations) as f:
        configurations = {k: v for k, v in json.load(f).items() if not k.startswith("_")}
    # By default every configuration but those that run only beside another (in a pair).
    names = [n for n in args.only.split(",") if n] or [n for n, c in configurations.items() if not c.get("beside_only")]
    names = [n for n in names if n not in configurations or configurations[n].get("where", "guest") == args.where]
    if args.repeat < 1:
        parser.error(f"--repeat {args.repeat}: expected 1 or more")
    unknown = [n for n in names if n not in configurations]
    if unknown:
        parser.error(f"unknown configuration {', '.join(unknown)} (known: {', '.join(configurations)})")
    os.makedirs(args.out, exist_ok=True)
    if os.environ.get("VCAN_RUN_IN") in ("uml", "netns"):
        # A network of the run's own: loopback up, with the route LCM's default multicast
        # group needs (DDS on loopback needs lo up as well).
        subprocess.run("ip link set lo up && ip link set lo multicast on && "
                       "ip route replace 239.255.76.67/32 dev lo", shell=True, check=False)
    # run.json collects what ran where, over the guest's and the host's invocation.
    run_file = os.path.join(args.out, "run.json")
    try:
        with open(run_file) as f:
            run = json.load(f)
    except (OSError, ValueError):
        run = {"configurations": {}, "environments": {}}
    every = reported(configurations, names)
    run["configurations"].update(every)
    run["environments"].update({n: os.environ.get("VCAN_RUN_IN", "host") for n in every})
    run.update({"duration_s": args.duration, "scenario": args.scenario, "repetitions": args.repeat})
    with open(run_file, "w") as f:
        json.dump(run, f, indent=1)
    failed = []
    for k in range(1, args.repeat + 1):
        if args.where == "host":
            if names:
                progress(f"repetition {k}/{args.repeat}")
                failed += [f"{n} ({k})" for n in run_together(names, configurations, args, args.out, k)]
            continue
        # Every other repetition runs the configurations in reverse order (A B C, C B A, ...):
        # what drifts over the run then falls on each configuration alike, and each pair of
        # neighbours swaps which of them runs first.
        for i, n in enumerate(names if k % 2 else names[::-1], 1):
            progress(f"repetition {k}/{args.repeat}, configuration {i}/{len(names)}: {n}")
            members = [(m, c, folder_of(args.out, m, k)) for m, c in reported(configurations, [n]).items()]
            if not run_config(members, args):
                failed.append(f"{n} ({k})")
    if failed:
        progress(f"failed: {', '.join(failed)}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
