#!/usr/bin/python3
"""The hazard-map benchmark: a helix-shaped path, as AvaFrame's test case avaHelix, run by Firn.

Builds the helix topography AvaFrame documents (in3Utils generateTopo, type HX: a parabolic fall
of C = 1000 m along the arc of a circle of radius 1250 m, mean slope 34 degrees down to the flat at
fLen = C / tan 34 = 1482.6 m of arc, then flat; no channel), on the same grid as avaHelix's DEM
(1001 x 401 cells of 5 m, lower-left centre at 1000 E, -5000 N), written here from the formula,
not copied. The release is a 1 m slab of about 66 000 m^2 on the helix's top (between radii 1080
and 1420 m and 0.07 to 0.2253 rad of arc), the path line runs along the helix's centre line
(radius 1250 m). The scene is the issue's: granular snow of 200 kg/m^3 on a Voellmy bed
(mu 0.155, xi 4000 m/s^2), dx 2.5 m, grid.max_dt 0.01 s, end_time 150 s.

Each variant runs once, one at a time, on the given threads; the table gives wall time, steps,
particle-steps per second, the simulated end time and why the run ended, and the map's figures
(max pfv, max ppr, the ppr >= 1 kPa footprint, pft over it, runout along the path, alpha). The
inputs and runs go to WORK (default out/helix-bench/, git-ignored); the table to OUT/helix.csv
and OUT/helix.md (default bench/results/helix/).

    /usr/bin/python3 bench/helix.py [--firn build/firn] [--threads 2] [--variants NAME ...]
    /usr/bin/python3 bench/helix.py --inputs-only     # just the DEM, release and path line
    /usr/bin/python3 bench/helix.py --reuse           # the table again from the runs on disk
"""
import argparse
import csv
import json
import math
import pathlib
import subprocess
import sys

import numpy as np

from esri_ascii import read_asc

ROOT = pathlib.Path(__file__).resolve().parent.parent

CELL = 5.0
COLS, ROWS = 1001, 401  # x from -2500 to 2500, y from -2000 to 0 around the helix's centre
XLL, YLL = 1000.0, -5000.0  # lower-left cell centre, as avaHelix's DEM
FALL = 1000.0  # C, total fall height
R_HELIX = 1250.0
F_LEN = FALL / math.tan(math.radians(34.0))  # arc length to the flat
RELEASE_RADII = (1080.0, 1420.0)
RELEASE_THETA = (0.07, 0.2253)
RELEASE_THICKNESS = 1.0

# The snow: granular, 200 kg/m^3, phi 35 deg (bench/thickness_study.py uses it too).
SNOW_MATERIAL = """[[material]]
name = "snow"
model = "granular"
density = 200.0
youngs_modulus = 1.0e5
poisson_ratio = 0.3
friction_angle = 35.0
"""

SCENE = """# avaHelix as Firn runs it (bench/helix.py writes this file and its inputs)
[simulation]
name = "helix"
dimension = 3
end_time = 150.0
frame_rate = 1.0

[grid]
dx = 2.5
max_dt = 0.01

""" + SNOW_MATERIAL + """
[[terrain]]
shape = "heightfield"
file = "dem.asc"
boundary = "voellmy"
friction = 0.155
turbulence = 4000.0

[[body]]
name = "release"
material = "snow"
shape = "polygon"
file = "release.geojson"

[output]
path = "path.geojson"
particles = false
volumes = []
"""

# name -> (what it is, --set overrides). "issue" is the run the issue timed: all 150 s.
VARIANTS = {
    "issue": ("the issue's run: all of end_time", ["simulation.stop_at_rest=false"]),
    "stop": ("stop at rest (the default)", []),
    "stop-cfl": ("stop at rest, no step cap: the CFL step (grid.max_dt 1 s never binds)",
                 ["grid.max_dt=1.0"]),
    "stop-cfl-ppc1": ("as stop-cfl, one particle per cell (the sheet is one particle thick anyway)",
                      ["grid.max_dt=1.0", "grid.particles_per_cell=1"]),
    "stop-cfl-dx5": ("as stop-cfl at dx 5 m, AvaFrame's mesh and the DEM's cell",
                     ["grid.max_dt=1.0", "grid.dx=5.0"]),
    "stop-cfl-dx1.25": ("as stop-cfl at dx 1.25 m: where pft goes on a finer grid",
                        ["grid.max_dt=1.0", "grid.dx=1.25"]),
}


def local_to_world(x, y):
    """The local frame has the helix's axis at the origin and y <= 0. AvaFrame writes its rows from
    y = -2000 up, which GIS software reads as the top row: the world is mirrored in y."""
    return x + XLL + 0.5 * (COLS - 1) * CELL, -y + YLL


def helix_elevation(x, y):
    """generateTopo's HX surface: the parabola z(s) = A s^2 + B s + C of the arc length
    s = theta * rHelix, flat (z = 0) beyond fLen; theta = atan2(y, x) + pi."""
    a = FALL / F_LEN**2
    b = -2.0 * FALL / F_LEN
    s = (np.arctan2(y, x) + math.pi) * R_HELIX
    z = np.where(s < F_LEN, a * s * s + b * s + FALL, 0.0)
    return np.maximum(z, 0.0)


def write_inputs(folder):
    folder.mkdir(parents=True, exist_ok=True)
    xs = -0.5 * (COLS - 1) * CELL + CELL * np.arange(COLS)
    ys = -(ROWS - 1) * CELL + CELL * np.arange(ROWS)  # row 0 of the file: y = -2000 (the mirror)
    x, y = np.meshgrid(xs, ys)
    z = helix_elevation(x, y)
    z[-1, : COLS // 2] = FALL  # generateTopo sets the axis row's upper half to the top
    with open(folder / "dem.asc", "w", encoding="ascii") as f:
        f.write(f"ncols {COLS}\nnrows {ROWS}\nxllcenter {XLL:.2f}\nyllcenter {YLL:.2f}\n"
                f"cellsize {CELL:g}\nnodata_value -9999\n")
        np.savetxt(f, z, fmt="%.4f")

    def ring(radius, thetas):
        return [local_to_world(-radius * math.cos(t), -radius * math.sin(t)) for t in thetas]

    inner, outer = RELEASE_RADII
    arc = np.linspace(*RELEASE_THETA, 12)
    polygon = ring(inner, arc) + ring(outer, arc[::-1])
    polygon.append(polygon[0])
    area = 0.5 * (RELEASE_THETA[1] - RELEASE_THETA[0]) * (outer**2 - inner**2)
    release = {"type": "FeatureCollection", "features": [{
        "type": "Feature", "properties": {"thickness": RELEASE_THICKNESS},
        "geometry": {"type": "Polygon", "coordinates": [[list(p) for p in polygon]]}}]}
    (folder / "release.geojson").write_text(json.dumps(release), encoding="utf-8")

    line = ring(R_HELIX, np.linspace(0.0, math.pi, 121))
    path = {"type": "FeatureCollection", "features": [{
        "type": "Feature", "properties": {"name": "helix centre line"},
        "geometry": {"type": "LineString", "coordinates": [list(p) for p in line]}}]}
    (folder / "path.geojson").write_text(json.dumps(path), encoding="utf-8")
    (folder / "helix.toml").write_text(SCENE, encoding="utf-8")
    return area


def map_figures(rasters):
    """Max pfv, max ppr (kPa), the ppr >= 1 kPa footprint (ha) and, over it, the 90th percentile
    and the maximum of pft (m) from the peak rasters; the same of the release raster (a uniform 1 m
slab: what it reads above 1 m is the particles' sampling noise)."""
    _, pfv = read_asc(rasters / "pfv.asc")
    _, pft = read_asc(rasters / "pft.asc")
    header, ppr = read_asc(rasters / "ppr.asc")
    _, release = read_asc(rasters / "release.asc")
    seeded = release[np.nan_to_num(release) > 0]
    cell_area = header["cellsize"] ** 2
    footprint = ppr >= 1.0
    return {"max_pfv": float(np.nanmax(pfv)), "max_ppr_kpa": float(np.nanmax(ppr)),
            "footprint_ha": float(np.count_nonzero(footprint)) * cell_area / 1e4,
            "pft_p90": float(np.percentile(pft[footprint], 90)),
            "max_pft": float(np.nanmax(pft)),
            "release_p90": float(np.percentile(seeded, 90)), "release_max": float(seeded.max())}


def run_variant(firn, folder, name, threads, reuse):
    out = folder / "runs" / name
    if not (reuse and (out / "summary.json").exists()):
        run_firn(firn, folder, name, threads, out)
    with open(out / "summary.json", encoding="utf-8") as f:
        s = json.load(f)
    row = {"variant": name, "particles": s["particles"], "wall_seconds": s["wall_seconds"],
           "steps": s["steps"], "particle_steps_per_second": s["particle_steps_per_second"],
           "end_time": s["end_time"], "stop_reason": s.get("stop_reason", "end_time"),
           "runout_length": s.get("runout_length", float("nan")),
           "alpha_angle_deg": s["alpha_angle_deg"]}
    row.update(map_figures(out / "rasters"))
    return row


def run_firn(firn, folder, name, threads, out):
    cmd = [str(firn), "run", str(folder / "helix.toml"), "--quiet", "--threads", str(threads),
           "--out", str(out)]
    for setting in VARIANTS[name][1]:
        cmd += ["--set", setting]
    print(" ".join(cmd), flush=True)
    subprocess.run(cmd, check=True)


def markdown(rows):
    lines = ["| variant | particles | wall (s) | steps | particle-steps/s | end (s) | ended by |"
             " max pfv (m/s) | max ppr (kPa) | footprint (ha) | pft p90 / max (m) |"
             " release raster p90 / max (m) | runout (m) | α (°) |", "|---" * 14 + "|"]
    for r in rows:
        lines.append(
            f"| {r['variant']} | {r['particles']} | {r['wall_seconds']:.0f} | {r['steps']} | "
            f"{r['particle_steps_per_second'] / 1e6:.2f} M | {r['end_time']:.1f} | "
            f"{r['stop_reason']} | {r['max_pfv']:.1f} | {r['max_ppr_kpa']:.0f} | "
            f"{r['footprint_ha']:.1f} | {r['pft_p90']:.2f} / {r['max_pft']:.2f} | "
            f"{r['release_p90']:.2f} / {r['release_max']:.2f} | "
            f"{r['runout_length']:.0f} | {r['alpha_angle_deg']:.1f} |")
    return "\n".join(lines) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--firn", default=str(ROOT / "build/firn"))
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--out", default=str(ROOT / "bench/results/helix"))
    parser.add_argument("--work", default=str(ROOT / "out/helix-bench"))
    parser.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=list(VARIANTS))
    parser.add_argument("--inputs-only", action="store_true")
    parser.add_argument("--reuse", action="store_true",
                        help="take a variant's earlier run from OUT/runs/ where it has a summary")
    args = parser.parse_args()
    folder, out = pathlib.Path(args.work), pathlib.Path(args.out)
    area = write_inputs(folder)
    print(f"helix inputs in {folder}: release {area:.0f} m^2 x {RELEASE_THICKNESS:g} m")
    if args.inputs_only:
        return 0
    rows = [run_variant(args.firn, folder, name, args.threads, args.reuse) for name in args.variants]
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "helix.csv", "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    table = markdown(rows)
    (out / "helix.md").write_text(table, encoding="utf-8")
    print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
