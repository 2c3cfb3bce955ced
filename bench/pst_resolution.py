#!/usr/bin/env python3
"""PST study (validation.md V8): critical cut length and steady crack speed of scenes/pst.toml
at several grid spacings and slope angles, beside the closed form of Gaume et al. (2017a).

    /usr/bin/python3 bench/pst_resolution.py [--dx 0.03 0.02 0.015] [--slopes 0 10 20 30 35]
        [--firn build/firn] [--set key=value ...] [--criterion run|onset] [--ac-only | --speed-only]
        [--speed-column 6] [--speed-cut 0.8] [--bracket 0 0.8] [--steps 5]
        [--weak-thickness 0.06] [--ac-end-time 0.2] [--speed-time-per-metre 0.05]
        [--threads N] [--out DIR] [--scene SCENE.toml] [--ac-column 3]

For each dx and slope: the critical cut length by bisection (0-0.8 m, to 2.5 cm; --bracket and
--steps narrow it: a result at a bracket's end means a_c lies outside it) on a 3 m column with
the cut at the down-slope end, as in the field (criterion "run": the crack from the cut reaches
the up-slope end within 0.2 s, or --ac-end-time; "onset": it grows more than 0.3 m past the cut;
a crack that does not reach back to the cut, such as the free up-slope end yielding on its own,
counts for neither), then the steady crack speed on the full 6 m column (--speed-column) with a
0.8 m cut (--speed-cut) at its down-slope end (not with --ac-only), lasting 0.05 s per metre of
column (--speed-time-per-metre), as summary.json's mean_crack_speed, as the up-slope end's speed
over the column less 0.5 m at each end (front_speed) and over its last 4 m before that margin
(late_front_speed: on a 12 m column, after 6.7 m of travel), from 1000 frames per second. The
saw is the scenes' (quasi-static unless --set cut.weak.saw="instant"). A slope tilts gravity,
g (sin psi, -cos psi), so that x runs down the slope. --set passes scene overrides to every run.
Writes results.csv into bench/results/pst-resolution/ (or --out) and prints a table. The weak
layer stays 0.06 m thick, so it spans 2 to 4 cells over the default spacings; particles per cell
stay 4. --weak-thickness T gives the layer another thickness with the PST layer's collapse energy
per unit area: the scene's softening times T over its thickness (100 T / 0.06), and
softening_length T, so that the crack band scales the softening wherever its 6 cells are thinner
than T (docs/snow.md, Resolution); the closed form takes D_wl = T. --scene runs another PST
scene whose layers are bodies "weak" and "slab" with a cut in "weak" (bench/pst_slope3d_layers.toml:
scenes/slope3d.toml's layers); the closed form, for pst.toml's slab and layer, is then left out.
--ac-column sets the bisection's column length (default 3 m; longer for cuts near it).
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys
import tempfile
import time
import tomllib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


THREADS = []
SCENE = [os.path.join(ROOT, "scenes", "pst.toml")]


def run(firn, overrides, out, extra=()):
    args = [firn, "run", SCENE[0], "--quiet", "--out", out,
            *THREADS,
            "--set", "output.particles=false", "--set", "output.volumes=[]"]
    for o in list(extra) + list(overrides):
        args += ["--set", o]
    start = time.time()
    subprocess.run(args, check=True)
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    return summary, time.time() - start


def gravity(slope):
    g = 9.81
    psi = math.radians(slope)
    return f"simulation.gravity=[{g * math.sin(psi):.6f}, {-g * math.cos(psi):.6f}]"


def closed_form_ac(slope, E=5e6, nu=0.2, rho=250.0, D=0.5, D_wl=0.06, G_wl=0.2e6, tau_p=1000.0):
    """a_c of Gaume et al. (2017a) as validation.md V8 gives it, for pst.toml's slab and layer."""
    psi = math.radians(slope)
    lam = math.sqrt(E / (1 - nu * nu) * D * D_wl / G_wl)
    sigma_n = rho * 9.81 * D * math.cos(psi)
    tau_g = rho * 9.81 * D * math.sin(psi)
    return lam * (-tau_g + math.sqrt(tau_g ** 2 + 2 * sigma_n * (tau_p - tau_g))) / sigma_n


def weak_thickness_overrides(thickness):
    """Overrides that give pst.toml's weak layer `thickness` with the same collapse energy per
    unit area (none for the scene's own thickness): softening scaled with the thickness, and
    softening_length the thickness, so that the crack band scales it on finer grids."""
    with open(os.path.join(ROOT, "scenes", "pst.toml"), "rb") as f:
        scene = tomllib.load(f)
    layer = next(b for b in scene["body"] if b["name"] == "weak")["thickness"]
    softening = next(m for m in scene["material"] if m["name"] == "weak")["softening"]
    if thickness == layer:
        return []
    return [f"body.weak.thickness={thickness}",
            f"material.weak.softening={softening * thickness / layer:g}",
            f"material.weak.softening_length={thickness}"]


def up_slope_track(out):
    """(time, crack_tip_min_x) of every frame of metrics.csv with a crack: its up-slope end."""
    with open(os.path.join(out, "metrics.csv")) as f:
        return [(float(row["time"]), float(row["crack_tip_min_x"]))
                for row in csv.DictReader(f) if row["crack_tip_min_x"]]


def up_slope_reach(out, tip, dx):
    """Smallest crack_tip_min_x in metrics.csv over the frames whose crack reaches back to the
    cut's tip (its crack_tip_max_x within two cells of it; inf when none): how far up-slope the
    crack from the cut ran. A crack elsewhere (the column's free up-slope end yielding under
    its static load on a steep slope) does not count: it is not the cut's."""
    with open(os.path.join(out, "metrics.csv")) as f:
        return min((float(row["crack_tip_min_x"]) for row in csv.DictReader(f)
                    if row["crack_tip_min_x"] and float(row["crack_tip_max_x"]) >= tip - 2 * dx),
                   default=math.inf)


def front_speed(out, start, end):
    """Speed of the crack's up-slope end (crack_tip_min_x) from x = start to x = end < start:
    the distance over the time between its first passes of the two, interpolated between
    frames. Unlike mean_crack_speed (the tracked end's pass-time mean) it follows the up-slope
    end alone, so daughter cracks ahead of the tip on steep slopes count as the advance they
    are. None when the crack does not get that far."""
    rows = up_slope_track(out)

    def first_pass(x):
        for (t0, m0), (t1, m1) in zip([(None, math.inf)] + rows[:-1], rows):
            if m1 <= x:
                return t1 if t0 is None or m0 == m1 else t0 + (t1 - t0) * (m0 - x) / (m0 - m1)
        return None

    t_start, t_end = first_pass(start), first_pass(end)
    if t_start is None or t_end is None or t_end <= t_start:
        return None
    return (start - end) / (t_end - t_start)


def bisect_cut(bracket, steps, runs_at):
    """The critical cut by bisection: runs_at(cut, i) runs the column with that cut (the i-th run)
    and says whether its crack ran. Returns the last (stays, runs) bracket."""
    stays, runs = bracket
    for i in range(steps):
        cut = 0.5 * (stays + runs)
        if runs_at(cut, i):
            runs = cut
        else:
            stays = cut
    return stays, runs


def critical_cut(firn, dx, slope, work, extra=(), criterion="run", steps=5, bracket=(0.0, 0.8),
                 end_time=0.2, length=3.0):
    seconds = 0.0

    def runs_at(cut, i):
        nonlocal seconds
        out = os.path.join(work, f"ac-{dx}-{slope}-{i}")
        _, t = run(firn, [f"grid.dx={dx}", gravity(slope), f"body.weak.x_range=[0.0, {length}]",
                          f"body.slab.x_range=[0.0, {length}]", f"cut.weak.from_x={length - cut}",
                          f"cut.weak.length={cut}", f"simulation.end_time={end_time}",
                          "simulation.frame_rate=100"], out, extra)
        seconds += t
        reach = up_slope_reach(out, length - cut, dx)
        return (reach < 0.1) if criterion == "run" else (reach < length - cut - 0.3)

    stays, runs = bisect_cut(bracket, steps, runs_at)
    return stays, runs, seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dx", type=float, nargs="+", default=[0.03, 0.02, 0.015])
    parser.add_argument("--slopes", type=float, nargs="+", default=[0.0])
    parser.add_argument("--firn", default=os.path.join(ROOT, "build", "firn"))
    parser.add_argument("--set", action="append", default=[], dest="overrides",
                        help="scene override for every run (repeatable)")
    parser.add_argument("--criterion", choices=["run", "onset"], default="run")
    only = parser.add_mutually_exclusive_group()
    only.add_argument("--ac-only", action="store_true", help="skip the crack-speed run")
    only.add_argument("--speed-only", action="store_true", help="skip the critical cut")
    parser.add_argument("--bracket", type=float, nargs=2, default=[0.0, 0.8],
                        metavar=("STAYS", "RUNS"),
                        help="cut lengths (m) the bisection starts between (default 0 0.8)")
    parser.add_argument("--steps", type=int, default=5, help="bisection steps (default 5)")
    parser.add_argument("--speed-column", type=float, default=6.0,
                        help="length of the speed run's column, m (default 6)")
    parser.add_argument("--speed-cut", type=float, default=0.8,
                        help="the speed run's cut, m: longer than a_c (default 0.8)")
    parser.add_argument("--ac-end-time", type=float, default=0.2,
                        help="how long each bisection run lasts, s: a crack that runs reaches "
                             "the column's up-slope end within it (default 0.2: 12.5 m/s or "
                             "faster over the 3 m column; a slab softer than ~2 MPa needs more)")
    parser.add_argument("--speed-time-per-metre", type=float, default=0.05,
                        help="the speed run's end time per metre of column, s/m (default 0.05: "
                             "cracks of 20 m/s or faster cross it)")
    parser.add_argument("--weak-thickness", type=float, default=0.06,
                        help="weak layer thickness in m, its softening scaled (default 0.06)")
    parser.add_argument("--threads", type=int, help="threads per run (default: all cores)")
    parser.add_argument("--out", default=os.path.join(ROOT, "bench", "results", "pst-resolution"))
    parser.add_argument("--scene", help="another PST scene (default scenes/pst.toml)")
    parser.add_argument("--ac-column", type=float, default=3.0,
                        help="the bisection's column length, m (default 3)")
    args = parser.parse_args()
    if args.scene:
        SCENE[0] = os.path.abspath(args.scene)
    results_dir = args.out
    if args.threads:
        THREADS.extend(["--threads", str(args.threads)])
    if args.scene:
        with open(SCENE[0], "rb") as f:
            weak_thickness = next(b for b in tomllib.load(f)["body"]
                                  if b["name"] == "weak")["thickness"]
    else:
        weak_thickness = args.weak_thickness
        args.overrides = weak_thickness_overrides(args.weak_thickness) + args.overrides
    os.makedirs(results_dir, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory() as work:
        for dx in args.dx:
            for slope in args.slopes:
                row = {"dx": dx, "slope": slope,
                       "cells_in_weak_layer": round(weak_thickness / dx, 2),
                       "criterion": args.criterion, "overrides": " ".join(args.overrides)}
                if not args.speed_only:
                    stays, runs, t_ac = critical_cut(args.firn, dx, slope, work, args.overrides,
                                                     args.criterion, args.steps,
                                                     tuple(args.bracket), args.ac_end_time,
                                                     args.ac_column)
                    row.update({"a_c_low": round(stays, 4), "a_c_high": round(runs, 4),
                                "a_c_closed_form":
                                    "" if args.scene else
                                    round(closed_form_ac(slope, D_wl=args.weak_thickness), 4),
                                "wall_seconds_ac": round(t_ac, 1)})
                if not args.ac_only:
                    speed_out = os.path.join(work, f"speed-{dx}-{slope}")
                    column, tip = args.speed_column, args.speed_column - args.speed_cut
                    summary, t_speed = run(args.firn, [f"grid.dx={dx}", gravity(slope),
                                                       f"body.weak.x_range=[0.0, {column}]",
                                                       f"body.slab.x_range=[0.0, {column}]",
                                                       f"cut.weak.from_x={tip}",
                                                       f"cut.weak.length={args.speed_cut}",
                                                       "simulation.end_time="
                                                       f"{args.speed_time_per_metre * column}",
                                                       "simulation.frame_rate=1000"],
                                           speed_out, args.overrides)
                    front = front_speed(speed_out, tip - 0.5, 0.5)
                    late = front_speed(speed_out, 4.5, 0.5)
                    row.update({"column": column, "speed_cut": args.speed_cut,
                                "steady_crack_speed": round(summary["mean_crack_speed"], 2),
                                "front_speed": round(front, 2) if front else "",
                                "late_front_speed": round(late, 2) if late else "",
                                "propagation_distance":
                                    round(summary["crack_propagation_distance"], 3),
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
