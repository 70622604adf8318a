#!/usr/bin/python3
"""Scrapes polyportd's /metrics, parses it with prometheus_client's own text parser (Debian's
python3-prometheus-client) and compares each connection's latency histogram with the stats
JSON taken at the same quiet moment (polyportctl --json stats).

Usage: check_metrics.py URL STATS_JSON
Prints one JSON object (what was compared) and exits 0 when everything matched, 1 when
something did not (each mismatch printed on stderr), 2 when the endpoint could not be read.
"""
import json
import math
import sys
import urllib.request

from prometheus_client.parser import text_string_to_metric_families


def main():
    url, stats_file = sys.argv[1], sys.argv[2]
    try:
        with urllib.request.urlopen(url, timeout=10) as response:
            content_type = response.headers.get("Content-Type", "")
            text = response.read().decode("utf-8")
    except OSError as error:
        print(f"cannot read {url}: {error}", file=sys.stderr)
        return 2
    with open(stats_file) as f:
        stats = json.load(f)

    problems = []
    if not content_type.startswith("text/plain"):
        problems.append(f"Content-Type {content_type!r}, not text/plain")
    families = {family.name: family for family in text_string_to_metric_families(text)}

    # Each connection's histogram: buckets cumulative, +Inf == _count.
    histograms = {}
    latency = families.get("polyport_connection_latency_seconds")
    if latency is None or latency.type != "histogram":
        problems.append("no histogram polyport_connection_latency_seconds")
    else:
        for sample in latency.samples:
            entry = histograms.setdefault(sample.labels["connection"], {"buckets": []})
            if sample.name.endswith("_bucket"):
                entry["buckets"].append((float(sample.labels["le"]), sample.value))
            elif sample.name.endswith("_count"):
                entry["count"] = sample.value
            elif sample.name.endswith("_sum"):
                entry["sum"] = sample.value
    for name, entry in histograms.items():
        buckets = sorted(entry["buckets"])
        counts = [value for _, value in buckets]
        if counts != sorted(counts):
            problems.append(f"{name}: buckets not cumulative: {buckets}")
        if not buckets or not math.isinf(buckets[-1][0]) or buckets[-1][1] != entry.get("count"):
            problems.append(f"{name}: +Inf bucket {buckets[-1:]} != _count {entry.get('count')}")

    compared = []
    for connection in stats["connections"]:
        if connection.get("removed"):
            continue
        name = connection["name"]
        want = connection["latency_ns"]["count"]
        got = histograms.get(name, {}).get("count")
        compared.append({"connection": name, "stats_count": want, "metrics_count": got})
        if got != want:
            problems.append(f"{name}: _count {got} != stats latency count {want}")
        delivered = families.get("polyport_connection_delivered")
        got_delivered = None
        if delivered is not None:
            for sample in delivered.samples:
                if sample.labels.get("connection") == name and sample.name.endswith("_total"):
                    got_delivered = sample.value
        if got_delivered != connection["delivered"]:
            problems.append(f"{name}: delivered_total {got_delivered} != stats {connection['delivered']}")

    # One state gauge at 1 per component, the one the stats name.
    states = families.get("polyport_component_state")
    for component in stats["components"]:
        current = [s.labels["state"] for s in (states.samples if states else [])
                   if s.labels.get("component") == component["name"] and s.value == 1]
        if current != [component["state"]]:
            problems.append(f"{component['name']}: state gauge {current} != stats {component['state']}")

    print(json.dumps({"families": sorted(families), "compared": compared}))
    for problem in problems:
        print(problem, file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
