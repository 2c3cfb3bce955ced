#!/usr/bin/python3
"""Speed against accuracy on the practitioner's case: scenes/path3d.toml at several dx.

Runs the 1.6 km synthetic path (60 000 m^3 release on a 5 m GeoTIFF DEM, Voellmy bed) at each
grid spacing, one run at a time, and charts the runout along the path, the peak speed and the
alpha angle against dx beside the wall time and memory. Writes OUT/path_study.csv and
OUT/path_study.png (default bench/results/path/).

    /usr/bin/python3 bench/path_study.py [--firn build/firn] [--dx 8 5.66 4 2.83 2] [--threads 2]
    /usr/bin/python3 bench/path_study.py --replot
"""
import argparse
import csv
import json
import pathlib
import subprocess
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parent.parent
EAST = 2600000.0  # the path's south-west corner (bench/synthetic_path.cc): s = x - EAST


def run(firn, dx, threads, work):
    out = work / f"dx{dx:g}"
    cmd = [firn, "run", str(ROOT / "scenes/path3d.toml"), "--quiet", "--threads", str(threads),
           "--out", str(out), "--set", f"grid.dx={dx}", "--set", "output.particles=false",
           "--set", "output.volumes=[]"]
    subprocess.run(cmd, check=True)
    with open(out / "summary.json", encoding="utf-8") as f:
        s = json.load(f)
    return {
        "dx": dx,
        "particles": s["particles"],
        "steps": s["steps"],
        "wall_seconds": s["wall_seconds"],
        "peak_rss_mb": s["peak_rss_bytes"] / 1e6,
        "particle_steps_per_second": s["particle_steps_per_second"],
        "runout_m": s["runout_x"] - EAST,
        "max_speed": s["max_speed"],
        "alpha_angle_deg": s["alpha_angle_deg"],
        "com_travel_angle_deg": s["com_travel_angle_deg"],
        "raster_share": s["raster_wall_seconds"] / s["wall_seconds"],
    }


def two_curves(ax, plot, dx, rows, first, second, title):
    """Two quantities against dx on one panel: (key, label) pairs, circles and dashed squares."""
    plot(dx, [r[first[0]] for r in rows], "o-", label=first[1])
    plot(dx, [r[second[0]] for r in rows], "s--", label=second[1])
    ax.set_xlabel("dx (m)")
    ax.set_title(title)
    ax.legend()


def chart(rows, path):
    dx = [r["dx"] for r in rows]
    fig, axes = plt.subplots(1, 3, figsize=(13, 4), constrained_layout=True)
    ax = axes[0]
    ax.plot(dx, [r["runout_m"] for r in rows], "o-")
    ax.set_xlabel("dx (m)")
    ax.set_ylabel("runout along the path (m)")
    ax.set_title("Runout (farthest moved snow)")
    two_curves(axes[1], axes[1].plot, dx, rows, ("max_speed", "max speed (m/s)"),
               ("alpha_angle_deg", "alpha angle (deg)"), "Peak speed and alpha angle")
    ax = axes[2]
    two_curves(ax, ax.loglog, dx, rows, ("wall_seconds", "wall time (s, 2 cores)"),
               ("peak_rss_mb", "peak memory (MB)"), "Cost")
    ax.xaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
    ax.xaxis.set_minor_formatter(matplotlib.ticker.ScalarFormatter())
    for a in axes:
        a.invert_xaxis()
    fig.suptitle("scenes/path3d.toml: accuracy against cost over dx")
    fig.savefig(path, dpi=110)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--firn", default=str(ROOT / "build/firn"))
    parser.add_argument("--dx", type=float, nargs="+", default=[8.0, 5.66, 4.0, 2.83, 2.0])
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--work", default="/tmp/firn-path-study")
    parser.add_argument("--out", default=str(ROOT / "bench/results/path"))
    parser.add_argument("--replot", action="store_true",
                        help="redraw OUT/path_study.png from OUT/path_study.csv, running nothing")
    args = parser.parse_args()
    work, out = pathlib.Path(args.work), pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.replot:
        with open(out / "path_study.csv", encoding="utf-8") as f:
            rows = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(f)]
        chart(rows, out / "path_study.png")
        return 0
    rows = []
    for dx in sorted(args.dx, reverse=True):
        rows.append(run(args.firn, dx, args.threads, work))
        print(", ".join(f"{k} {v:.4g}" for k, v in rows[-1].items()), file=sys.stderr)
    with open(out / "path_study.csv", "w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    chart(rows, out / "path_study.png")
    print(f"wrote {out / 'path_study.csv'} and {out / 'path_study.png'}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
