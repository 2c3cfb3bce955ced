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


def main():
    parser = argparse.ArgumentParser(description="Firn study harness")
    parser.add_argument("study", choices=["stability"])
    parser.add_argument("--quick", action="store_true", help="small subset with a check (CI)")
    parser.add_argument("--firn", default=os.path.join(ROOT, "build", "firn"))
    parser.add_argument("--out", default=None, help="results folder (default bench/results/<study>)")
    parser.add_argument("--chart-only", action="store_true",
                        help="redraw the charts from an existing results.csv")
    args = parser.parse_args()
    out_dir = args.out or os.path.join(ROOT, "bench", "results", args.study)
    os.makedirs(out_dir, exist_ok=True)
    if args.chart_only:
        with open(os.path.join(out_dir, "results.csv")) as f:
            rows = [dict(r, cfl=float(r["cfl"]), particles_per_cell=int(r["particles_per_cell"]))
                    for r in csv.DictReader(f)]
        chart_stability(rows, out_dir)
        return 0
    rows = stability(args, out_dir)
    with open(os.path.join(out_dir, "results.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        writer.writerows(rows)
    with open(os.path.join(out_dir, "run.json"), "w") as f:
        json.dump({"study": args.study, "quick": args.quick, "commit": commit(),
                   "machine": platform.platform(), "processor": platform.processor(),
                   "cpus": os.cpu_count(), "scene": STIFF_BLOCK}, f, indent=2)
    chart_stability(rows, out_dir)
    if args.quick:
        outcome = {(r["transfer"], r["cfl"]): r["outcome"] for r in rows}
        if outcome[("apic", 0.4)] != "stable" or outcome[("apic", 2.0)] == "stable":
            print("check failed: APIC must be stable at CFL 0.4 and not at CFL 2.0")
            return 1
    print(f"wrote {out_dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
