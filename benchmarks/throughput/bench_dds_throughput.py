#!/usr/bin/python3
"""DDS forwarding throughput on one core (benchmarks/throughput/README.md): Cyclone DDS's own
`ddsperf` publishes its "OU" topic (a 4-byte sequence number) on domain 60, polyportd bridges
it to domain 61, and a second `ddsperf` subscribes there and counts what it gets and what it
lost. polyportd runs alone on CPU 1, both ddsperf processes on CPU 0. Cases:

  passthrough   Cyclone -> Cyclone, the same type: the serialized sample is written as it came
  converting    the same with a <mapping> on the connection: XCDR1 -> flat -> map -> XCDR1

Each case runs at every publish rate asked (--rates, "inf" = as fast as ddsperf can), and
reports over a measuring window: samples polyport forwarded per second, polyportd's CPU time
per forwarded sample (utime + stime of the whole process: Cyclone's receive thread, the
forwarding, the write), the implied samples per second of one fully busy core (1e9 / that),
the subscriber's rate and loss (ddsperf's sequence gaps), polyport's in-to-out p50 / p99.

Usage: bench_dds_throughput.py --polyportd P --out-dir DIR [--rates 10kHz,50kHz,inf]
       [--window-s 5] [--warmup-s 2]
Run it through scripts/bench_throughput.sh (a private network namespace, root).
"""
import argparse
import datetime
import json
import os
import platform
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.realpath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "benchmarks", "common"))
from bench_results import write_results  # noqa: E402
TICKS = os.sysconf("SC_CLK_TCK")
DOMAIN_IN, DOMAIN_OUT = 60, 61


def component(folder, name, domain, usage):
    with open(os.path.join(folder, f"{name}.xml"), "w") as f:
        f.write(f'<?xml version="1.0"?>\n<component_profile><name>{name}</name><model>cyclonedds</model>\n'
                f"  <dds><domain>{domain}</domain><qos><reliability>reliable</reliability><history>keep_all</history></qos></dds>\n"
                f"  <types><file>{os.path.join(HERE, 'ddsperf_types.idl')}</file></types>\n"
                f"  <ports><data_port><name>ou</name><data_type>OneULong</data_type><usage>{usage}</usage>"
                f"<topic>DDSPerfRDataOU</topic></data_port></ports>\n</component_profile>\n")


def application(folder, converting):
    component(folder, "PerfIn", DOMAIN_IN, "output")
    component(folder, "PerfOut", DOMAIN_OUT, "input")
    mapping = '<mapping><field target="seq" source="seq"/></mapping>' if converting else ""
    path = os.path.join(folder, "app.xml")
    with open(path, "w") as f:
        f.write('<?xml version="1.0"?>\n<application_profile><name>dds_throughput</name>\n  <subcomponents>\n'
                "    <subcomponent><name>in</name><reference>PerfIn.xml</reference></subcomponent>\n"
                "    <subcomponent><name>out</name><reference>PerfOut.xml</reference></subcomponent>\n"
                '  </subcomponents>\n  <port_connections><port_connection port_type="data">'
                '<source component_name="in" port_name="ou"/><target component_name="out" port_name="ou"/>'
                f"{mapping}</port_connection></port_connections>\n</application_profile>\n")
    return path


def cpu_seconds(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS


def connection(ctl, socket):
    out = subprocess.run([ctl, "--socket", socket, "--json", "stats"], check=True, capture_output=True, text=True).stdout
    return json.loads(out)["connections"][0]


def ddsperf(args, cpu, log):
    env = dict(os.environ, CYCLONEDDS_URI="file://" + os.path.join(ROOT, "config", "cyclonedds-loopback.xml"))
    return subprocess.Popen(["taskset", "-c", str(cpu), "ddsperf"] + args, stdout=log, stderr=subprocess.STDOUT, env=env)


def stop(process):
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(20)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def run_case(args, case, rate, work):
    folder = os.path.join(work, f"{case}-{rate}")
    os.makedirs(folder)
    app = application(folder, case == "converting")
    socket = os.path.join(folder, "admin.sock")
    daemon_log = open(os.path.join(folder, "polyportd.log"), "w+")
    daemon = subprocess.Popen(["taskset", "-c", "1", args.polyportd, "run", app, "--admin-socket", socket,
                               "--stats-interval", "0"], stdout=daemon_log, stderr=daemon_log)
    sub_log = open(os.path.join(folder, "sub.log"), "w+")
    pub_log = open(os.path.join(folder, "pub.log"), "w+")
    sub = pub = None
    try:
        t0 = time.monotonic()
        while not os.path.exists(socket):
            if daemon.poll() is not None or time.monotonic() - t0 > 30:
                daemon_log.seek(0)
                sys.exit(f"bench_dds_throughput: polyportd did not start:\n{daemon_log.read()}")
            time.sleep(0.05)
        sub = ddsperf(["-i", str(DOMAIN_OUT), "-T", "OU", "sub"], 0, sub_log)
        time.sleep(1)
        pub = ddsperf(["-i", str(DOMAIN_IN), "-T", "OU", "pub", rate], 0, pub_log)
        time.sleep(args.warmup_s)
        c0, s0, t_start = cpu_seconds(daemon.pid), connection(args.polyportctl, socket)["delivered"], time.monotonic()
        time.sleep(args.window_s)
        c1, last, t_end = cpu_seconds(daemon.pid), connection(args.polyportctl, socket), time.monotonic()
    finally:
        for p in (pub, sub):
            if p is not None:
                stop(p)
        stop(daemon)
    forwarded = last["delivered"] - s0
    seconds = t_end - t_start
    cpu_ns = (c1 - c0) * 1e9 / forwarded if forwarded else None
    sub_log.seek(0)
    totals = re.findall(r"total (\d+) lost (\d+)", sub_log.read())
    received, lost = (int(totals[-1][0]), int(totals[-1][1])) if totals else (0, 0)
    return {"case": case, "publish_rate": rate, "window_s": seconds, "forwarded_per_s": forwarded / seconds,
            "cpu_busy": (c1 - c0) / seconds, "cpu_ns_per_sample": cpu_ns,
            "one_core_samples_per_s": 1e9 / cpu_ns if cpu_ns else None, "conversion": last.get("conversion"),
            "in_to_out_ns": {k: last["latency_ns"][k] for k in ("p50", "p99")},
            "dropped": last.get("dropped"), "subscriber_received": received, "subscriber_lost": lost}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--polyportd", required=True)
    parser.add_argument("--polyportctl", required=True)
    parser.add_argument("--out-dir", required=True)
    parser.add_argument("--rates", default="10kHz,50kHz,inf")
    parser.add_argument("--window-s", type=float, default=5)
    parser.add_argument("--warmup-s", type=float, default=2)
    args = parser.parse_args()
    if not shutil.which("ddsperf"):
        sys.exit("bench_dds_throughput: ddsperf not found (Debian cyclonedds-tools; scripts/setup.sh installs it)")
    if os.cpu_count() < 2:
        sys.exit("bench_dds_throughput: needs two CPUs (polyportd on one, the ddsperf peers on the other)")
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    result = {"benchmark": "dds_throughput", "date": stamp, "host": platform.node(), "cpus": os.cpu_count(),
              "revision": os.environ.get("POLYPORT_GIT_REVISION", "unknown"), "runs": []}
    work = tempfile.mkdtemp(prefix="polyport-throughput-")
    try:
        for case in ("passthrough", "converting"):
            for rate in args.rates.split(","):
                print(f"throughput: {case} at {rate} ...", flush=True)
                r = run_case(args, case, rate, work)
                result["runs"].append(r)
                print(f"throughput: {case} at {rate}: {r['forwarded_per_s']:.0f}/s forwarded, "
                      f"{r['cpu_ns_per_sample'] or 0:.0f} CPU ns per sample", flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    rows = [f"DDS forwarding throughput {stamp}, {result['host']}, {result['cpus']} CPUs, revision {result['revision']}: "
            "ddsperf pub (OU) -> polyportd on CPU 1 -> ddsperf sub, both ddsperf on CPU 0", "",
            "| case | publish rate | forwarded / s | polyportd CPU busy | CPU ns / sample | one core: samples / s | "
            "in-to-out p50 / p99 ns | subscriber received / lost |", "|---|---|---|---|---|---|---|---|"]
    for r in result["runs"]:
        rows.append(f"| {r['case']} ({r['conversion']}) | {r['publish_rate']} | {r['forwarded_per_s']:.0f} | "
                    f"{100 * r['cpu_busy']:.0f} % | {r['cpu_ns_per_sample'] or 0:.0f} | "
                    f"{r['one_core_samples_per_s'] or 0:.0f} | {r['in_to_out_ns']['p50']} / {r['in_to_out_ns']['p99']} | "
                    f"{r['subscriber_received']} / {r['subscriber_lost']} |")
    text = "\n".join(rows) + "\n"
    path = write_results(args.out_dir, "dds_throughput", stamp, result, text)
    print(text)
    print(f"written {path}.json and {path}.md")


if __name__ == "__main__":
    main()
