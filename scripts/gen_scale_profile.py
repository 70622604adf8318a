#!/usr/bin/python3
"""Writes an application profile of N in-process source -> sink pairs (N connections, 2N
components), with the scale benchmark's component profiles beside it (benchmarks/scale).

    scripts/gen_scale_profile.py N OUT_DIR [--period-ms P] [--policy buffer|circular|data]
"""
import argparse
import os
import sys

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "benchmarks", "scale")


def write_component_profiles(out_dir, period_ms):
    """ScaleSource.xml and ScaleSink.xml in OUT_DIR, periodic at PERIOD_MS (also used by
    benchmarks/soak/soak.py)."""
    os.makedirs(out_dir, exist_ok=True)
    here = os.path.realpath(HERE)
    for name in ("ScaleSource.xml", "ScaleSink.xml"):
        with open(os.path.join(here, name)) as template:
            text = template.read().replace("@PERIOD_MS@", f"{period_ms:g}").replace("@DIR@", here)
        with open(os.path.join(out_dir, name), "w") as out:
            out.write(text)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("n", type=int, help="connections (source -> sink pairs)")
    parser.add_argument("out_dir")
    parser.add_argument("--period-ms", type=float, default=10.0, help="every component's period (default 10)")
    parser.add_argument("--policy", default="buffer", choices=["buffer", "circular", "data"])
    args = parser.parse_args()
    if args.n < 1:
        sys.exit("gen_scale_profile: N must be at least 1")
    write_component_profiles(args.out_dir, args.period_ms)
    width = len(str(args.n))
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             f"<!-- {args.n} source -> sink pairs, made by scripts/gen_scale_profile.py -->",
             "<application_profile>", f"  <name>scale_{args.n}</name>", "  <subcomponents>"]
    for i in range(args.n):
        for role, ref in (("src", "ScaleSource.xml"), ("sink", "ScaleSink.xml")):
            lines.append(f"    <subcomponent><name>{role}{i:0{width}d}</name><reference>{ref}</reference></subcomponent>")
    lines += ["  </subcomponents>", "  <port_connections>"]
    for i in range(args.n):
        depth = ' depth="16"' if args.policy != "data" else ""
        lines += [f'    <port_connection port_type="data" policy="{args.policy}"{depth}>',
                  f'      <source component_name="src{i:0{width}d}" port_name="out"/>',
                  f'      <target component_name="sink{i:0{width}d}" port_name="in"/>',
                  "    </port_connection>"]
    lines += ["  </port_connections>", "</application_profile>", ""]
    app = os.path.join(args.out_dir, "app.xml")
    with open(app, "w") as out:
        out.write("\n".join(lines))
    print(app)


if __name__ == "__main__":
    main()
