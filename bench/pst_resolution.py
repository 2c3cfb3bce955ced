#!/usr/bin/env python3
"""PST resolution study (issue: snow mechanics): critical cut length and steady crack speed of
scenes/pst.toml at several grid spacings, so we know what resolution the answer needs.

    /usr/bin/python3 bench/pst_resolution.py [--dx 0.03 0.02 0.015] [--firn build/firn]
        [--set key=value ...] [--criterion run|onset] [--ac-only] [--out DIR]

For each dx: the critical cut length by bisection on a 3 m column (criterion "run": the crack
reaches the far end within 0.2 s; "onset": it grows more than 0.3 m past the cut), then the
steady crack speed on the full 6 m column (not with --ac-only). --set passes scene overrides
to every run, e.g. --set material.weak.initial_p0=6900 for the weak-layer variants of the
README's Snow section. Writes results.csv into bench/results/pst-resolution/ (or --out) and
prints a table. The weak layer stays 0.06 m thick,
so it spans 2 to 4 cells over the default spacings; particles per cell stay 4.
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(firn, overrides, out, extra=()):
    args = [firn, "run", os.path.join(ROOT, "scenes", "pst.toml"), "--quiet", "--out", out,
            "--set", "output.particles=false", "--set", "output.volumes=[]"]
    for o in list(extra) + list(overrides):
        args += ["--set", o]
    start = time.time()
    subprocess.run(args, check=True)
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    return summary, time.time() - start


def tip_reach(out):
    """Largest crack_tip_max_x in metrics.csv (0 when no crack)."""
    reach = 0.0
    with open(os.path.join(out, "metrics.csv")) as f:
        for row in csv.DictReader(f):
            if row["crack_tip_max_x"]:
                reach = max(reach, float(row["crack_tip_max_x"]))
    return reach


def critical_cut(firn, dx, work, extra=(), criterion="run", steps=4):
    stays, runs = 0.1, 0.9
    seconds = 0.0
    for i in range(steps):
        cut = 0.5 * (stays + runs)
        out = os.path.join(work, f"ac-{dx}-{i}")
        _, t = run(firn, [f"grid.dx={dx}", "body.weak.x_range=[0.0, 3.0]",
                          "body.slab.x_range=[0.0, 3.0]", f"cut.weak.length={cut}",
                          "simulation.end_time=0.2", "simulation.frame_rate=100"], out, extra)
        seconds += t
        reach = tip_reach(out)
        if (reach > 2.9) if criterion == "run" else (reach > cut + 0.3):
            runs = cut
        else:
            stays = cut
    return stays, runs, seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dx", type=float, nargs="+", default=[0.03, 0.02, 0.015])
    parser.add_argument("--firn", default=os.path.join(ROOT, "build", "firn"))
    parser.add_argument("--set", action="append", default=[], dest="overrides",
                        help="scene override for every run (repeatable)")
    parser.add_argument("--criterion", choices=["run", "onset"], default="run")
    parser.add_argument("--ac-only", action="store_true", help="skip the crack-speed run")
    parser.add_argument("--out", default=os.path.join(ROOT, "bench", "results", "pst-resolution"))
    args = parser.parse_args()
    results_dir = args.out
    os.makedirs(results_dir, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory() as work:
        for dx in args.dx:
            stays, runs, t_ac = critical_cut(args.firn, dx, work, args.overrides, args.criterion)
            row = {"dx": dx, "cells_in_weak_layer": round(0.06 / dx, 2),
                   "criterion": args.criterion, "overrides": " ".join(args.overrides),
                   "a_c_low": round(stays, 4), "a_c_high": round(runs, 4),
                   "wall_seconds_ac": round(t_ac, 1)}
            if not args.ac_only:
                summary, t_speed = run(args.firn, [f"grid.dx={dx}", "simulation.end_time=0.25"],
                                       os.path.join(work, f"speed-{dx}"), args.overrides)
                row.update({"steady_crack_speed": round(summary["mean_crack_speed"], 2),
                            "propagation_distance": round(summary["crack_propagation_distance"], 3),
                            "particles": summary["particles"],
                            "wall_seconds_speed": round(t_speed, 1)})
            rows.append(row)
            print(rows[-1], flush=True)
    with open(os.path.join(results_dir, "results.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {os.path.join(results_dir, 'results.csv')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
