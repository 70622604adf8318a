#!/usr/bin/python3
"""Turns a result file of bench_matrix (benchmarks/matrix/run_matrix.cpp) into the cross-model
matrix:

  RESULTS/matrix-STAMP.json   bench_matrix's file, to which this adds "pairs": for every
                              ordered pair of models polyport speaks (and every placement and
                              size), the measured figures and whether each bar holds, or why
                              the pair was not measured
  RESULTS/matrix-STAMP.md     the tables: rows source model, columns target model
  RESULTS/matrix-STAMP.png    the heat map: cell = via polyport median one-way us, annotated
                              with the native relay's median and whether the bars hold

The CAN pairs (the CAN row and column: classic 8-byte frames in the 16 B class, CAN FD 64-byte
frames in the 1 KiB class) are measured in the
vcan guest by a run of their own, RESULTS/matrix-STAMP-vcan.json (bench_matrix --pairs can
inside scripts/vcan-run; scripts/bench_matrix.sh runs both): given after the host file, its
CAN pairs fill the same tables and heat map, marked as measured in the guest (user-mode Linux:
every figure inflated; a CAN pair's bars compare it with its relay and with direct figures
of the same guest run). Its other diagonal cases serve those bars and show only where the host
file has no figures of its own. Without a CAN run, the CAN diagonal comes from the newest
can_pingpong-*.json in the results directory, a different run: the tables say so. Nothing is
smoothed or hard-coded: every number comes from those files. Plots use matplotlib (Debian:
python3-matplotlib); run with /usr/bin/python3.

  /usr/bin/python3 benchmarks/matrix/report.py RESULTS/matrix-STAMP.json [RESULTS/matrix-STAMP-vcan.json]
  (either alone works too; the first file named gets "pairs" and names the .md and .png)"""
import argparse
import glob
import json
import os
import sys

ALL_MODELS = ["cyclonedds", "fastdds", "lcm", "can", "inprocess"]
LABEL = {"cyclonedds": "Cyclone DDS", "fastdds": "Fast DDS", "lcm": "LCM", "can": "CAN", "inprocess": "in-process"}
# The second bar applies to pairs of these models (issue 11, "Decisions from the DDS round").
DIRECT_BAR_MODELS = {"cyclonedds", "lcm", "can"}
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def us(ns):
    return "-" if ns is None else "%.1f" % (ns / 1000.0)


def p(case, series, q):
    return case.get(series, {}).get("one_way_ns", {}).get(q)


def cpu_per_message(case, series, role):
    """The bridging process's CPU time per message: per round trip / 2."""
    v = case.get(series, {}).get("cpu_per_round_trip_ns", {}).get(role)
    return None if v is None else v // 2


def in_to_out(case):
    own = case.get("polyport", [])
    if not own:
        return None
    return {"p50_ns": max(c["in_to_out_ns"].get("p50", 0) for c in own),
            "p99_ns": max(c["in_to_out_ns"].get("p99", 0) for c in own)}


def verdict(v):
    return "n/a" if v is None else ("ok" if v else "MISS")


def into_inprocess(case):
    """X -> in-process or in-process -> X (X's ping or pong program against the in-process pong or
    ping inside polyportd): no native relay, its bar is via <= direct(X) + 2 us, X's direct series
    in the same case. In-process -> in-process has no bar."""
    return "inprocess" in (case["from"], case["to"]) and case["from"] != case["to"]


def pair_of(case, source):
    """One measured pair: the figures and the bars."""
    t = case.get("targets", {})
    direct_bar = t.get("direct_bar")
    same = case["from"] == case["to"]
    if into_inprocess(case) and "via_within_direct_plus_2us" in t:
        direct_bar = {"via_within": t["via_within_direct_plus_2us"], "is_a_bar": True,
                      "bound_ns": t["bound_direct_plus_2us_ns"]}
    if same and "direct" in case and "via_one_way_p50_ns" in t and case["from"] != "inprocess":
        # The diagonal's own direct series (same case): 2 x direct + 2 us.
        d50 = p(case, "direct", "p50")
        bound = 2 * d50 + 2000
        direct_bar = {"from_direct_one_way_p50_ns": d50, "to_direct_one_way_p50_ns": d50, "bound_ns": bound,
                      "via_within": t["via_one_way_p50_ns"] <= bound, "margin_ns": bound - t["via_one_way_p50_ns"],
                      "is_a_bar": case["from"] in DIRECT_BAR_MODELS}
    errors = [case[s]["error"] for s in ("direct", "via_polyport", "via_native_relay") if "error" in case.get(s, {})]
    if "polyport_error" in case:
        errors.append(case["polyport_error"])
    return {
        "from": case["from"], "to": case["to"], "placement": case["placement"], "size_bytes": case["size_bytes"],
        "measured": True, "source": source, "can_frame_bytes": case.get("can_frame_bytes"),
        "direct_one_way_ns": ({"p50": p(case, "direct", "p50"), "p99": p(case, "direct", "p99")}
                              if same or into_inprocess(case) else None),
        "via_polyport_one_way_ns": {"p50": p(case, "via_polyport", "p50"), "p99": p(case, "via_polyport", "p99")},
        "via_native_relay_one_way_ns": {"p50": p(case, "via_native_relay", "p50"),
                                        "p99": p(case, "via_native_relay", "p99")},
        "cpu_per_message_ns": {"polyportd": cpu_per_message(case, "via_polyport", "polyportd"),
                               "relay": cpu_per_message(case, "via_native_relay", "relay")},
        "polyport_in_to_out_ns": in_to_out(case),
        "bars": {
            "via_within_relay_plus_2us": t.get("via_within_relay_plus_2us"),
            "relay_plus_2us_bound_ns": t.get("bound_relay_plus_2us_ns"),
            # Whether this run decides that bar: the chunks' paired differences (runner.hpp).
            "via_minus_relay_paired_chunks": t.get("via_minus_relay_paired_chunks"),
            "via_within_direct_bound": None if direct_bar is None else direct_bar["via_within"],
            "direct_bound_is_a_bar": None if direct_bar is None else direct_bar["is_a_bar"],
            "direct_bound_ns": None if direct_bar is None else direct_bar["bound_ns"],
            "direct_bound": ("2 x direct + 2 us" if same else
                             "direct(from) + 2 us, same case (no native relay: the component lives in the bridge)"
                             if into_inprocess(case) else "direct(from) + direct(to) + 2 us, this run's diagonal"),
        },
        "errors": errors,
    }


def newest(results, prefix):
    files = sorted(glob.glob(os.path.join(results, prefix + "-*.json")))
    return files[-1] if files else None


def can_pairs(results):
    """The CAN diagonal from the newest CAN ping-pong run (another run, in the vcan guest, which
    has one CPU: shown in every placement's table)."""
    path = newest(results, "can_pingpong")
    if path is None:
        return []
    with open(path) as f:
        run = json.load(f)
    out = []
    for c in run.get("cases", []):
        c = dict(c, **{"from": "can", "to": "can"})
        out.append(pair_of(c, os.path.relpath(path, ROOT)))
    return out


def not_measured(runs, pairs, sizes):
    """Every ordered pair of ALL_MODELS (with CAN: and size) that has no figures, with the reason
    the result files give (an entry naming the size first)."""
    entries = [e for m in runs for e in m.get("not_measured", [])]

    def reason_for(prefix, size):
        named = [e for e in entries if e["pairs"].startswith(prefix) and e.get("size_bytes") == size]
        other = [e for e in entries if e["pairs"].startswith(prefix) and "size_bytes" not in e]
        return next((e["reason"] for e in named + other), None)

    out = []
    for a in ALL_MODELS:
        for b in ALL_MODELS:
            if "can" in (a, b):
                if "inprocess" in (a, b):
                    # Not size by size: the in-process pairs run on the host, the CAN pairs in the guest.
                    if not any(q["from"] == a and q["to"] == b for q in pairs):
                        out.append({"from": a, "to": b, "measured": False,
                                    "reason": reason_for("can <-> inprocess", None) or CAN_INPROCESS})
                    continue
                for size in sizes:
                    if any(q["from"] == a and q["to"] == b and (q["size_bytes"] == size or not from_run(q))
                           for q in pairs):
                        continue
                    reason = reason_for("can <-> every", size)
                    if reason is not None:
                        out.append({"from": a, "to": b, "size_bytes": size, "measured": False, "reason": reason})
            elif "inprocess" in (a, b) and not any(q["from"] == a and q["to"] == b for q in pairs):
                out.append({"from": a, "to": b, "measured": False, "reason": "not in this run (bench_matrix --models)"})
    return out


def shown(model, pairs, missing):
    """A model with a row: one that has figures, or CAN while its pairs are listed missing."""
    return any(model in (q["from"], q["to"]) for q in pairs) or (
        model == "can" and any("size_bytes" in m and "can" in (m["from"], m["to"]) for m in missing))


def is_missing(missing, a, b, size):
    return any(m["from"] == a and m["to"] == b and m.get("size_bytes", size) == size for m in missing)


def from_run(q):
    """A pair of the matrix files given (not the CAN diagonal of a can_pingpong run)."""
    return q["source"] in ("matrix", GUEST)


def find_cell(pairs, placement, a, b, size):
    """The pair of a cell: `placement`'s; for a CAN pair (measured in the guest, in its own
    placements) any placement's; for CAN -> CAN also a can_pingpong run's."""
    q = find(pairs, placement, a, b, size)
    if q is None and "can" in (a, b):
        same = [x for x in pairs if x["from"] == a and x["to"] == b and x["size_bytes"] == size and from_run(x)]
        q = same[0] if same else None
    if q is None and a == b == "can":
        q = find_any_size([x for x in pairs if not from_run(x)], placement, "can")
    return q


def mark(q):
    return " ‡" if q["source"] == GUEST else "" if q["source"] == "matrix" else " †"


GUEST = "matrix, vcan guest"
CAN_INPROCESS = ("not in these runs (the vcan part measures them when its --models names inprocess, as "
                 "scripts/bench_matrix.sh does)")


def cell_text(pair):
    via = pair["via_polyport_one_way_ns"]
    relay = pair["via_native_relay_one_way_ns"]
    bars = pair["bars"]
    if pair["from"] == pair["to"] == "inprocess":
        return "via %s/%s\nping and pong\nin one polyportd" % (us(via["p50"]), us(via["p99"]))
    if "inprocess" in (pair["from"], pair["to"]):
        d = pair["direct_one_way_ns"] or {}
        return "via %s/%s\ndirect %s/%s\ndirect+2: %s" % (us(via["p50"]), us(via["p99"]), us(d.get("p50")),
                                                        us(d.get("p99")), verdict(bars["via_within_direct_bound"]))
    text = "via %s/%s\nrelay %s/%s\nrelay+2: %s" % (us(via["p50"]), us(via["p99"]), us(relay["p50"]), us(relay["p99"]),
                                                   verdict(bars["via_within_relay_plus_2us"]))
    if bars["via_within_direct_bound"] is not None:
        text += "\ndirect: %s%s" % (verdict(bars["via_within_direct_bound"]),
                                     "" if bars["direct_bound_is_a_bar"] else " (info)")
    return text


def markdown(matrix, runs, pairs, missing, json_name):
    h = matrix["host"]
    s = matrix["settings"]
    lines = ["# Cross-model latency matrix", "",
             "Run %s on %s (%s CPUs, %s), git %s; %d measured round trips per series in %d chunks, %d warm-up per "
             "chunk. One-way = round trip / 2, median / p99 in us. Raw figures: `%s`." % (
                 matrix["started_utc"], h.get("cpu", "?"), h.get("nproc", "?"), h.get("uname", "?"),
                 matrix.get("git_revision", "?"), s["round_trips"], s["chunks"], s["warmup_per_chunk"], json_name),
             "",
             "Bars (issue 11): via polyport one-way p50 <= native relay p50 + 2 us, same case, every pair; via <= "
             "direct(from) + direct(to) + 2 us (2 x direct on the diagonal) for Cyclone DDS, LCM and CAN, reported "
             "as information for Fast DDS. X -> in-process and in-process -> X: X's ping (pong) program against the "
             "in-process pong (ping), components inside polyportd answering from their CallbackInPort; no native "
             "relay exists for them, the cell shows [direct X] instead of (relay) and the bar is via <= direct(X) + "
             "2 us, same case; in-process -> in-process: polyport's own figure, no bar. CPU per message: the "
             "bridging process's CPU time per round trip / 2.", ""]
    guest = next((m for m in runs if m is not matrix and is_guest(m)), matrix if is_guest(matrix) else None)
    if guest is not None:
        g = guest["settings"]
        lines += ["CAN pairs (‡): run %s %s; %d measured round trips per series in %d chunks, git %s." % (
            guest["started_utc"], g.get("where", "under scripts/vcan-run"), g["round_trips"], g["chunks"],
            guest.get("git_revision", "?")), ""]
    placements = sorted({q["placement"] for q in pairs if q["source"] == "matrix"} or
                        {q["placement"] for q in pairs if from_run(q)})
    sizes = sorted({q["size_bytes"] for q in pairs if from_run(q)})
    models = [m for m in ALL_MODELS if shown(m, pairs, missing)]
    for placement in placements:
        for size in sizes:
            lines += ["## %s, %d B: via polyport (relay) median one-way us" % (placement, size), "",
                      "| from \\ to | " + " | ".join(LABEL[m] for m in models) + " |",
                      "|---|" + "---|" * len(models)]
            for a in models:
                row = []
                for b in models:
                    q = find_cell(pairs, placement, a, b, size)
                    if q is None:
                        row.append("not measured" if is_missing(missing, a, b, size) else "-")
                        continue
                    bars = q["bars"]
                    if a == b == "inprocess":
                        row.append("%s (ping and pong in one polyportd)" % us(q["via_polyport_one_way_ns"]["p50"]))
                        continue
                    if "inprocess" in (a, b):
                        row.append("%s [%s] %s%s" % (us(q["via_polyport_one_way_ns"]["p50"]),
                                                     us((q["direct_one_way_ns"] or {}).get("p50")),
                                                     verdict(bars["via_within_direct_bound"]), mark(q)))
                        continue
                    row.append("%s (%s) %s%s" % (us(q["via_polyport_one_way_ns"]["p50"]),
                                                 us(q["via_native_relay_one_way_ns"]["p50"]),
                                                 verdict(bars["via_within_relay_plus_2us"]), mark(q)))
                lines.append("| %s | %s |" % (LABEL[a], " | ".join(row)))
            lines.append("")
    if any(q["source"] == GUEST for q in pairs):
        lines += ["‡ CAN pairs: classic CAN frames of 8 data bytes in the 16 B tables, CAN FD frames of 64 in the "
                  "1 KiB ones (seq; the other model's pad not carried), measured in the vcan guest (user-mode Linux, one CPU; its own placement, shown in every table): each system call "
                  "there (a clock read too, ~15 us) goes through the guest kernel process, so every figure is "
                  "inflated. Compare such a pair with its relay and the guest's direct figures (the bars do), not "
                  "with the host's cells.", ""]
    can_source = next((q["source"] for q in pairs if not from_run(q)), None)
    if can_source is not None:
        lines += ["† CAN -> CAN: classic CAN (8 data bytes) from `%s`, run in the vcan guest (user-mode Linux, one "
                  "CPU), not in this run." % can_source, ""]
    lines += ["## Every measured pair", "",
              "*via - relay, chunks paired*: the median over chunks of via p50 - relay p50 of the same chunk (the "
              "series alternate chunk by chunk), the sign test's interval for it at the confidence shown, and "
              "whether this run decides the relay bar: holds (interval at or under +2 us), misses (above), "
              "undecided (across: more chunks would tell).", "",
              "| placement | from | to | size B | direct p50/p99 | via p50/p99 | relay p50/p99 | via <= relay + 2 | "
              "via - relay, chunks paired | direct bound | via <= direct bound | polyportd CPU/msg | relay CPU/msg | "
              "in-to-out p50/p99 ns |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for q in pairs:
        d = q["direct_one_way_ns"] or {}
        b = q["bars"]
        own = q["polyport_in_to_out_ns"] or {}
        direct_verdict = verdict(b["via_within_direct_bound"])
        if b["via_within_direct_bound"] is not None and not b["direct_bound_is_a_bar"]:
            direct_verdict += " (info)"
        lines.append("| %s | %s | %s | %s | %s/%s | %s/%s | %s/%s | %s | %s | %s | %s | %s | %s | %s/%s |" % (
            q["placement"], LABEL[q["from"]], LABEL[q["to"]],
            "%d%s" % (q["size_bytes"], " (CAN %d)" % q["can_frame_bytes"] if q.get("can_frame_bytes") else ""),
            us(d.get("p50")), us(d.get("p99")),
            us(q["via_polyport_one_way_ns"]["p50"]), us(q["via_polyport_one_way_ns"]["p99"]),
            us(q["via_native_relay_one_way_ns"]["p50"]), us(q["via_native_relay_one_way_ns"]["p99"]),
            verdict(b["via_within_relay_plus_2us"]), paired_text(b.get("via_minus_relay_paired_chunks")),
            us(b["direct_bound_ns"]), direct_verdict,
            us(q["cpu_per_message_ns"]["polyportd"]), us(q["cpu_per_message_ns"]["relay"]),
            own.get("p50_ns", "-"), own.get("p99_ns", "-")))
        for e in q["errors"]:
            lines.append("|  | error: %s |" % e.replace("\n", " ").replace("|", "/")[:300])
    lines += ["", "## Not measured", ""]
    reasons = {}
    for m in missing:
        reasons.setdefault(m["reason"], []).append("%s -> %s%s" % (
            LABEL[m["from"]], LABEL[m["to"]], " (%d B)" % m["size_bytes"] if "size_bytes" in m else ""))
    for reason, which in reasons.items():
        lines.append("- %s: %s" % (", ".join(dict.fromkeys(which)), reason))
    return "\n".join(lines) + "\n"


def paired_text(p):
    """The paired chunks' estimate, e.g. "+1.2 [-0.4, +3.0] 98 % undecided"."""
    if not p:
        return "-"
    return "%+.1f [%+.1f, %+.1f] %.0f %% %s" % (p["via_minus_relay_p50_ns"] / 1000, p["interval_ns"][0] / 1000,
                                               p["interval_ns"][1] / 1000, 100 * p["confidence"], p["verdict"])


def is_guest(run):
    """A run with CAN pairs (under scripts/vcan-run)."""
    return "vcan_run" in run.get("settings", {})


def find(pairs, placement, a, b, size):
    return next((q for q in pairs if q["placement"] == placement and q["from"] == a and q["to"] == b and
                 q["size_bytes"] == size), None)


def find_any_size(pairs, placement, model):
    """A diagonal pair of `model` in any size: `placement`'s, else any placement's."""
    same = [q for q in pairs if q["from"] == model and q["to"] == model]
    return next((q for q in same if q["placement"] == placement), same[0] if same else None)


def heat_map(pairs, missing, png, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.colors
    import numpy as np

    placements = sorted({q["placement"] for q in pairs if q["source"] == "matrix"} or
                        {q["placement"] for q in pairs if from_run(q)})
    sizes = sorted({q["size_bytes"] for q in pairs if from_run(q)})
    models = [m for m in ALL_MODELS if m != "inprocess" and shown(m, pairs, missing)] + ["inprocess"]
    panels = [(pl, sz) for pl in placements for sz in sizes]
    fig, axes = plt.subplots(len(placements), len(sizes), figsize=(8.5 * len(sizes), 7.5 * len(placements)),
                             squeeze=False)
    vmax = max(q["via_polyport_one_way_ns"]["p50"] or 0 for q in pairs) / 1000.0
    # A logarithmic scale: the vcan guest's CAN cells are several times the host's; from 10 us (the
    # in-process diagonal's fraction of a microsecond takes the lightest colour).
    vmin = max(min((q["via_polyport_one_way_ns"]["p50"] or vmax * 1000) for q in pairs) / 1000.0, 10.0)
    norm = matplotlib.colors.LogNorm(vmin=vmin, vmax=max(vmax, vmin * 1.01))
    for (pl, sz), ax in zip(panels, axes.flat):
        grid = np.full((len(models), len(models)), np.nan)
        for i, a in enumerate(models):
            for j, b in enumerate(models):
                q = find_cell(pairs, pl, a, b, sz)
                if q is not None and q["via_polyport_one_way_ns"]["p50"] is not None:
                    grid[i, j] = q["via_polyport_one_way_ns"]["p50"] / 1000.0
                    text = cell_text(q) + ("\n(vcan guest, %s B)" % (q.get("can_frame_bytes") or 8)
                                           if q["source"] != "matrix" else "")
                    dark = norm(grid[i, j]) > 0.6
                    ax.text(j, i, text, ha="center", va="center", fontsize=6.5, color="white" if dark else "black")
                else:
                    ax.text(j, i, "not\nmeasured" if is_missing(missing, a, b, sz) else "-", ha="center", va="center",
                            fontsize=7, color="dimgray")
        cmap = plt.get_cmap("YlOrRd").copy()
        cmap.set_bad("lightgray")
        image = ax.imshow(np.ma.masked_invalid(grid), cmap=cmap, norm=norm)
        ax.set_xticks(range(len(models)), [LABEL[m] for m in models], fontsize=8)
        ax.set_yticks(range(len(models)), [LABEL[m] for m in models], fontsize=8)
        ax.set_xlabel("target model (pong)")
        ax.set_ylabel("source model (ping)")
        ax.set_title("%s, %d B: one-way p50/p99 us; relay+2: via <= relay + 2 us;\ndirect: via <= direct(from) + "
                     "direct(to) + 2 us" % (pl, sz), fontsize=9)
        fig.colorbar(image, ax=ax, shrink=0.7, label="via polyport median one-way (us, log scale)")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("matrix_json", nargs="+", help="the host run's file, the vcan guest's, or both")
    parser.add_argument("--results", help="where the CAN ping-pong results are (default: the JSON's directory)")
    args = parser.parse_args()
    runs = []
    for path in args.matrix_json:
        with open(path) as f:
            runs.append(json.load(f))
    matrix = runs[0]
    results = args.results or os.path.dirname(os.path.abspath(args.matrix_json[0]))
    pairs = [pair_of(c, "matrix") for m in runs if not is_guest(m) for c in m["cases"]]
    for m in (m for m in runs if is_guest(m)):
        # The guest's CAN pairs; its other diagonals only where no host run measured them.
        for c in m["cases"]:
            if "can" in (c["from"], c["to"]) or find(pairs, c["placement"], c["from"], c["to"], c["size_bytes"]) is None:
                pairs.append(pair_of(c, GUEST))
    if not any(q["from"] == q["to"] == "can" for q in pairs):
        pairs += can_pairs(results)
    missing = not_measured(runs, pairs, sorted({q["size_bytes"] for q in pairs if from_run(q)}))
    matrix["pairs"] = pairs + missing
    with open(args.matrix_json[0], "w") as f:
        json.dump(matrix, f, indent=2)
        f.write("\n")
    stem = os.path.splitext(args.matrix_json[0])[0]
    with open(stem + ".md", "w") as f:
        f.write(markdown(matrix, runs, pairs, missing,
                         ", ".join("`%s`" % os.path.basename(p) for p in args.matrix_json).strip("`")))
    heat_map(pairs, missing, stem + ".png", "polyport cross-model matrix, %s, %s CPUs (%s)" % (
        matrix["started_utc"], matrix["host"].get("nproc"), matrix["host"].get("cpu")))
    print("report: %s.md, %s.png; pairs in %s" % (stem, stem, args.matrix_json[0]), file=sys.stderr)
    misses = [q for q in pairs if q["bars"]["via_within_relay_plus_2us"] is False or
              (q["bars"]["via_within_direct_bound"] is False and q["bars"]["direct_bound_is_a_bar"])]
    for q in misses:
        bars = q["bars"]
        which = []
        if bars["via_within_relay_plus_2us"] is False:
            paired = bars.get("via_minus_relay_paired_chunks")
            which.append("relay + 2 us" + ("" if not paired else " (via - relay, chunks paired: %s)" % paired_text(paired)))
        if bars["via_within_direct_bound"] is False and bars["direct_bound_is_a_bar"]:
            which.append(bars["direct_bound"])
        print("bar missed: %s %s -> %s %d B: %s" % (q["placement"], q["from"], q["to"], q["size_bytes"], "; ".join(which)),
              file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
