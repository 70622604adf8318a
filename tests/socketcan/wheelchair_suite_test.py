#!/usr/bin/python3
"""The wheelchair suite's pieces work (benchmarks/wheelchair): not a benchmark, no timing bar.

  wheelchair_suite_test.py check BIN      every configuration's profile passes `polyportd
                                          check` and its programs exist (host, no CAN)
  wheelchair_suite_test.py run BIN        a short run of every guest configuration against
                                          the bus simulator (and of each pair's members at
                                          the same time, each against its own) produces a
                                          full trace in which the controller commanded the
                                          motors and the chair drove; the report turns it
                                          into its JSON and table (in the vcan guest: needs
                                          vcan0 and vcan1)
  wheelchair_suite_test.py host BIN       two short interleaved repetitions of every host
                                          configuration (no CAN) measure Joystick -> Control,
                                          and the report has both and compares them pairwise

Exit 0 when it holds, 1 with the reason otherwise."""
import csv
import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SUITE = os.path.join(ROOT, "benchmarks", "wheelchair")
sys.path.insert(0, SUITE)
import run_configs  # noqa: E402  (reported: what a run reports, pairs' members included)
DURATION_S = 1.5
PERIOD_S = 0.01
# The stick goes forward at 0.2 s, turns at 0.8 s: both inside a short run.
SCENARIO = "0:0:0; 0.2:0:0.6; 0.8:20:0.6"


def configurations():
    with open(os.path.join(SUITE, "configurations.json")) as f:
        return {k: v for k, v in json.load(f).items() if not k.startswith("_")}


def reported(where):
    """What a run of every configuration meant for `where` reports, by name (a pair's
    members as <pair>/<member>)."""
    every = configurations()
    return run_configs.reported(every, [n for n, c in every.items()
                                        if not c.get("beside_only") and c.get("where", "guest") == where])


def check(bin_dir):
    problems = []
    for name, config in configurations().items():
        if "together" in config:
            members = config["together"]
            unknown = [m for m in members if m not in configurations() or "together" in configurations()[m]]
            compared = [m for pair in config.get("compare", {}).items() for m in pair if m not in members]
            if unknown or compared or len(members) < 2:
                problems.append(f"{name}: a pair of {members}: not configurations {unknown}, compared but not members {compared}")
            interfaces = [configurations().get(m, {}).get("interface", "vcan0") for m in members]
            if len(set(interfaces)) != len(interfaces):
                problems.append(f"{name}: its members share a bus ({interfaces})")
            continue
        if config.get("profile"):
            r = subprocess.run([os.path.join(bin_dir, "polyportd"), "check", os.path.join(ROOT, config["profile"])],
                               capture_output=True, text=True)
            if r.returncode != 0:
                problems.append(f"{name}: polyportd check {config['profile']} exited {r.returncode}:\n{r.stdout}{r.stderr}")
        for p in config.get("processes", []):
            program = p["argv"][0].replace("{bin}", bin_dir)
            if not os.access(program, os.X_OK):
                problems.append(f"{name}: program {program} ({p['name']}) is not built")
        if "joystick_to_control" not in config:
            problems.append(f"{name}: says nowhere where Joystick -> Control is measured")
    for p in problems:
        print(p)
    print(f"checked {len(configurations())} configurations: {len(problems)} problems")
    return 1 if problems else 0


def run(bin_dir, where):
    problems = []
    repetitions = 1 if where == "guest" else 2
    every = reported(where)
    with tempfile.TemporaryDirectory() as out:
        r = subprocess.run(["/usr/bin/python3", os.path.join(SUITE, "run_configs.py"), "--out", out, "--bin", bin_dir,
                            "--duration", str(DURATION_S), "--scenario", SCENARIO, "--where", where,
                            "--repeat", str(repetitions)])
        if r.returncode != 0:
            problems.append(f"run_configs.py exited {r.returncode}")
        expected = round(DURATION_S / PERIOD_S)
        for name in every if where == "guest" else []:
            try:
                with open(os.path.join(out, name, "1", "sim_trace.csv")) as f:
                    rows = list(csv.DictReader(f))
            except OSError as e:
                problems.append(f"{name}: no trace ({e})")
                continue
            if len(rows) != expected:
                problems.append(f"{name}: {len(rows)} trace rows, expected {expected}")
                continue
            commanded = sum(int(row["voltage_frames"]) for row in rows)
            speed = float(rows[-1]["left_rad_s"]) + float(rows[-1]["right_rad_s"])
            turn = float(rows[-1]["left_rad_s"]) - float(rows[-1]["right_rad_s"])
            if commanded < expected // 2:
                problems.append(f"{name}: only {commanded} motor-voltage frames in {expected} periods")
            if speed <= 1.0:
                problems.append(f"{name}: the chair did not drive (left + right {speed:.3f} rad/s at the end)")
            if turn <= 0.1:
                problems.append(f"{name}: the chair did not turn right (left - right {turn:.3f} rad/s at the end)")
        # A compared pair reads one clock: each side's arrival stamps (a native program's or
        # polyportd's) with the TSC in the guest, where clock_gettime is a system call of
        # ~15 us that would otherwise lie inside one side's figure only.
        def arrival_clock(name):
            process = every[name]["joystick_to_control"].get("process")
            with open(os.path.join(out, name, "1", (process or "polyportd") + ".json")) as f:
                summary = json.load(f)
            return summary.get("arrival_clock") if process else summary["clock"]["source"]

        for name, config in every.items():
            native = config.get("compare_with")
            if not native:
                continue
            try:
                clocks = arrival_clock(name), arrival_clock(native)
            except (OSError, ValueError, KeyError, TypeError) as e:
                problems.append(f"{name}: the clocks of the comparison with {native} are not in its files ({e!r})")
                continue
            if clocks[0] != clocks[1]:
                problems.append(f"{name} stamps its arrivals with the {clocks[0]} clock, {native} with {clocks[1]}")
        results = os.path.join(out, "results")
        r = subprocess.run(["/usr/bin/python3", os.path.join(SUITE, "report.py"), out, "--results", results, "--no-plots"],
                           capture_output=True, text=True)
        if r.returncode != 0:
            problems.append(f"report.py exited {r.returncode}: {r.stderr}")
        else:
            reports = [f for f in os.listdir(results) if f.endswith(".json")]
            with open(os.path.join(results, reports[0])) as f:
                report = json.load(f)
            for name in every:
                c = report["configurations"].get(name)
                if c is None or (where == "guest" and c["trace_periods"] != expected):
                    problems.append(f"{name}: missing from the report or short")
                elif not (c["joystick_to_control_ns"] or c["polyport_share_ns"] or {}).get("count"):
                    problems.append(f"{name}: no Joystick -> Control latency measured ({c['joystick_to_control_source']})")
                elif c["repetitions"] != repetitions or any(
                        v is None for v in c["joystick_to_control_mean_ns_by_repetition"].values()
                        if c["joystick_to_control_ns"]):
                    problems.append(f"{name}: {c['repetitions']} repetitions in the report, expected {repetitions} "
                                    f"each with its mean ({c['joystick_to_control_mean_ns_by_repetition']})")
                else:
                    # Every program's threads over the scenario: each periodic one woke.
                    config = every[name]
                    expected_processes = {p["name"] for p in config.get("processes", [])}
                    if config.get("profile"):
                        expected_processes.add("polyportd")
                    per_period = c.get("per_period") or {}
                    missing = sorted(expected_processes - set(per_period))
                    asleep = sorted(p for p, f in per_period.items() if f["wakes"] < 0.5)
                    if missing or asleep:
                        problems.append(f"{name}: thread figures missing for {missing}, "
                                        f"fewer than one wake in two periods for {asleep}")
            # A configuration compared with a native one: one difference per repetition.
            for name, config in every.items():
                if not config.get("compare_with"):
                    continue
                bar = next((b for b in report["bars"] if b["bar"].startswith(f"{name} ") and "within" in b["bar"]), None)
                if bar is None or len(bar["by_repetition_ns"]) != repetitions:
                    problems.append(f"{name}: no end-to-end bar over {repetitions} repetitions in the report ({bar})")
                if config.get("position_check"):
                    bar = next((b for b in report["bars"] if b["bar"].startswith(f"{name} ")
                                and "same place in the period" in b["bar"]), None)
                    if bar is None or bar["measured_ns"] is None:
                        problems.append(f"{name}: no bar less {config['position_check']}'s difference in the report ({bar})")
    for p in problems:
        print(p)
    print(f"ran {len(every)} {where} configurations: {len(problems)} problems")
    return 1 if problems else 0


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in ("check", "run", "host"):
        print(__doc__)
        sys.exit(2)
    if sys.argv[1] == "check":
        sys.exit(check(sys.argv[2]))
    sys.exit(run(sys.argv[2], "guest" if sys.argv[1] == "run" else "host"))
