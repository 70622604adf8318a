#!/usr/bin/python3
"""The cross-model matrix's CAN pairs work (benchmarks/matrix): not a benchmark, no timing bar.
Runs inside scripts/vcan-run (label vm); needs the benchmark build (the ping-pong programs and
the relays).

  can_pairs_test.py relays BIN   each native relay (relay_can_cyclone, relay_can_fastdds,
                                 relay_can_lcm) carries a short ping-pong both ways: a CAN ping
                                 to the model's pong and back, and the model's ping to a CAN
                                 pong and back, in classic and in FD frames (needs vcan0 and
                                 vcan1 with the FD MTU)
  can_pairs_test.py matrix BIN   a short run of bench_matrix's CAN part (--pairs can: every CAN
                                 pair, in-process included, and every program model's diagonal,
                                 both size classes) measures every series of every CAN case in
                                 full (each ping matches its echoes' sequence numbers, probes
                                 included), and every CAN case's generated profile passes
                                 `polyportd check` (needs vcan0..44, FD MTU)

Exit 0 when it holds, 1 with the reason otherwise."""
import json
import os
import signal
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ROUNDS = 20
WARMUP = 5
LCM_GROUP = "239.255.76.67"
# program name, model name as the relays and bench_matrix say it, a domain (DDS) or port (LCM)
MODELS = [("cyclone", "cyclonedds", 7), ("fastdds", "fastdds", 8), ("lcm", "lcm", 7711)]


def environment():
    env = dict(os.environ)
    env["CYCLONEDDS_URI"] = "file://" + os.path.join(ROOT, "config", "cyclonedds-loopback.xml")
    env["FASTRTPS_DEFAULT_PROFILES_FILE"] = os.path.join(ROOT, "config", "fastdds-loopback.xml")
    return env


def loopback_route():
    """LCM's group on the guest's loopback (the guest's network is the test's own)."""
    subprocess.run("ip link set lo up && ip link set lo multicast on && ip route replace %s/32 dev lo" % LCM_GROUP,
                   shell=True, check=True)


def ping_pong(label, ping, background, problems):
    """Starts `background` (a pong and a relay), runs `ping` to its end, stops them."""
    env = environment()
    started = [subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
               for argv in background]
    try:
        r = subprocess.run(ping, env=env, capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        problems.append(f"{label}: the ping did not end within 60 s")
        return
    finally:
        for p in started:
            p.send_signal(signal.SIGTERM)
        for p in started:
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
    if r.returncode != 0:
        problems.append(f"{label}: the ping exited {r.returncode}: {r.stderr.strip()[-500:]}")
        return
    report = json.loads(r.stdout.strip().splitlines()[-1])
    got = report.get("rtt_ns", {}).get("n")
    if got != ROUNDS:
        problems.append(f"{label}: the ping reports {got} round trips, expected {ROUNDS}: {r.stdout.strip()[-300:]}")
    else:
        print(f"{label}: {ROUNDS} round trips")


def relays(bin_dir):
    loopback_route()
    b = lambda name: os.path.join(bin_dir, name)
    problems = []
    # Each size class: the other model's type, and CAN's frame (classic, FD).
    for size, frame in (("16", "8"), ("1024", "64")):
        can_ping = [b("pingpong_can"), "ping", "0", frame, str(ROUNDS), str(WARMUP)]
        for program, model, domain in MODELS:
            relay = b("relay_can_" + program)
            other = b("pingpong_" + program)
            # CAN ping on vcan0 -> relay -> the model's pong, and back.
            ping_pong(f"CAN -> {model}, {frame} B frames", can_ping,
                      [[other, "pong", str(domain), size], [relay, "can", "0", str(domain), size]], problems)
            # The model's ping -> relay -> CAN pong on vcan1, and back.
            ping_pong(f"{model} -> CAN, {frame} B frames", [other, "ping", str(domain + 1), size, str(ROUNDS), str(WARMUP)],
                      [[b("pingpong_can"), "pong", "1", frame], [relay, model, str(domain + 1), "1", size]], problems)
    for p in problems:
        print(p)
    return 1 if problems else 0


def matrix(bin_dir):
    problems = []
    with tempfile.TemporaryDirectory() as keep:
        out = os.path.join(keep, "matrix.json")
        r = subprocess.run([os.path.join(bin_dir, "bench_matrix"), out, str(ROUNDS), str(WARMUP), "--chunks", "1",
                            "--models", "can,cyclonedds,fastdds,lcm,inprocess", "--pairs", "can", "--sizes", "16,1024",
                            "--placements", "unpinned", "--domain-base", "100", "--keep", keep])
        if not os.path.exists(out):
            print(f"bench_matrix wrote no result (exited {r.returncode})")
            return 1
        with open(out) as f:
            result = json.load(f)
        cases = [c for c in result["cases"] if "can" in (c["from"], c["to"])]
        if len(cases) != 18:
            problems.append(f"{len(cases)} CAN cases, expected 18 (CAN -> 4 models, 4 models -> CAN, CAN -> CAN; "
                            "two sizes)")
        for c in cases:
            label = f"{c['from']} -> {c['to']} {c['size_bytes']} B"
            # An in-process end has no native relay: its series beside via is CAN's direct one.
            inprocess = "inprocess" in (c["from"], c["to"])
            series = ["via_polyport"] + ([] if inprocess else ["via_native_relay"]) + (
                ["direct"] if c["from"] == c["to"] or inprocess else [])
            for s in series:
                got = c.get(s, {}).get("one_way_ns", {}).get("n")
                if got != ROUNDS:
                    problems.append(f"{label}: {s} measured {got} round trips, expected {ROUNDS}: "
                                    f"{c.get(s, {}).get('error', '')}")
            if "polyport_error" in c:
                problems.append(f"{label}: {c['polyport_error']}")
            if "targets" not in c:
                problems.append(f"{label}: no bars computed")
            case_dir = os.path.join(keep, f"{c['placement']}-{c['from']}-{c['to']}-{c['size_bytes']}")
            # The in-process ping's series: a polyportd run per chunk, each with its profile.
            app = os.path.join(case_dir, "chunk-0" if c["from"] == "inprocess" else "", "app.xml")
            check = subprocess.run([os.path.join(bin_dir, "polyportd"), "check", app], capture_output=True, text=True)
            if check.returncode != 0:
                problems.append(f"{label}: polyportd check {app} exited {check.returncode}:\n{check.stdout}{check.stderr}")
        if r.returncode != 0 and not problems:
            problems.append(f"bench_matrix exited {r.returncode}")
    for p in problems:
        print(p)
    print(f"checked {len(cases)} CAN cases: {len(problems)} problems")
    return 1 if problems else 0


def main():
    if len(sys.argv) != 3 or sys.argv[1] not in ("relays", "matrix"):
        print(__doc__)
        return 2
    return relays(sys.argv[2]) if sys.argv[1] == "relays" else matrix(sys.argv[2])


if __name__ == "__main__":
    sys.exit(main())
