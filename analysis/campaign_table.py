#!/usr/bin/python3
"""Tabulates a campaign of geosynth runs from their summary.json files.

    analysis/campaign_table.py runs/campaign [--json out.json]

Prints one row per run directory: engine, config name, ranks, seed, wall
seconds, the slowest phase, peak memory and digest, then checks that runs
differing only in rank count agree on the digest (the determinism contract)
and reports speed-up relative to the smallest rank count. Reads only the
machine-readable files (analysis/gsio.py); never scrapes logs. The HTML
report with figures: analysis/report.py.
"""
import argparse
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gsio  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("root")
    ap.add_argument("--json", help="also write the table as JSON here")
    args = ap.parse_args()
    runs = gsio.load_runs(args.root)
    if not runs:
        print(f"no summary.json under {args.root}", file=sys.stderr)
        return 1
    runs.sort(key=lambda r: (r["_dir"], r.get("ranks", 0)))
    print(f"{'run':40s} {'engine':7s} {'np':>3s} {'seed':>6s} {'wall s':>8s} {'peak MiB':>9s}  digest")
    for r in runs:
        print(f"{r['_dir'][:40]:40s} {r.get('engine',''):7s} {r.get('ranks',0):3d} "
              f"{r.get('seed',0):6d} {r.get('wall_seconds',0):8.2f} "
              f"{r.get('mem_peak_bytes',0)/2**20:9.1f}  {r.get('digest','')}")
    bad = 0
    for members in gsio.comparable_groups(runs):
        if len({m.get("digest") for m in members}) > 1:
            bad += 1
            print("DIGEST MISMATCH between " + ", ".join(m["_dir"] for m in members))
        base = min(members, key=lambda m: m.get("ranks", 1))
        for m in members:
            if m is not base and m.get("wall_seconds"):
                print(f"speed-up {m['_dir']}: {base['wall_seconds'] / m['wall_seconds']:.2f}x "
                      f"over np={base.get('ranks')}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump([{k: v for k, v in r.items() if k != "config" and not k.startswith("_")}
                       | {"dir": r["_dir"]} for r in runs], f, indent=1)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
