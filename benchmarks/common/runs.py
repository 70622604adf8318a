#!/usr/bin/python3
"""Verdicts over several whole runs of one ping-pong benchmark (lcm, can, dds, matrix).

One run's paired chunks (runner.hpp, paired_chunks) decide a bar only for what moves between
the chunks of that run; what a case's start fixes for all of its chunks (where the scheduler
put the pong, the relay and polyportd, which pool slots they got) stays the same inside the
run and differs from run to run. Runs are independent starts, so the runs' own figures are the
samples that cover it: per case, one value per run, and the sign test's interval for their
median, as paired_chunks computes it over chunks.

  runs.py [--out PREFIX] RESULT.json...
    RESULT.json  results of one benchmark (its "benchmark" field), each a whole run
    --out        also write PREFIX.json (every figure and verdict) and PREFIX.md (the table)

Per case (placement, vendor or pair, size) and run:
  via - relay  the run's paired chunks' median (via p50 - relay p50, chunks side by side;
               from the series' chunk figures in results that predate it), or its series'
               medians' difference where the run has no chunk figures
  CPU          polyportd's CPU time per round trip - the relay's
  all CPU      the same of all processes of the path (ping, middle, pong)
  round trip   the mean round trip via polyport - via the relay: where one CPU runs the whole
               path (the one-CPU vcan guest, the one-core placement) a round trip costs the CPU
               time of its processes, and the ends are the same programs on both paths, so
               this is the middle's extra CPU per round trip, read from a clock that does not
               tick (the guest charges CPU time in 10 ms ticks)
  in-to-out    polyport's own in-to-out p99, the worst connection
Verdicts on the runs' median: via - relay <= +2 us, CPU <= 0, holds / misses / undecided as
paired_chunks says it, but only at 95 % confidence or more (six runs and up); in-to-out p99
<= 1 us in every run.

Exit 0 with the table, 2 when the files cannot be read or are not one benchmark's."""
import json
import math
import sys

ALLOWANCE_NS = 2000
# Below this the runs decide nothing: the sign test reaches 96.9 % with 6 runs, 93.8 % with 5.
MIN_CONFIDENCE = 0.95
SUMMARY_SUFFIX = "_runs"  # the benchmark name of what this writes
IN_TO_OUT_BAR_NS = 1000
KEY_FIELDS = ("placement", "vendor", "from", "to", "size_bytes")


def sign_interval(values, allowance):
    """The median of `values`, the sign test's interval for it and the verdict against
    `allowance` (the rule of runner.cpp's paired_chunks): d_(k) .. d_(n+1-k) of the sorted
    values, k the largest with 2 P(Bin(n, 1/2) < k) <= 5 %, or k = 1 below six values, where
    the confidence is 1 - 2^(1-n). Unlike one run's chunks, a verdict over runs is given only at
    95 % or more: with fewer runs it is "undecided" and "why" says what the interval would say.
    None without values."""
    d = sorted(values)
    n = len(d)
    if n == 0:
        return None
    tail = []  # P(Bin(n, 1/2) <= j)
    total = 0.0
    for j in range(n + 1):
        total += math.comb(n, j) / 2 ** n
        tail.append(total)
    k = 1
    while k + 1 <= (n + 1) // 2 and 2 * tail[k] <= 0.05:
        k += 1
    low, high = d[k - 1], d[n - k]
    median = median_of(d)
    confidence = 1 - 2 * tail[k - 1]
    verdict = "holds" if high <= allowance else "misses" if low > allowance else "undecided"
    result = {"runs": n, "median_ns": median, "interval_ns": [low, high], "confidence": confidence,
              "allowance_ns": allowance, "verdict": verdict}
    if confidence < MIN_CONFIDENCE and verdict != "undecided":
        result["verdict"] = "undecided"
        result["why"] = "%d runs: would say %s, at %.1f %%" % (n, verdict, 100 * confidence)
    return result


def median_of(d):
    """The median of the sorted list `d` (non-empty)."""
    n = len(d)
    return d[n // 2] if n % 2 == 1 else (d[n // 2 - 1] + d[n // 2]) / 2


def targets_of(case):
    """The case's targets: "targets", with the DDS runner's "against_native_relay" joined to it
    (that one holds the DDS relay figures)."""
    t = dict(case.get("targets") or {})
    t.update(case.get("against_native_relay") or {})
    return t


def series_figure(case, series, group, field):
    """case[series][group][field], None where any of it is missing."""
    return ((case.get(series) or {}).get(group) or {}).get(field)


def difference(a, b):
    return None if a is None or b is None else a - b


def paired_median(case):
    """The median of the chunks' via p50 - relay p50, from the targets or, in results written
    before the runners reported it, from the series' chunk figures; None without them."""
    paired = targets_of(case).get("via_minus_relay_paired_chunks") or {}
    if "via_minus_relay_p50_ns" in paired:
        return paired["via_minus_relay_p50_ns"]
    via = (case.get("via_polyport") or {}).get("one_way_p50_per_chunk_ns") or []
    relay = (case.get("via_native_relay") or {}).get("one_way_p50_per_chunk_ns") or []
    if not via or len(via) != len(relay):
        return None
    return int(median_of(sorted(v - r for v, r in zip(via, relay))))  # as C++ divides


def figures(case):
    """One run's figures of one case, None where the run has none."""
    t = targets_of(case)
    paired = paired_median(case)
    series = t.get("via_polyport_minus_relay_p50_ns")  # the DDS runner's
    if t.get("via_one_way_p50_ns") is not None and t.get("relay_one_way_p50_ns") is not None:
        series = t["via_one_way_p50_ns"] - t["relay_one_way_p50_ns"]
    def both(group, field):
        return difference(series_figure(case, "via_polyport", group, field),
                          series_figure(case, "via_native_relay", group, field))
    # The targets' CPU figures (lcm, can, matrix), else the series' own (dds).
    cpu = difference(
        t.get("polyportd_cpu_per_round_trip_ns",
              series_figure(case, "via_polyport", "cpu_per_round_trip_ns", "polyportd")),
        t.get("relay_cpu_per_round_trip_ns",
              series_figure(case, "via_native_relay", "cpu_per_round_trip_ns", "relay")))
    all_cpu = both("cpu_per_round_trip_ns", "all")
    rtt = both("rtt_ns", "mean")
    return {"via_minus_relay_ns": series if paired is None else paired,
            "from_chunks": paired is not None,
            "series_medians_ns": series,
            "cpu_ns": cpu,
            "all_cpu_ns": all_cpu,
            "round_trip_mean_ns": rtt,
            "in_to_out_p99_ns": t.get("polyport_in_to_out_p99_ns")}


def case_key(case):
    return tuple((f, case[f]) for f in KEY_FIELDS if f in case)


def label(key):
    d = dict(key)
    parts = [str(d.get("placement", "")), str(d.get("vendor", ""))]
    if "from" in d:
        parts.append("%s -> %s" % (d["from"], d["to"]))
    parts.append("%s B" % d.get("size_bytes", "?"))
    return " ".join(p for p in parts if p)


def load(paths):
    """[(path, run)] of one benchmark; raises ValueError saying what is wrong."""
    runs = []
    for path in paths:
        try:
            with open(path) as f:
                run = json.load(f)
        except (OSError, ValueError) as e:
            raise ValueError("%s: cannot read: %s" % (path, e))
        if not isinstance(run, dict) or not isinstance(run.get("cases"), list):
            raise ValueError("%s: not a ping-pong benchmark's result (no \"cases\")" % path)
        if str(run.get("benchmark", "")).endswith(SUMMARY_SUFFIX):
            raise ValueError("%s: a summary over runs (give the runs' own files)" % path)
        runs.append((path, run))
    kinds = sorted({str(run.get("benchmark")) for _, run in runs})
    if len(kinds) != 1:
        raise ValueError("the files are of different benchmarks: %s" % ", ".join(kinds))
    return runs


def summarize(runs):
    """Every case's figures per run and the verdicts over the runs."""
    cases = {}
    for path, run in runs:
        for case in run["cases"]:
            cases.setdefault(case_key(case), []).append(dict(figures(case), run=path))
    out = []
    for key, per_run in cases.items():
        def values(field):
            return [r[field] for r in per_run if r[field] is not None]
        in_to_out = values("in_to_out_p99_ns")
        out.append({
            "case": dict(key),
            "label": label(key),
            "runs": per_run,
            "via_minus_relay": sign_interval(values("via_minus_relay_ns"), ALLOWANCE_NS),
            "cpu_polyportd_minus_relay": sign_interval(values("cpu_ns"), 0),
            "all_cpu_via_minus_relay": sign_interval(values("all_cpu_ns"), 0),
            "round_trip_mean_via_minus_relay": sign_interval(values("round_trip_mean_ns"), 0),
            "in_to_out_p99_worst_ns": max(in_to_out) if in_to_out else None,
            "in_to_out_p99_within_1us_every_run": (all(v <= IN_TO_OUT_BAR_NS for v in in_to_out)
                                                   if in_to_out else None),
        })
    return {
        "benchmark": "%s%s" % (runs[0][1].get("benchmark"), SUMMARY_SUFFIX),
        "bars": "per case over the runs' values: via - relay (each run's paired chunks' median) <= +2 us; "
                "polyportd's CPU per round trip - the relay's <= 0; in-to-out p99 <= 1 us in every run",
        "method": "sign test on the runs' values (each run an independent start of every process), "
                  "interval d_(k)..d_(n+1-k), k largest with 2 P(Bin(n,1/2) < k) <= 5 %, k = 1 below 6 runs",
        "runs": [{"file": p, "git_revision": r.get("git_revision"), "started_utc": r.get("started_utc"),
                  "host": r.get("host")} for p, r in runs],
        "cases": out,
    }


def us(ns):
    return "-" if ns is None else "%+.1f" % (ns / 1000)


def verdict_text(s):
    if not s:
        return "-"
    text = "%s [%s, %s] %.0f %% **%s**" % (us(s["median_ns"]), us(s["interval_ns"][0]), us(s["interval_ns"][1]),
                                          100 * s["confidence"], s["verdict"])
    return text + (" (%s)" % s["why"] if "why" in s else "")


def markdown(summary):
    revisions = sorted({str(r["git_revision"]) for r in summary["runs"]})
    lines = ["# %s over %d runs" % (summary["benchmark"][:-len(SUMMARY_SUFFIX)], len(summary["runs"])), "",
             "Revisions: %s. Runs: %s." % (", ".join(revisions),
                                           ", ".join(str(r["started_utc"]) for r in summary["runs"])), ""]
    if len(revisions) > 1:
        lines += ["**The runs are of %d revisions** (\"+dirty\": tracked files differed from the commit); "
                  "they are pooled as given." % len(revisions), ""]
    lines += [
             "Per case, one value per run (µs); over the runs: median [sign-test interval] confidence verdict. "
             "via − relay is each run's paired chunks' median (bar ≤ +2); CPU is polyportd's per round trip "
             "minus the relay's (bar ≤ 0); all CPU is that of every process of the path; the mean round trip's "
             "difference is the middle's extra CPU per round trip where one CPU runs the whole path (the vcan "
             "guest, one core). A value in *italics* is a run's series medians' difference (no chunk figures).", "",
             "| case | via − relay per run | via − relay over runs | CPU per run | CPU over runs | "
             "all CPU over runs | mean round trip, via − relay, over runs | in-to-out p99 worst |",
             "|---|---|---|---|---|---|---|---|"]
    for c in summary["cases"]:
        lines.append("| %s | %s | %s | %s | %s | %s | %s | %s |" % (
            c["label"],
            " ".join(us(r["via_minus_relay_ns"]) if r["from_chunks"] or r["via_minus_relay_ns"] is None
                     else "*%s*" % us(r["via_minus_relay_ns"]) for r in c["runs"]),
            verdict_text(c["via_minus_relay"]),
            " ".join(us(r["cpu_ns"]) for r in c["runs"]),
            verdict_text(c["cpu_polyportd_minus_relay"]),
            verdict_text(c["all_cpu_via_minus_relay"]),
            verdict_text(c["round_trip_mean_via_minus_relay"]),
            "-" if c["in_to_out_p99_worst_ns"] is None else "%d ns" % c["in_to_out_p99_worst_ns"]))
    return "\n".join(lines) + "\n"


def main(argv):
    out = None
    if len(argv) >= 2 and argv[0] == "--out":
        out, argv = argv[1], argv[2:]
    if not argv or any(a.startswith("-") for a in argv):
        sys.stderr.write(__doc__)
        return 2
    try:
        summary = summarize(load(argv))
    except ValueError as e:
        sys.stderr.write("runs.py: %s\n" % e)
        return 2
    if len(summary["runs"]) < 6:
        sys.stderr.write("runs.py: %d runs: no verdict reaches 95 %%; it takes 6\n" % len(summary["runs"]))
    text = markdown(summary)
    sys.stdout.write(text)
    if out:
        with open(out + ".json", "w") as f:
            json.dump(summary, f, indent=1)
        with open(out + ".md", "w") as f:
            f.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
