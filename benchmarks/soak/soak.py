#!/usr/bin/python3
"""The soak (benchmarks/soak/README.md): two polyportd processes forward SOURCES x 100 Hz
(default 100 paths, 10 kHz) for a given duration:

  sender    in-process sources (scale benchmark components, 10 ms) -> in-process sinks, and
            -> Cyclone DDS topics, Fast DDS topics and LCM channels (one each per path)
  receiver  the same topics and channels -> in-process sinks

Each sink counts the gaps in its samples' sequence numbers (`missed`, traced on change): on
reliable paths (in-process, DDS reliable / keep_all) that is loss, and must stay 0. LCM (UDP
multicast) is best effort: its loss is reported, not judged. Every interval: both daemons'
RSS, samples delivered per kind of path, and in-to-out latency percentiles per kind (from the
interval's Prometheus histogram buckets: bucket upper bounds).

Usage: soak.py --polyportd P --out-dir DIR [--duration-s 600] [--interval-s 60]
       [--paths inproc=40,cyclonedds=20,fastdds=20,lcm=20] [--period-ms 10]
Run it through scripts/soak.sh (a private network namespace with a multicast route for LCM).
Writes DIR/soak-<stamp>.json and .md, and prints progress and the table.
"""
import argparse
import datetime
import importlib.util
import json
import os
import platform
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
KINDS = ("inproc", "cyclonedds", "fastdds", "lcm")
RELIABLE = ("inproc", "cyclonedds", "fastdds")

spec = importlib.util.spec_from_file_location("gen_scale_profile", os.path.join(ROOT, "scripts", "gen_scale_profile.py"))
gen_scale_profile = importlib.util.module_from_spec(spec)
spec.loader.exec_module(gen_scale_profile)

FOREIGN = {
    "cyclonedds": ("SoakCyclone", "cyclonedds",
                   "<dds><domain>42</domain><qos><reliability>reliable</reliability><history>keep_all</history></qos></dds>",
                   "topic", "soak/cyclonedds/{i}", "scale::Sample64", "scale.idl"),
    "fastdds": ("SoakFastdds", "fastdds",
                "<dds><domain>43</domain><qos><reliability>reliable</reliability><history>keep_all</history></qos></dds>",
                "topic", "soak/fastdds/{i}", "scale::Sample64", "scale.idl"),
    "lcm": ("SoakLcm", "lcm", "<lcm><url>udpm://239.255.76.67:7667?ttl=0</url></lcm>", "channel", "SOAK_{i}",
            "soak::sample64_t", "soak.lcm"),
}


def foreign_component(folder, kind, side, paths):
    """The sender's (ports written by polyport: input) or receiver's (output) foreign component."""
    name, model, section, wire, pattern, data_type, types = FOREIGN[kind]
    usage = "input" if side == "sender" else "output"
    type_dir = os.path.join(ROOT, "benchmarks", "scale" if types == "scale.idl" else "soak")
    ports = "".join(f"    <data_port><name>p{i}</name><data_type>{data_type}</data_type><usage>{usage}</usage>"
                    f"<{wire}>{pattern.format(i=i)}</{wire}></data_port>\n" for i in paths)
    with open(os.path.join(folder, f"{name}.xml"), "w") as f:
        f.write(f'<?xml version="1.0" encoding="UTF-8"?>\n<component_profile>\n  <name>{name}</name>\n'
                f"  <model>{model}</model>\n  {section}\n  <types><file>{os.path.join(type_dir, types)}</file></types>\n"
                f"  <ports>\n{ports}  </ports>\n</component_profile>\n")
    return name


def application(folder, side, plan, period_ms):
    """Writes SIDE's app.xml into FOLDER; returns (path, traced sink ports, {connection name: kind})."""
    gen_scale_profile.write_component_profiles(folder, period_ms)
    subs, conns, traced, kinds = [], [], [], {}

    def connect(src, dst, kind):
        # LCM has no unsigned integers: the sequence numbers cross as int64 (never near 2^63).
        mapping = ('\n      <mapping><field target="seq" source="seq" allow_narrowing="true"/>'
                   '<field target="stamp_ns" source="stamp_ns" allow_narrowing="true"/></mapping>') if kind == "lcm" else ""
        conns.append(f'    <port_connection port_type="data" policy="buffer" depth="64">\n'
                     f'      <source component_name="{src[0]}" port_name="{src[1]}"/>\n'
                     f'      <target component_name="{dst[0]}" port_name="{dst[1]}"/>{mapping}\n    </port_connection>')
        kinds[f"{src[0]}.{src[1]} -> {dst[0]}.{dst[1]}"] = kind

    for kind, paths in plan.items():
        if not paths:
            continue
        if kind == "inproc":
            if side == "receiver":
                continue
            for i in paths:
                subs += [("src%03d" % i, "ScaleSource.xml"), ("sink%03d" % i, "ScaleSink.xml")]
                connect(("src%03d" % i, "out"), ("sink%03d" % i, "in"), kind)
                traced.append(("sink%03d" % i, kind))
            continue
        name = foreign_component(folder, kind, side, paths)
        subs.append((name, f"{name}.xml"))
        for i in paths:
            if side == "sender":
                subs.append(("src%03d" % i, "ScaleSource.xml"))
                connect(("src%03d" % i, "out"), (name, f"p{i}"), kind)
            else:
                subs.append(("sink%03d" % i, "ScaleSink.xml"))
                connect((name, f"p{i}"), ("sink%03d" % i, "in"), kind)
                traced.append(("sink%03d" % i, kind))
    lines = ['<?xml version="1.0" encoding="UTF-8"?>', f"<!-- the soak's {side}, made by benchmarks/soak/soak.py -->",
             "<application_profile>", f"  <name>soak_{side}</name>", "  <subcomponents>"]
    lines += [f"    <subcomponent><name>{n}</name><reference>{r}</reference></subcomponent>" for n, r in subs]
    lines += ["  </subcomponents>", "  <port_connections>"] + conns + ["  </port_connections>", "</application_profile>", ""]
    path = os.path.join(folder, "app.xml")
    with open(path, "w") as f:
        f.write("\n".join(lines))
    return path, traced, kinds


def rss_kib(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def scrape(port):
    """{connection: (delivered, [(le, cumulative count)])} from a daemon's /metrics."""
    from prometheus_client.parser import text_string_to_metric_families
    text = urllib.request.urlopen(f"http://127.0.0.1:{port}/metrics", timeout=10).read().decode()
    out = {}
    for family in text_string_to_metric_families(text):
        for s in family.samples:
            c = s.labels.get("connection")
            if c is None:
                continue
            entry = out.setdefault(c, [0, []])
            if s.name == "polyport_connection_delivered_total":
                entry[0] = s.value
            elif s.name == "polyport_connection_latency_seconds_bucket":
                entry[1].append((float(s.labels["le"]), s.value))
    for entry in out.values():
        entry[1].sort()
    return out


def percentile(buckets, q):
    """The upper bound (ns) of the bucket holding quantile Q of a cumulative bucket list."""
    total = buckets[-1][1] if buckets else 0
    if total <= 0:
        return None
    for le, count in buckets:
        if count >= q * total:
            return None if le == float("inf") else round(le * 1e9)
    return None


class Daemon:
    def __init__(self, polyportd, side, app, traced, work):
        self.side, self.port = side, free_port()
        self.trace = os.path.join(work, f"{side}-trace.jsonl")
        self.log_path = os.path.join(work, f"{side}.log")
        self.log = open(self.log_path, "w")
        command = [polyportd, "run", app, "--admin-socket", "none", "--stats-interval", "0", "--metrics-port",
                   str(self.port), "--stats-json", os.path.join(work, f"{side}-stats.json"), "--trace-file", self.trace]
        for sink, _ in traced:
            command += ["--trace", f"{sink}.missed"]
        self.process = subprocess.Popen(command, stdout=self.log, stderr=self.log)

    def wait_running(self):
        t0 = time.monotonic()
        while " running " not in open(self.log_path).read():
            if self.process.poll() is not None or time.monotonic() - t0 > 120:
                sys.exit(f"soak: the {self.side} did not run:\n{open(self.log_path).read()[-3000:]}")
            time.sleep(0.1)

    def stop(self):
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                self.process.wait(60)
            except subprocess.TimeoutExpired:
                self.process.kill()
        self.log.close()
        return self.process.returncode


def missed(trace_file, traced):
    """The last `missed` value each traced sink wrote (none written: 0), summed per kind."""
    last = {}
    if os.path.exists(trace_file):
        with open(trace_file) as f:
            for line in f:
                try:
                    record = json.loads(line)
                except json.JSONDecodeError:
                    continue
                last[record.get("port")] = record.get("value")
    out = {}
    for sink, kind in traced:
        value = last.get(f"{sink}.missed", 0)
        out[kind] = out.get(kind, 0) + (value if isinstance(value, (int, float)) else 0)
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--polyportd", required=True)
    parser.add_argument("--out-dir", required=True)
    parser.add_argument("--duration-s", type=float, default=600)
    parser.add_argument("--interval-s", type=float, default=60)
    parser.add_argument("--paths", default="inproc=40,cyclonedds=20,fastdds=20,lcm=20")
    parser.add_argument("--period-ms", type=float, default=10.0)
    args = parser.parse_args()
    counts = dict(item.split("=") for item in args.paths.split(","))
    if set(counts) - set(KINDS):
        sys.exit(f"soak: unknown kind in --paths (known: {', '.join(KINDS)})")
    plan, next_index = {}, 0
    for kind in KINDS:
        n = int(counts.get(kind, 0))
        plan[kind] = list(range(next_index, next_index + n))
        next_index += n
    rate = next_index * 1000.0 / args.period_ms
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    result = {"benchmark": "soak", "date": stamp, "host": platform.node(), "kernel": platform.release(),
              "cpus": os.cpu_count(), "revision": os.environ.get("POLYPORT_GIT_REVISION", "unknown"),
              "paths": {k: len(v) for k, v in plan.items()}, "samples_per_s": rate, "duration_s": args.duration_s,
              "interval_s": args.interval_s, "intervals": []}
    work = tempfile.mkdtemp(prefix="polyport-soak-")
    daemons = []
    try:
        apps = {}
        for side in ("receiver", "sender"):
            folder = os.path.join(work, side)
            os.makedirs(folder)
            apps[side] = application(folder, side, plan, args.period_ms)
        receiver = Daemon(args.polyportd, "receiver", apps["receiver"][0], apps["receiver"][1], work)
        daemons.append(receiver)
        receiver.wait_running()
        sender = Daemon(args.polyportd, "sender", apps["sender"][0], apps["sender"][1], work)
        daemons.append(sender)
        sender.wait_running()
        kinds = {**{("sender", c): k for c, k in apps["sender"][2].items()},
                 **{("receiver", c): k for c, k in apps["receiver"][2].items()}}
        print(f"soak: {next_index} paths ({', '.join(f'{k} {len(v)}' for k, v in plan.items())}), "
              f"{rate:.0f} samples/s, {args.duration_s:g} s", flush=True)
        t0 = time.monotonic()
        previous = {d.side: scrape(d.port) for d in daemons}
        while time.monotonic() - t0 < args.duration_s:
            time.sleep(min(args.interval_s, args.duration_s - (time.monotonic() - t0)))
            for d in daemons:
                if d.process.poll() is not None:
                    sys.exit(f"soak: the {d.side} ended:\n{open(d.log_path).read()[-3000:]}")
            now = {d.side: scrape(d.port) for d in daemons}
            interval = {"t_s": round(time.monotonic() - t0, 1),
                        "rss_kib": {d.side: rss_kib(d.process.pid) for d in daemons}, "kinds": {}}
            for (side, connection), kind in kinds.items():
                key = f"{kind} {side}"
                delivered, buckets = now[side].get(connection, (0, []))
                before = previous[side].get(connection, (0, []))
                old = dict(before[1])
                entry = interval["kinds"].setdefault(key, {"delivered": 0, "buckets": {}})
                entry["delivered"] += delivered - before[0]
                for le, count in buckets:
                    entry["buckets"][le] = entry["buckets"].get(le, 0) + count - old.get(le, 0)
            for entry in interval["kinds"].values():
                b = sorted(entry.pop("buckets").items())
                entry["latency_ns_p50"], entry["latency_ns_p99"] = percentile(b, 0.5), percentile(b, 0.99)
            result["intervals"].append(interval)
            previous = now
            print(f"soak: {interval['t_s']:.0f} s: RSS sender {interval['rss_kib']['sender'] / 1024:.1f} MiB, receiver "
                  f"{interval['rss_kib']['receiver'] / 1024:.1f} MiB; delivered "
                  + ", ".join(f"{k} {v['delivered']:.0f}" for k, v in sorted(interval["kinds"].items())), flush=True)
    finally:
        codes = {d.side: d.stop() for d in reversed(daemons)}
    result["exit_codes"] = codes
    loss = {}
    for d in daemons:
        for kind, value in missed(d.trace, apps[d.side][1]).items():
            loss[kind] = loss.get(kind, 0) + value
    result["missed"] = loss
    result["reliable_loss"] = sum(loss.get(k, 0) for k in RELIABLE)
    for side in ("sender", "receiver"):
        with open(os.path.join(work, f"{side}-stats.json")) as f:
            stats = json.load(f)
        result[f"{side}_dropped"] = sum(c.get("dropped", 0) for c in stats["connections"])
        result[f"{side}_overruns"] = sum(e.get("overruns", 0) for e in stats.get("execution_contexts", []))
    first = result["intervals"][0]["rss_kib"] if result["intervals"] else {}
    last = result["intervals"][-1]["rss_kib"] if result["intervals"] else {}
    result["rss_growth_after_first_interval_kib"] = {s: last[s] - first[s] for s in first}
    shutil.rmtree(work, ignore_errors=True)

    rows = [f"Soak {stamp}, {result['host']}, {result['cpus']} CPUs, revision {result['revision']}: "
            f"{next_index} paths, {rate:.0f} samples/s, {args.duration_s:g} s", "",
            "| t (s) | RSS sender / receiver (MiB) | " + " | ".join(
                f"{k}: delivered, p50 / p99 ns" for k in sorted(result["intervals"][0]["kinds"])) + " |",
            "|---|---|" + "---|" * len(result["intervals"][0]["kinds"])] if result["intervals"] else []
    for iv in result["intervals"]:
        rows.append(f"| {iv['t_s']:.0f} | {iv['rss_kib']['sender'] / 1024:.1f} / {iv['rss_kib']['receiver'] / 1024:.1f} | "
                    + " | ".join(f"{v['delivered']:.0f}, {v['latency_ns_p50']} / {v['latency_ns_p99']}"
                                 for _, v in sorted(iv["kinds"].items())) + " |")
    rows += ["", f"missed (sequence gaps) per kind: {loss}; on reliable paths: {result['reliable_loss']}",
             f"connections' drops: sender {result['sender_dropped']}, receiver {result['receiver_dropped']}; overruns: "
             f"sender {result['sender_overruns']}, receiver {result['receiver_overruns']}",
             f"RSS growth after the first interval (KiB): {result['rss_growth_after_first_interval_kib']}",
             f"exit codes: {codes}"]
    text = "\n".join(rows) + "\n"
    path = write_results(args.out_dir, "soak", stamp, result, text)
    print(text)
    print(f"written {path}.json and {path}.md")
    return 0 if result["reliable_loss"] == 0 and all(c == 0 for c in codes.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
