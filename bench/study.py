#!/usr/bin/env python3
"""Firn study harness: runs a named study through the `firn` binary and writes results.csv and
charts (PNG and SVG) into bench/results/<study>/, with the scene, overrides, commit and machine
of every run.

    /usr/bin/python3 bench/study.py stability [--quick] [--firn build/firn]

Studies:
  stability  a stiff elastic block dropped on the ground, CFL 0.1-2.0 x transfer (APIC, PIC,
             FLIP 0.95, FLIP 0.99) x particles per cell: each run is stable, unstable (the
             solver's own status) or inaccurate (|energy drift| above 5 % of the initial
             energy scale). --quick runs a small subset and checks that APIC at CFL 0.4 is
             stable and that CFL 2.0 is not.
  accuracy   validation V1 (a stiff block sliding on a 30 degree plane, mu 0.5, analytic
             a = 0.6571 m/s^2): relative error of the fitted acceleration against wall time
             and particle-steps over dx x transfer x CFL, log-log, Pareto front marked.
             --quick runs APIC at two spacings and checks both are within the 3 % of V1.
  throughput build/firn_bench on elastic blocks of 7 000 to 1 600 000 particles: particle-steps
             per second with 1 thread and all threads, bytes per particle; and the same block
             at the origin and 1 km away (a sparse grid must not care). Not in CI (timings).
"""
import argparse
import csv
import json
import os
import platform
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

STIFF_BLOCK = """
[simulation]
name = "stiff-block"
dimension = 2
end_time = 0.4
frame_rate = 50
gravity = [0.0, -9.81]
[grid]
dx = 0.02
particles_per_cell = 4
max_dt = 1.0
[[material]]
name = "block"
model = "elastic"
density = 500.0
youngs_modulus = 5.0e7
poisson_ratio = 0.3
[[terrain]]
shape = "plane"
point = [0.0, 0.0]
normal = [0.0, 1.0]
boundary = "friction"
friction = 0.3
[[body]]
material = "block"
shape = "box"
min = [0.0, 0.1]
max = [0.4, 0.3]
velocity = [0.5, -1.0]
[output]
particles = false
volumes = []
"""

TRANSFERS = {"apic": ["grid.transfer=apic"], "pic": ["grid.transfer=pic"],
             "flip95": ["grid.transfer=flip", "grid.flip_blend=0.95"],
             "flip99": ["grid.transfer=flip", "grid.flip_blend=0.99"]}
DRIFT_LIMIT = 0.05  # of the energy scale: kinetic + released potential energy

SLIDING_BLOCK = """
[simulation]
name = "sliding-block"
dimension = 2
end_time = 1.0
frame_rate = 20
gravity = [4.905, -8.49571]
gravity_ramp = 0.1
[grid]
dx = 0.05
particles_per_cell = 4
[[material]]
name = "block"
model = "elastic"
density = 1000.0
youngs_modulus = 1.0e7
poisson_ratio = 0.3
[[terrain]]
shape = "plane"
point = [0.0, 0.0]
normal = [0.0, 1.0]
boundary = "friction"
friction = 0.5
[[body]]
material = "block"
shape = "box"
min = [0.0, 0.0]
max = [1.0, 0.25]
[output]
particles = false
volumes = []
"""
SLIDING_EXPECTED = 9.81 * (0.5 - 0.5 * 3 ** 0.5 / 2)  # g (sin 30 - mu cos 30), validation.md V1


def commit():
    try:
        return subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"],
                              capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def run_scene(firn, scene_path, overrides, out):
    args = [firn, "run", scene_path, "--quiet", "--out", out]
    for o in overrides:
        args += ["--set", o]
    proc = subprocess.run(args, capture_output=True, text=True)
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    rows = list(csv.DictReader(open(os.path.join(out, "metrics.csv"))))
    return proc.returncode, summary, rows


def classify(code, summary, rows):
    if summary["status"] == "unstable" or code == 2:
        return "unstable", float("nan")
    first = rows[0]
    scale = max(abs(float(r["kinetic_energy"])) for r in rows) + abs(
        float(first["gravitational_energy"]) - min(float(r["gravitational_energy"]) for r in rows))
    drift = max(abs(float(r["energy_drift"])) for r in rows) / max(scale, 1e-12)
    # Energy only leaves (friction, numerical damping); a gain is the failure we look for.
    gain = max(float(r["energy_drift"]) for r in rows) / max(scale, 1e-12)
    return ("inaccurate" if gain > DRIFT_LIMIT else "stable"), drift


def stability(args, out_dir):
    cfls = [0.2, 0.4, 2.0] if args.quick else [0.1, 0.2, 0.4, 0.7, 1.0, 1.5, 2.0]
    ppcs = [4] if args.quick else [1, 4, 9]
    transfers = ["apic", "flip99"] if args.quick else list(TRANSFERS)
    rows = []
    with tempfile.TemporaryDirectory() as work:
        scene = os.path.join(work, "stiff-block.toml")
        with open(scene, "w") as f:
            f.write(STIFF_BLOCK)
        for transfer in transfers:
            for ppc in ppcs:
                for cfl in cfls:
                    overrides = TRANSFERS[transfer] + [f"grid.cfl={cfl}",
                                                       f"grid.particles_per_cell={ppc}"]
                    out = os.path.join(work, f"{transfer}-{ppc}-{cfl}")
                    code, summary, metrics = run_scene(args.firn, scene, overrides, out)
                    outcome, drift = classify(code, summary, metrics)
                    rows.append({"transfer": transfer, "particles_per_cell": ppc, "cfl": cfl,
                                 "outcome": outcome, "energy_drift": drift,
                                 "steps": summary["steps"],
                                 "wall_seconds": summary["wall_seconds"],
                                 "overrides": " ".join(overrides)})
                    print(f"{transfer:7s} ppc {ppc} cfl {cfl:4.2f}: {outcome}", flush=True)
    return rows


def fitted_acceleration(metrics):
    """a from a least-squares fit x = x0 + v0 t + a t^2 / 2 of com_x over t in [0.2, 1] s."""
    import numpy as np
    t = np.array([float(r["time"]) for r in metrics if float(r["time"]) >= 0.2 - 1e-9])
    x = np.array([float(r["com_x"]) for r in metrics if float(r["time"]) >= 0.2 - 1e-9])
    return 2.0 * np.polyfit(t, x, 2)[0]


def accuracy(args, out_dir):
    if args.quick:
        grid = [("apic", 0.1, 0.4), ("apic", 0.05, 0.4)]
    else:
        grid = [(t, dx, cfl) for t in ("apic", "pic", "flip95", "flip99")
                for dx in (0.1, 0.05, 0.025) for cfl in (0.2, 0.4, 0.8)]
    rows = []
    with tempfile.TemporaryDirectory() as work:
        scene = os.path.join(work, "sliding-block.toml")
        with open(scene, "w") as f:
            f.write(SLIDING_BLOCK)
        for transfer, dx, cfl in grid:
            overrides = TRANSFERS[transfer] + [f"grid.dx={dx}", f"grid.cfl={cfl}"]
            out = os.path.join(work, f"{transfer}-{dx}-{cfl}")
            code, summary, metrics = run_scene(args.firn, scene, overrides, out)
            a = fitted_acceleration(metrics) if summary["status"] == "ok" else float("nan")
            error = abs(a - SLIDING_EXPECTED) / SLIDING_EXPECTED
            rows.append({"transfer": transfer, "dx": dx, "cfl": cfl, "acceleration": a,
                         "relative_error": error, "particles": summary["particles"],
                         "steps": summary["steps"],
                         "particle_steps": summary["particles"] * summary["steps"],
                         "wall_seconds": summary["wall_seconds"], "status": summary["status"],
                         "overrides": " ".join(overrides)})
            print(f"{transfer:7s} dx {dx:5.3f} cfl {cfl:3.1f}: a = {a:.5f}, error {error:.2e}",
                  flush=True)
    return rows


def run_bench(bench, cells, steps, offset=0.0):
    out = subprocess.run([bench, "--cells", str(cells), "--steps", str(steps),
                          "--offset", str(offset)], capture_output=True, text=True, check=True)
    line = [l for l in out.stdout.splitlines() if l.startswith("result ")][-1]
    return {k: float(v) for k, v in (kv.split("=") for kv in line.split()[1:])}


def throughput(args, out_dir):
    bench = os.path.join(os.path.dirname(args.firn), "firn_bench")
    rows = []
    for cells in ([10, 20] if args.quick else [10, 15, 20, 30, 45, 60]):
        for offset in ([0.0, 1000.0] if cells == 20 else [0.0]):
            steps = int(max(10, min(60, 4e7 / (7400 * (cells / 10) ** 3))))
            r = run_bench(bench, cells, steps, offset)
            r.update({"cells": cells, "offset_m": offset, "steps": steps})
            rows.append(r)
            print(f"{int(r['particles']):8d} particles (offset {offset:g} m): "
                  f"{r['pss1'] / 1e6:.2f} M/s 1 thread, {r['pssN'] / 1e6:.2f} M/s "
                  f"{int(r['threads'])} threads, {r['bytes_per_particle_net']:.0f} B/particle",
                  flush=True)
    return rows


def chart_throughput(rows, out_dir):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib missing (Debian: python3-matplotlib): no chart")
        return
    at0 = sorted((r for r in rows if float(r["offset_m"]) == 0.0), key=lambda r: r["particles"])
    n = [r["particles"] for r in at0]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    axes[0].semilogx(n, [r["pss1"] / 1e6 for r in at0], "o-", label="1 thread")
    axes[0].semilogx(n, [r["pssN"] / 1e6 for r in at0], "o-",
                     label=f"{int(at0[0]['threads'])} threads")
    axes[0].set_ylabel("million particle-steps per second")
    axes[1].semilogx(n, [r["bytes_per_particle_net"] for r in at0], "o-",
                     label="simulation (peak RSS - libraries)")
    axes[1].semilogx(n, [r["bytes_per_particle"] for r in at0], "o--", label="peak RSS")
    axes[1].set_yscale("log")
    axes[1].set_ylabel("bytes per particle")
    for ax in axes:
        ax.set_xlabel("particles")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize="small")
    fig.suptitle("Elastic block, APIC, dx 0.02: throughput and memory")
    fig.tight_layout()
    for ext in ("png", "svg"):
        fig.savefig(os.path.join(out_dir, f"throughput.{ext}"))


def pareto(points):
    """Indices of the points not beaten in both cost and error (lower is better)."""
    front = []
    for i, (c, e) in enumerate(points):
        if not any(c2 <= c and e2 <= e and (c2, e2) != (c, e) for c2, e2 in points):
            front.append(i)
    return sorted(front, key=lambda i: points[i][0])


def chart_accuracy(rows, out_dir):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib missing (Debian: python3-matplotlib): no chart")
        return
    ok = [r for r in rows if r["status"] == "ok" and float(r["relative_error"]) > 0]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for ax, cost, label in ((axes[0], "wall_seconds", "wall time (s)"),
                            (axes[1], "particle_steps", "particle-steps")):
        for transfer in sorted({r["transfer"] for r in ok}):
            pts = sorted((float(r[cost]), float(r["relative_error"])) for r in ok
                         if r["transfer"] == transfer)
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", label=transfer, alpha=0.8)
        points = [(float(r[cost]), float(r["relative_error"])) for r in ok]
        front = pareto(points)
        ax.loglog([points[i][0] for i in front], [points[i][1] for i in front], "k--",
                  lw=1.5, label="Pareto front")
        ax.set_xlabel(label)
        ax.set_ylabel("relative error of the acceleration")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize="small")
    fig.suptitle("V1 sliding block (30 deg, mu 0.5): accuracy against cost")
    fig.tight_layout()
    for ext in ("png", "svg"):
        fig.savefig(os.path.join(out_dir, f"accuracy.{ext}"))


def chart_stability(rows, out_dir):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib missing (Debian: python3-matplotlib): no chart")
        return
    colours = {"stable": "tab:green", "inaccurate": "tab:orange", "unstable": "tab:red"}
    labels = sorted({(r["transfer"], r["particles_per_cell"]) for r in rows})
    fig, ax = plt.subplots(figsize=(7, 0.5 * len(labels) + 1.5))
    for y, (transfer, ppc) in enumerate(labels):
        for r in rows:
            if (r["transfer"], r["particles_per_cell"]) == (transfer, ppc):
                ax.scatter(r["cfl"], y, c=colours[r["outcome"]], s=120, marker="s")
    ax.set_yticks(range(len(labels)))
    ax.set_yticklabels([f"{t}, {p} ppc" for t, p in labels])
    ax.set_xlabel("CFL number")
    ax.set_title("Stiff elastic block dropped on the ground: stability map")
    for outcome, colour in colours.items():
        ax.scatter([], [], c=colour, marker="s", label=outcome)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")
    fig.tight_layout()
    for ext in ("png", "svg"):
        fig.savefig(os.path.join(out_dir, f"stability.{ext}"))


NUMERIC = {"cfl", "particles_per_cell", "dx", "relative_error", "wall_seconds",
           "particle_steps", "acceleration", "energy_drift", "steps", "particles", "pss1",
           "pssN", "threads", "speedup", "bytes_per_particle", "bytes_per_particle_net", "cells",
           "offset_m"}


def quick_check(study, rows):
    """The assertion of each study's quick mode (run in CI)."""
    if study == "throughput":
        return True  # timings are reported, never asserted
    if study == "stability":
        outcome = {(r["transfer"], r["cfl"]): r["outcome"] for r in rows}
        if outcome[("apic", 0.4)] != "stable" or outcome[("apic", 2.0)] == "stable":
            print("check failed: APIC must be stable at CFL 0.4 and not at CFL 2.0")
            return False
        return True
    worst = max(float(r["relative_error"]) for r in rows)
    if not worst < 0.03:  # validation.md V1: 3 %
        print(f"check failed: acceleration error {worst:.3g} above the 3 % of V1")
        return False
    return True


def main():
    parser = argparse.ArgumentParser(description="Firn study harness")
    parser.add_argument("study", choices=["stability", "accuracy", "throughput"])
    parser.add_argument("--quick", action="store_true", help="small subset with a check (CI)")
    parser.add_argument("--firn", default=os.path.join(ROOT, "build", "firn"))
    parser.add_argument("--out", default=None, help="results folder (default bench/results/<study>)")
    parser.add_argument("--chart-only", action="store_true",
                        help="redraw the charts from an existing results.csv")
    args = parser.parse_args()
    out_dir = args.out or os.path.join(ROOT, "bench", "results", args.study)
    os.makedirs(out_dir, exist_ok=True)
    studies = {"stability": (stability, chart_stability), "accuracy": (accuracy, chart_accuracy),
               "throughput": (throughput, chart_throughput)}
    run, chart = studies[args.study]
    if args.chart_only:
        with open(os.path.join(out_dir, "results.csv")) as f:
            rows = [{k: (float(v) if k in NUMERIC else v) for k, v in r.items()}
                    for r in csv.DictReader(f)]
        for r in rows:
            if "particles_per_cell" in r:
                r["particles_per_cell"] = int(r["particles_per_cell"])
        chart(rows, out_dir)
        return 0
    rows = run(args, out_dir)
    with open(os.path.join(out_dir, "results.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        writer.writerows(rows)
    scene = {"stability": STIFF_BLOCK, "accuracy": SLIDING_BLOCK,
             "throughput": "bench/bench_core.cc blockScene()"}[args.study]
    with open(os.path.join(out_dir, "run.json"), "w") as f:
        json.dump({"study": args.study, "quick": args.quick, "commit": commit(),
                   "machine": platform.platform(), "processor": platform.processor(),
                   "cpus": os.cpu_count(), "scene": scene}, f, indent=2)
    chart(rows, out_dir)
    if args.quick and not quick_check(args.study, rows):
        return 1
    print(f"wrote {out_dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
