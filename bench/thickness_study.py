#!/usr/bin/python3
"""Flow thickness of a sheet thinner than a cell: a dam break on a DEM against its analytic profile.

Why: on the avaHelix case (issue 54) Firn's peak flow thickness was thinner than AvaFrame's
(90th percentile 1.22 against 1.80 m) while the speeds agreed. There the 1 m release is less
than half a cell (dx 2.5 m) thick. This study runs validation.md's V11 dam break (slope 22 deg,
Coulomb bed delta 21 deg, a 1 m layer let go at t = 0) through the same pipeline as a hazard
run: an inclined-plane DEM, a release polygon, the peak rasters; at several dx, from a layer
2.5 cells thick to one 0.4 of a cell thick (the helix's), with the helix's snow (granular,
phi 35 deg, 200 kg/m^3). The thickness profile at t along the strip's centre line (`dft`, the
last sample, on raster cells of dx: two particle spacings, so that a cell's thickness is a
mean and not a particle's footprint) is compared, after the same cloud-in-cell spreading, with the shallow-water rarefaction (Mangeney et al. 2000), in the frame
sliding with m0 t^2 / 2:

    h = (2 a - xi / t)^2 / (9 K g cos theta),   -a t < xi < 2 a t,   a = sqrt(K g cos theta h0)

with Savage and Hutter's active K (a frictional continuum spreading, 0.60 for phi 35, delta 21)
and with K = 1 (the hydrostatic depth-averaged model, AvaFrame's). Runs in WORK (default
out/thickness-study/, git-ignored); writes OUT/thickness.csv, OUT/thickness.md and
OUT/thickness.png (default bench/results/thickness/).

    /usr/bin/python3 bench/thickness_study.py [--firn build/firn] [--dx 5 2.5 1.25 0.625]
"""
import argparse
import csv
import json
import math
import pathlib
import subprocess
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from esri_ascii import read_asc  # noqa: E402
from helix import SNOW_MATERIAL  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parent.parent
G = 9.81
THETA, DELTA, PHI = 22.0, 21.0, 35.0  # PHI: SNOW_MATERIAL's friction angle
H0 = 1.0
LENGTH, WIDTH = 60.0, 80.0  # m along the slope and across: see the bounds in `layout`
T_END = 10.0
BAND = 15.0  # m each side of the centre line: the side edges' rarefactions stop 17 m from it

SCENE = """[simulation]
name = "dam-break-dem"
dimension = 3
end_time = {t_end}
frame_rate = 1.0
stop_at_rest = false

[grid]
dx = {dx}

{snow}
[[terrain]]
shape = "heightfield"
file = "plane.asc"
boundary = "friction"
friction = {mu}

[[body]]
name = "release"
material = "snow"
shape = "polygon"
file = "release.geojson"
thickness = {h0}

[output]
particles = false
volumes = []
raster_cell = {dx}
"""


def k_active(phi, delta):
    """Savage and Hutter (1989): K = 2 sec^2 phi (1 - sqrt(1 - cos^2 phi sec^2 delta)) - 1."""
    cp, cd = math.cos(math.radians(phi)), math.cos(math.radians(delta))
    return 2 / cp**2 * (1 - math.sqrt(1 - cp**2 / cd**2)) - 1


def rarefaction(s, k, t):
    """Thickness normal to the bed at distance s (m) along the slope from the dam, time t."""
    cos_t = math.cos(math.radians(THETA))
    a = math.sqrt(k * G * cos_t * H0)
    m0 = G * (math.sin(math.radians(THETA)) - math.tan(math.radians(DELTA)) * cos_t)
    xi = np.asarray(s) - 0.5 * m0 * t * t
    h = (2 * a - xi / t) ** 2 / (9 * k * G * cos_t)
    return np.where(xi < -a * t, H0, np.where(xi > 2 * a * t, 0.0, h))


def layout():
    """The plane runs down +x (plan) from x = 0; the release's lower edge (the dam) at the plan
    distance LENGTH cos(theta). The rarefaction reaches up the layer a t = 2.3 m/s x 10 s = 23 m
    and the back end's comes down as far, so 60 m keeps them apart; the side edges' come in 23 m
    each, so the centre line of 80 m stays a plane flow; the front is 56 m below the dam at 10 s
    and the plane ends 100 m below it."""
    cos_t = math.cos(math.radians(THETA))
    dam = (LENGTH + 10.0) * cos_t
    extent = dam + 100.0 * cos_t
    return dam, extent


def write_inputs(folder, dx):
    folder.mkdir(parents=True, exist_ok=True)
    dam, extent = layout()
    cell = 2.0
    cols, rows = int(extent / cell) + 1, int((WIDTH + 40.0) / cell) + 1
    xs = cell * np.arange(cols)
    z = np.tile(-math.tan(math.radians(THETA)) * xs + 200.0, (rows, 1))
    with open(folder / "plane.asc", "w", encoding="ascii") as f:
        f.write(f"ncols {cols}\nnrows {rows}\nxllcenter 0\nyllcenter 0\ncellsize {cell:g}\n"
                "nodata_value -9999\n")
        np.savetxt(f, z, fmt="%.4f")
    top = dam - LENGTH * math.cos(math.radians(THETA))
    y0, y1 = 20.0, 20.0 + WIDTH
    ring = [[top, y0], [dam, y0], [dam, y1], [top, y1], [top, y0]]
    release = {"type": "FeatureCollection", "features": [{
        "type": "Feature", "properties": {},
        "geometry": {"type": "Polygon", "coordinates": [ring]}}]}
    (folder / "release.geojson").write_text(json.dumps(release), encoding="utf-8")
    (folder / "scene.toml").write_text(SCENE.format(
        t_end=T_END, dx=dx, snow=SNOW_MATERIAL, mu=math.tan(math.radians(DELTA)), h0=H0),
        encoding="utf-8")
    return dam, 20.0 + 0.5 * WIDTH


def centre_profile(rasters, dam, y_centre, band):
    """The deposit (last-sample) thickness along the centre line, averaged over +-band m across,
    against the distance along the slope from the dam."""
    header, h = read_asc(rasters / "dft.asc")
    h = np.nan_to_num(h)
    cell = header["cellsize"]
    x0 = header.get("xllcenter", header.get("xllcorner", 0.0) + 0.5 * cell)
    y0 = header.get("yllcenter", header.get("yllcorner", 0.0) + 0.5 * cell)
    ys = y0 + cell * np.arange(h.shape[0])
    rows = np.abs(ys - y_centre) <= band
    xs = x0 + cell * np.arange(h.shape[1])
    return (xs - dam) / math.cos(math.radians(THETA)), h[rows].mean(axis=0)


def smoothed_rarefaction(s, k, cell):
    """The analytic profile as the rasters see it: spread by cloud-in-cell over raster cells of
    `cell` m (plan), a tent of half-width cell / cos(theta) along the slope."""
    w = cell / math.cos(math.radians(THETA))
    u = np.linspace(-w, w, 41)
    tent = 1.0 - np.abs(u) / w
    tent /= tent.sum()
    s = np.asarray(s, dtype=float)
    return sum(wt * rarefaction(s + du, k, T_END) for du, wt in zip(u, tent))


def clean_window(k):
    """Along-slope distances (m) where the semi-infinite solution holds at T_END: below the back
    end's rarefaction, which comes down the layer from its top (at -LENGTH) at a, sliding."""
    cos_t = math.cos(math.radians(THETA))
    a = math.sqrt(k * G * cos_t * H0)
    m0 = G * (math.sin(math.radians(THETA)) - math.tan(math.radians(DELTA)) * cos_t)
    return -LENGTH + 0.5 * m0 * T_END**2 + a * T_END, 80.0


def compare(s, h, k, cell):
    """L1 misfit (m) over the rarefaction and the tongue, against the smoothed analytic."""
    ref = smoothed_rarefaction(s, k, cell)
    lo, hi = clean_window(1.0)
    window = (s > lo) & (s < hi)
    return float(np.mean(np.abs(h[window] - ref[window])))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--firn", default=str(ROOT / "build/firn"))
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--dx", type=float, nargs="+", default=[5.0, 2.5, 1.25, 0.625])
    parser.add_argument("--out", default=str(ROOT / "bench/results/thickness"))
    parser.add_argument("--work", default=str(ROOT / "out/thickness-study"))
    args = parser.parse_args()
    out, work = pathlib.Path(args.out), pathlib.Path(args.work)
    out.mkdir(parents=True, exist_ok=True)
    ka = k_active(PHI, DELTA)
    rows, profiles = [], {}
    for dx in args.dx:
        folder = work / f"dx{dx:g}"
        dam, y_centre = write_inputs(folder, dx)
        subprocess.run([args.firn, "run", str(folder / "scene.toml"), "--quiet", "--threads",
                        str(args.threads), "--out", str(folder / "run")], check=True)
        summary = json.loads((folder / "run" / "summary.json").read_text(encoding="utf-8"))
        s, h = centre_profile(folder / "run" / "rasters", dam, y_centre, BAND)
        profiles[dx] = (s, h)
        wet = s[h > 0.01]
        _, release = read_asc(folder / "run" / "rasters" / "release.asc")
        seeded = np.nan_to_num(release)[np.nan_to_num(release) > 0]
        at = {f"h_at_{d:g}": float(np.interp(d, s, h)) for d in (0.0, 10.0, 20.0, 30.0, 40.0)}
        rows.append({"dx": dx, "cells_per_h0": H0 / dx, "particles": summary["particles"],
                     "wall_seconds": summary["wall_seconds"],
                     "release_p90": float(np.percentile(seeded, 90)),
                     "release_max": float(seeded.max()), "front_m": float(wet.max()), "misfit_k_active": compare(s, h, ka, dx),
                     "misfit_k1": compare(s, h, 1.0, dx), **at})
    ref_at = {k: {f"h_at_{d:g}": float(rarefaction(d, k, T_END))
                  for d in (0.0, 10.0, 20.0, 30.0, 40.0)} for k in (ka, 1.0)}
    with open(out / "thickness.csv", "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    lines = [f"Dam break on 22 deg, delta 21, phi {PHI:g}, h0 {H0:g} m, at t = {T_END:g} s: "
             "thickness (m) at the distance below the dam along the slope",
             "", "| | h0/dx | particles | wall (s) | release raster p90 / max | h at 0 | 10 m |"
             " 20 m | 30 m | 40 m | front (m) | L1 vs K_active | L1 vs K = 1 |", "|---" * 13 + "|"]
    for k, name in ((ka, f"analytic, K_active {ka:.2f}"), (1.0, "analytic, K = 1")):
        a = math.sqrt(k * G * math.cos(math.radians(THETA)) * H0)
        m0 = G * (math.sin(math.radians(THETA))
                  - math.tan(math.radians(DELTA)) * math.cos(math.radians(THETA)))
        r = ref_at[k]
        lines.append(f"| {name} | | | | 1 / 1 | {r['h_at_0']:.3f} | {r['h_at_10']:.3f} | "
                     f"{r['h_at_20']:.3f} | {r['h_at_30']:.3f} | {r['h_at_40']:.3f} | "
                     f"{2 * a * T_END + 0.5 * m0 * T_END**2:.1f} | | |")
    for r in rows:
        lines.append(f"| Firn dx {r['dx']:g} | {r['cells_per_h0']:.2g} | {r['particles']} | "
                     f"{r['wall_seconds']:.0f} | {r['release_p90']:.2f} / {r['release_max']:.2f} | "
                     f"{r['h_at_0']:.3f} | {r['h_at_10']:.3f} | "
                     f"{r['h_at_20']:.3f} | {r['h_at_30']:.3f} | {r['h_at_40']:.3f} | "
                     f"{r['front_m']:.1f} | {r['misfit_k_active']:.3f} | {r['misfit_k1']:.3f} |")
    table = "\n".join(lines) + "\n"
    (out / "thickness.md").write_text(table, encoding="utf-8")
    print(table)

    fig, ax = plt.subplots(figsize=(8, 4))
    s_ref = np.linspace(-30, 80, 600)
    ax.plot(s_ref, rarefaction(s_ref, ka, T_END), "k-", label=f"shallow water, K_active {ka:.2f}")
    ax.plot(s_ref, rarefaction(s_ref, 1.0, T_END), "k--", label="shallow water, K = 1")
    for dx, (s, h) in profiles.items():
        ax.plot(s, h, label=f"Firn dx {dx:g} (h0/dx {H0 / dx:.2g})")
    ax.set_xlim(clean_window(1.0)[0], 80)
    ax.set_xlabel("distance below the dam along the slope (m)")
    ax.set_ylabel("thickness normal to the bed (m)")
    ax.set_title(f"Dam break on a DEM at t = {T_END:g} s (22 deg, delta 21, phi {PHI:g})")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "thickness.png", dpi=120)
    return 0


if __name__ == "__main__":
    sys.exit(main())
