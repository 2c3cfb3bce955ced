#!/usr/bin/env python3
"""Resting snow sleeps: what sleeping saves and what it changes.

    /usr/bin/python3 bench/sleep_study.py [--quick] [--firn build/firn] [--out DIR] [--chart-only]

A 2D granular release (the default scene's slope) flows down beside a resting deposit: a 0.5 m
layer on a plateau above the release (out of the flow's reach, and behind it, so that runout_x
stays the flow's front), of length 0 to 60 m, so that the moving share of the particles runs
from all to a small part. A last case
puts a 10 m deposit in the flow's path, where the flow must wake it. Each case runs with
grid.sleep on and off (same seed). Recorded per run: wall time, particle-steps per second,
asleep particles at the end, and the outcome: runout_x, alpha angle, final centre of mass.
The error sleeping introduces is the difference in runout and centre of mass, on against off.

Writes results.csv, run.json and sleep.png/.svg into bench/results/sleep/ (or --out).
--quick (CTest) runs the 30 m deposit beside the flow, 4 s, and asserts: the deposit sleeps
(over 80 % of its particles at the end), the run costs less with sleeping, and the runout moves
by less than one grid cell.
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
DX = 0.1

SCENE = """
[simulation]
name = "sleep-study"
dimension = 2
end_time = {end_time}
frame_rate = 4
gravity = [0.0, -9.81]
gravity_ramp = 0.2
seed = 1
[grid]
dx = {dx}
particles_per_cell = 4
[[material]]
name = "snow"
model = "granular"
density = 250.0
youngs_modulus = 1.0e6
poisson_ratio = 0.3
friction_angle = 35.0
[[terrain]]
shape = "profile"
points = [[-70.0, 13.0], [0.0, 13.0], [5.0, 10.0], [12.0, 4.0], [18.0, 1.0], [25.0, 0.0], [60.0, 0.0]]
boundary = "friction"
friction = 0.3
[[body]]
name = "release"
material = "snow"
shape = "layer"
thickness = 0.5
x_range = [3.0, 12.0]
{deposit}
[output]
particles = false
volumes = []
"""

DEPOSIT = """
[[body]]
name = "deposit"
material = "snow"
shape = "layer"
thickness = 0.5
x_range = [{x0}, {x1}]
"""


def cases(quick):
    """(name, deposit x range or None, end time)."""
    if quick:
        return [("beside-30m", (-35.0, -5.0), 4.0)]
    beside = [("no-deposit", None, 8.0)] + [
        (f"beside-{L}m", (-5.0 - L, -5.0), 8.0) for L in (10, 30, 60)]
    return beside + [("in-path-10m", (28.0, 38.0), 8.0)]


def run(firn, text, sleep, threads, work):
    scene = os.path.join(work, "scene.toml")
    with open(scene, "w") as f:
        f.write(text)
    out = os.path.join(work, "on" if sleep else "off")
    cmd = [firn, "run", scene, "--quiet", "--out", out, "--set",
           f"grid.sleep={'true' if sleep else 'false'}"]
    if threads:
        cmd += ["--threads", str(threads)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        sys.exit(f"sleep_study: firn failed ({proc.returncode}): {proc.stderr.strip()}")
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    rows = list(csv.DictReader(open(os.path.join(out, "metrics.csv"))))
    return summary, rows[-1]


def study(args):
    results = []
    for name, deposit, end_time in cases(args.quick):
        text = SCENE.format(end_time=end_time, dx=DX, deposit=(
            DEPOSIT.format(x0=deposit[0], x1=deposit[1]) if deposit else ""))
        outcome = {}
        with tempfile.TemporaryDirectory() as work:
            for sleep in (False, True):
                summary, last = run(args.firn, text, sleep, args.threads, work)
                outcome[sleep] = (summary, last)
        off, on = outcome[False], outcome[True]
        row = {
            "case": name,
            "deposit_m": 0.0 if not deposit else deposit[1] - deposit[0],
            "in_path": int(bool(deposit) and deposit[0] > 0.0),
            "particles": on[0]["particles"],
            "asleep_end": int(on[1]["asleep"]),
            "wall_off_s": off[0]["wall_seconds"],
            "wall_on_s": on[0]["wall_seconds"],
            "speedup": off[0]["wall_seconds"] / on[0]["wall_seconds"],
            "psps_off": off[0]["particle_steps_per_second"],
            "psps_on": on[0]["particle_steps_per_second"],
            "runout_off_m": off[0]["runout_x"],
            "runout_on_m": on[0]["runout_x"],
            "runout_diff_m": abs(on[0]["runout_x"] - off[0]["runout_x"]),
            "alpha_off_deg": off[0]["alpha_angle_deg"],
            "alpha_on_deg": on[0]["alpha_angle_deg"],
            "com_shift_m": ((float(on[1]["com_x"]) - float(off[1]["com_x"])) ** 2 +
                            (float(on[1]["com_y"]) - float(off[1]["com_y"])) ** 2) ** 0.5,
        }
        results.append(row)
        print(f"{name}: {row['particles']} particles, speed-up {row['speedup']:.2f}, "
              f"runout {row['runout_off_m']:.2f} -> {row['runout_on_m']:.2f} m, "
              f"asleep at end {row['asleep_end']}", flush=True)
    return results


def write(results, out_dir, args):
    os.makedirs(out_dir, exist_ok=True)
    with open(os.path.join(out_dir, "results.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(results[0].keys()))
        w.writeheader()
        w.writerows(results)
    commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip() or "unknown"
    meta = {"study": "sleep", "quick": args.quick, "commit": commit,
            "machine": f"{platform.node()} {platform.processor() or platform.machine()}, "
                       f"{os.cpu_count()} cores",
            "threads": args.threads or os.cpu_count(),
            "scene": SCENE.format(end_time="<case>", dx=DX, deposit="<deposit>"),
            "overrides": ["grid.sleep=true|false"]}
    with open(os.path.join(out_dir, "run.json"), "w") as f:
        json.dump(meta, f, indent=2)


def chart(out_dir):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = list(csv.DictReader(open(os.path.join(out_dir, "results.csv"))))
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    beside = [r for r in rows if r["in_path"] == "0"]
    # The release is 9 m of the same 0.5 m layer: the resting share of the particles.
    resting = [float(r["deposit_m"]) / (float(r["deposit_m"]) + 9.0) for r in beside]
    ax1.plot([float(r["deposit_m"]) for r in beside], [float(r["wall_off_s"]) for r in beside],
             "o-", label="sleep off")
    ax1.plot([float(r["deposit_m"]) for r in beside], [float(r["wall_on_s"]) for r in beside],
             "s-", label="sleep on")
    for r, share in zip(beside, resting):
        ax1.annotate(f"{100 * share:.0f}% resting, x{float(r['speedup']):.2f}",
                     (float(r["deposit_m"]), float(r["wall_on_s"])),
                     textcoords="offset points", xytext=(4, -12), fontsize=8)
    ax1.set_xlabel("resting deposit beside the flow (m of 0.5 m layer)")
    ax1.set_ylabel("wall time (s)")
    ax1.set_title("Cost against resting snow")
    ax1.legend()
    names = [r["case"] for r in rows]
    ax2.bar(range(len(rows)), [float(r["runout_diff_m"]) for r in rows], label="runout")
    ax2.bar([i + 0.4 for i in range(len(rows))], [float(r["com_shift_m"]) for r in rows],
            width=0.4, label="centre of mass")
    ax2.axhline(DX, color="k", ls="--", lw=1, label=f"one cell ({DX} m)")
    ax2.set_xticks(range(len(rows)))
    ax2.set_xticklabels(names, rotation=20, fontsize=8)
    ax2.set_ylabel("|sleep on - off| (m)")
    ax2.set_title("What sleeping changes")
    ax2.legend(fontsize=8)
    fig.tight_layout()
    for ext in ("png", "svg"):
        fig.savefig(os.path.join(out_dir, f"sleep.{ext}"), dpi=120)


def check_quick(results):
    r = results[0]
    deposit_particles = r["particles"] * 30.0 / 39.0  # 30 m of the 39 m of snow
    failures = []
    if r["asleep_end"] < 0.8 * deposit_particles:
        failures.append(f"only {r['asleep_end']} particles asleep, expected most of the "
                        f"~{deposit_particles:.0f} in the deposit")
    if not r["wall_on_s"] < r["wall_off_s"]:
        failures.append(f"sleeping did not save time ({r['wall_on_s']:.2f} s on, "
                        f"{r['wall_off_s']:.2f} s off)")
    if not r["runout_diff_m"] < DX:
        failures.append(f"runout moved {r['runout_diff_m']:.3f} m (limit one cell, {DX} m)")
    for f in failures:
        print("sleep_study --quick: FAILED:", f)
    return not failures


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--firn", default=os.path.join(ROOT, "build", "firn"))
    p.add_argument("--out", default=os.path.join(ROOT, "bench", "results", "sleep"))
    p.add_argument("--threads", type=int, default=0)
    p.add_argument("--chart-only", action="store_true")
    args = p.parse_args()
    if not args.chart_only:
        results = study(args)
        write(results, args.out, args)
        if args.quick and not check_quick(results):
            return 1
    chart(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
