#!/usr/bin/python3
"""`firn report` end to end: a short 2D Propagation Saw Test whose crack runs the column, and a
granular slide without a weak layer; the report's HTML, PNGs and tables are checked on what they
show, not only on their existence.

usage: test_report.py --firn PATH/TO/firn --work SCRATCH_DIR   (exit status 0: all passed)
"""
import argparse
import base64
import csv
import io
import json
import math
import pathlib
import re
import shutil
import subprocess
import sys

import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402

# scenes/pst.toml shortened to a 3 m column with a 0.8 m cut (above critical: the crack runs
# the column in about 0.06 s at ~30 m/s). 16 000 particles, 0.15 s simulated: ~7 s on 2 cores.
PST = """
[simulation]
name = "report-pst"
dimension = 2
end_time = 0.15
frame_rate = 200
gravity = [0.0, -9.81]
gravity_ramp = 0.05

[grid]
dx = 0.02
particles_per_cell = 4

[[material]]
name = "slab"
model = "snow"
density = 250.0
youngs_modulus = 5.0e6
poisson_ratio = 0.2
critical_state_slope = 1.0
cohesion_ratio = 0.5
initial_p0 = 6.0e4
hardening = 0.5

[[material]]
name = "weak"
model = "weak_layer"
density = 100.0
youngs_modulus = 4.8e5
poisson_ratio = 0.2
critical_state_slope = 1.0
cohesion_ratio = 0.1
initial_p0 = 3450.0
hardening = 0.015
softening = 100.0
dynamic_critical_state_slope = 1.2

[[terrain]]
shape = "plane"
point = [0.0, 0.0]
normal = [0.0, 1.0]
friction = 0.5

[[body]]
name = "weak"
material = "weak"
shape = "layer"
thickness = 0.06
x_range = [0.0, 3.0]

[[body]]
name = "slab"
material = "slab"
shape = "layer"
on_top_of = "weak"
thickness = 0.5
x_range = [0.0, 3.0]

[[cut]]
layer = "weak"
from_x = 0.0
length = 0.8

[output]
volumes = []
"""

# The same column in 3D, 1.5 m long and 0.25 m wide on a coarse grid, for the x-z raster: ~3 s.
PST_3D = (PST.replace('name = "report-pst"', 'name = "report-pst3d"')
          .replace("dimension = 2", "dimension = 3")
          .replace("end_time = 0.15", "end_time = 0.06")
          .replace("frame_rate = 200", "frame_rate = 100")
          .replace("gravity = [0.0, -9.81]", "gravity = [0.0, -9.81, 0.0]")
          .replace("dx = 0.02", "dx = 0.05")
          .replace("point = [0.0, 0.0]", "point = [0.0, 0.0, 0.0]")
          .replace("normal = [0.0, 1.0]", "normal = [0.0, 1.0, 0.0]")
          .replace("x_range = [0.0, 3.0]", "x_range = [0.0, 1.5]\nz_range = [0.0, 0.25]"))

# A granular slide without any weak layer (scenes/granular-slide.toml, coarser and shorter): ~1 s.
SLIDE = """
[simulation]
name = "report-slide"
dimension = 2
end_time = 1.0
frame_rate = 12

[grid]
dx = 0.1
particles_per_cell = 4

[[material]]
name = "snow"
model = "granular"
friction_angle = 35.0

[[terrain]]
shape = "profile"
points = [[0.0, 13.0], [5.0, 10.0], [12.0, 4.0], [18.0, 1.0], [25.0, 0.0], [40.0, 0.0]]
friction = 0.3

[[material]]
name = "ice"
model = "elastic"
density = 900.0
youngs_modulus = 1.0e7

[[body]]
material = "snow"
shape = "layer"
thickness = 0.5
x_range = [3.0, 12.0]

# Snow that never moves, beyond the slide's reach: no part of the release or the deposit.
[[body]]
material = "ice"
shape = "layer"
thickness = 0.3
x_range = [32.0, 38.0]

[output]
volumes = []
"""

# A 2 m snow slab on a 30 degree slip slope without gravity, its halves pulled apart at 1 m/s:
# it breaks in tension near x = 1 m in the first steps (as tests/slab_fracture_test.cc): ~1 s.
PULLED = """
[simulation]
name = "report-pulled"
dimension = 2
end_time = 0.04
frame_rate = 200
gravity = [0.0, 0.0]

[grid]
dx = 0.05
particles_per_cell = 4

[[material]]
name = "slab"
model = "snow"
youngs_modulus = 1.0e6
initial_p0 = 2000.0

[[terrain]]
shape = "plane"
point = [0.0, 0.0]
normal = [0.5, 0.8660254]
boundary = "slip"

[[body]]
material = "slab"
shape = "layer"
thickness = 0.3
x_range = [0.0, 1.0]
velocity = [-0.8660254, 0.5]

[[body]]
material = "slab"
shape = "layer"
thickness = 0.3
x_range = [1.0, 2.0]
velocity = [0.8660254, -0.5]

[output]
volumes = []
"""

FAILURES = []


def check(condition, message):
    print(("ok   " if condition else "FAIL ") + message)
    if not condition:
        FAILURES.append(message)
    return condition


def firn(binary, *args, expect=0):
    result = subprocess.run([binary, *args], capture_output=True, text=True)
    if result.returncode != expect:
        sys.exit(f"firn {' '.join(args)}: exit {result.returncode}, expected {expect}\n"
                 f"{result.stdout}{result.stderr}")
    return result


def run_scene(binary, work, name, text):
    scene = work / f"{name}.toml"
    scene.write_text(text)
    out = work / name
    shutil.rmtree(out, ignore_errors=True)
    firn(binary, "run", str(scene), "--out", str(out), "--threads", "2", "--quiet")
    return out


def read_table(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) if r[k] else np.nan for r in rows]) for k in rows[0]}


def check_html(report_dir, expected_images):
    """Self-contained: every image a PNG data URI, nothing fetched from elsewhere."""
    page = (report_dir / "report.html").read_text(encoding="utf-8")
    images = re.findall(r'<img [^>]*src="([^"]*)"', page)
    check(len(images) == expected_images,
          f"report.html embeds {len(images)} images (expected {expected_images})")
    uris = [s for s in images if s.startswith("data:image/png;base64,")]
    check(len(uris) == len(images), "every <img> is a data:image/png;base64 URI")
    for uri in uris:
        png = base64.b64decode(uri.split(",", 1)[1])
        if not check(png[:8] == b"\x89PNG\r\n\x1a\n", "an embedded image is a PNG"):
            continue
        check(mpimg.imread(io.BytesIO(png)).shape[0] > 100, "an embedded PNG decodes")
    external = re.findall(r'(?:src|href)="(?!data:)[^"]*"', page)
    check(not external, f"no external src/href ({external[:3]})")
    check("<table>" in page and "max_speed" in page, "the summary table is there")
    return page


def check_png(path):
    """Decodes, and is not blank: pixel variance, non-background pixels, and the coloured
    pixels of the data (every chart draws its data in colour, axes and text in grey)."""
    image = mpimg.imread(path)[..., :3]
    ink = np.mean(np.any(image < 0.9, axis=2))
    coloured = np.sum(image.max(axis=2) - image.min(axis=2) > 0.3)
    check(image.std() > 0.05 and ink > 0.02 and coloured > 500,
          f"{path.name} is not blank (std {image.std():.3f}, non-white {ink:.1%}, "
          f"{coloured} coloured pixels)")
    return image


def panel(image, left, right, bottom=0.15, top=0.85):
    """The part of an image between fractions of its width and height (from the top)."""
    h, w = image.shape[:2]
    return image[int(bottom * h):int(top * h), int(left * w):int(right * w)]


def check_pst(binary, work):
    out = run_scene(binary, work, "pst", PST)
    metrics = read_table(out / "metrics.csv")
    tip = metrics["crack_tip_x"]
    check(np.nanmax(tip) > 2.5, f"the crack runs the column (tip reaches {np.nanmax(tip):.2f} m)")
    # The tip timed to the step runs the same way, step after step, and ends where the frames'
    # tip ends (within one cell, dx 0.03).
    steps = json.loads((out / "summary.json").read_text())["crack_tip_steps"]
    times, xs = np.array([s["time"] for s in steps]), np.array([s["x"] for s in steps])
    check(len(steps) > 10 and bool(np.all(np.diff(times) > 0)) and bool(np.all(np.diff(xs) > 0))
          and abs(xs[-1] - tip[np.isfinite(tip)][-1]) <= 0.031,
          f"crack_tip_steps: {len(steps)} steps, x rising to {xs[-1] if len(xs) else None} m")

    # Automatic map times: 4 frames while the crack runs.
    path = firn(binary, "report", str(out), "--quiet").stdout.strip()
    report_dir = out / "report"
    check(pathlib.Path(path) == report_dir / "report.html", f"prints the report's path ({path})")
    maps = read_table(report_dir / "data" / "map_frames.csv")
    running = metrics["time"][np.isfinite(tip)]
    check(len(maps["time"]) == 4 and maps["time"].min() >= running.min() and
          maps["time"].max() <= running.max(),
          f"automatic map times {list(maps['time'])} lie while the crack runs")

    weak = read_table(report_dir / "data" / "weak_layer.csv")
    frac = weak["failed_fraction"]
    check(bool(np.all((frac >= 0) & (frac <= 1))), "failed fractions lie in [0, 1]")
    check(bool(np.all((weak["x"] > 0.8 - 0.02) & (weak["x"] < 3.0 + 0.02))),
          "weak-layer cells lie on the layer, past the saw cut (0.8 to 3 m)")
    check(bool(np.all(weak["z"] == 0)), "2D cells have z = 0")
    check(bool(np.all(np.isfinite(weak["p"]))) and np.nanmax(weak["p"]) > 100,
          "weak-layer pressure is finite and loaded by the slab")
    speed = weak["slab_speed"]
    check(bool(np.all(speed[np.isfinite(speed)] >= 0)) and np.nanmax(speed) > 0.05,
          "slab speeds are non-negative and the slab moves")
    # The slab's p: given exactly where the column has slab (as its speed). This PST starts
    # unstressed (no settling): as gravity loads it the slab is compressed by its own weight
    # (p > 0 in most columns at the map times), and where the layer collapses under it, pulled
    # apart in places (p < 0).
    slab_p = weak["slab_p"]
    check(np.array_equal(np.isfinite(slab_p), np.isfinite(speed)),
          "the slab's p is given in the columns that have slab")
    mapped = np.isin(weak["frame"], maps["frame"])
    check(np.nanmedian(slab_p[mapped]) > 0 and np.nanmin(slab_p) < 0,
          f"the slab is compressed by its weight (median p {np.nanmedian(slab_p[mapped]):.0f} Pa "
          f"at the map times) and in tension in places (least {np.nanmin(slab_p):.0f} Pa)")

    # The frame at which the tip is nearest the middle of its travel: the weak layer there is
    # failed behind the tip and elastic ahead of it.
    middle = 0.5 * (np.nanmin(tip) + np.nanmax(tip))
    halfway = metrics["time"][np.nanargmin(np.abs(tip - middle))]
    firn(binary, "report", str(out), "--times", f"{halfway:.4f},{metrics['time'][-1]:.4f}",
         "--quiet")
    maps = read_table(report_dir / "data" / "map_frames.csv")
    check(list(maps["time"]) == sorted(maps["time"]) and len(maps["time"]) == 2,
          f"--times gives those two maps ({list(maps['time'])})")
    weak = read_table(report_dir / "data" / "weak_layer.csv")
    at = np.isclose(weak["time"], maps["time"][0])
    failed, elastic = np.sum(weak["failed_fraction"][at] > 0.5), np.sum(
        weak["failed_fraction"][at] == 0)
    check(failed > 5 and elastic > 5,
          f"halfway the map has failed ({failed}) and elastic ({elastic}) cells")
    tip_then = tip[np.isclose(metrics["time"], maps["time"][0])][0]
    up, down = at & (weak["x"] < tip_then - 0.1), at & (weak["x"] > tip_then + 0.3)
    check(np.mean(weak["failed_fraction"][up]) > 0.5 > np.mean(weak["failed_fraction"][down]),
          "failed behind the crack tip, elastic well ahead of it")
    # strength_used: a cell none of whose particles ever yielded still has its initial surface,
    # so its stress lies inside it (<= 1, float stresses: 1e-3); ahead of the tip the slab loads
    # the layer (> 5 %); the collapsed layer behind the tip carries little (< 1).
    used = weak["strength_used"]
    elastic_cells = at & (weak["failed_fraction"] == 0)
    check(np.all(used[elastic_cells] <= 1.001),
          f"elastic cells use at most their strength (max {np.max(used[elastic_cells]):.4f})")
    check(np.all(used[down] > 0.05), f"the slab loads the layer ahead of the tip (min "
          f"{np.min(used[down]):.3f})")
    check((report_dir / "strength_used.png").exists(), "the static load chart is drawn")

    check_html(report_dir, expected_images=8)
    for name in ("failure_maps", "failure_profiles", "strength_used", "crack", "slab_fractures",
                 "flow", "mcclung_gauer"):
        check_png(report_dir / f"{name}.png")
    # The x-time image of the failed share (top left of five panels in three rows): black
    # elastic below the crack's path, white/grey failed above it.
    left = panel(check_png(report_dir / "failure_maps.png"), 0.06, 0.24, 0.05, 0.28).mean(axis=2)
    check(np.mean(left < 0.1) > 0.1 and np.mean((left > 0.6) & (left < 0.999)) > 0.05,
          f"the failure map shows elastic (black {np.mean(left < 0.1):.0%}) and failed "
          f"(light {np.mean((left > 0.6) & (left < 0.999)):.0%}) cells")

    # Errors a user can make.
    bad = firn(binary, "report", str(out), "--times", "9", expect=1)
    check("--times" in bad.stderr and "outside the run" in bad.stderr,
          f"a time past the run is refused: {bad.stderr.strip()}")
    missing = firn(binary, "report", str(work / "no-such-run"), expect=3)
    check("no-such-run" in missing.stderr, f"a missing folder is named: {missing.stderr.strip()}")


def check_pst_3d(binary, work):
    out = run_scene(binary, work, "pst3d", PST_3D)
    firn(binary, "report", str(out), "--quiet")
    report_dir = out / "report"
    weak = read_table(report_dir / "data" / "weak_layer.csv")
    maps = read_table(report_dir / "data" / "map_frames.csv")
    frames = np.unique(weak["frame"])
    check(np.array_equal(frames, np.union1d(maps["frame"], [0])),
          f"3D: only the first frame and the map frames are binned ({frames})")
    z_cells = np.unique(weak["z"])
    check(np.allclose(z_cells, [0.025, 0.075, 0.125, 0.175, 0.225]),
          f"3D: cells across the 0.25 m width at z = {z_cells}")
    first = weak["frame"] == frames[0]
    check(np.sum(first) == 5 * np.unique(weak["x"][first]).size,
          "3D: each map is a full x-z raster")
    # The crack's arrival over the bed: cells on the layer's plan (x 0.8-1.5 m beyond the cut,
    # z 0-0.25 m), cracked later the farther from the cut: the crack runs along x.
    arrival = read_table(out / "crack_arrival.csv")
    check(arrival["x"].size > 0 and np.all((arrival["z"] > 0) & (arrival["z"] < 0.25)) and
          np.all((arrival["x"] > 0.75) & (arrival["x"] < 1.5)),
          f"3D: {arrival['x'].size} crack_arrival.csv cells on the layer's plan beyond the cut")
    r = np.corrcoef(arrival["x"], arrival["time"])[0, 1] if arrival["x"].size > 2 else 0.0
    check(r > 0.5, f"3D: the crack arrives later farther from the cut (correlation {r:.2f})")
    check_html(report_dir, expected_images=8)
    check_png(report_dir / "strength_used.png")
    check_png(report_dir / "failure_maps.png")
    check_png(report_dir / "slab_fractures.png")
    check_png(report_dir / "crack_arrival.png")


def check_slide(binary, work):
    out = run_scene(binary, work, "slide", SLIDE)
    # A heightfield's file in scene.toml is relative to the original scene's folder: the
    # report must not need it (it reads no terrain).
    with open(out / "scene.toml", "a") as f:
        f.write('\n[[terrain]]\nshape = "heightfield"\nfile = "not-here.asc"\n')
    firn(binary, "report", str(out), "--quiet")
    report_dir = out / "report"
    page = check_html(report_dir, expected_images=3)
    check("no weak layer" in page, "a run without a weak layer says so instead of maps")
    check("no slab" in page, "a run without a snow slab says so instead of slab fractures")
    check(not (report_dir / "slab_fractures.png").exists(), "no slab fracture chart is drawn")
    check(not (report_dir / "failure_maps.png").exists(), "no failure map is drawn")
    image = check_png(report_dir / "mcclung_gauer.png")
    # Our point is a red marker on both panels.
    red = (image[..., 0] > 0.7) & (image[..., 1] < 0.3) & (image[..., 2] < 0.3)
    check(red.sum() > 100, f"the run's point is drawn ({red.sum()} red pixels)")
    info = json.loads((report_dir / "data" / "report.json").read_text())
    check(info["deposit_far_x"] > info["release_top_x"], "the deposit lies down-slope of the top")
    # The snow's depth along the path (deposit.csv): in 2D each particle is dx^2 / 4 as seeded
    # (dx 0.1, 4 per cell), so depth times dx summed along x is the particle count times that,
    # the same at the start and the end (nothing leaves); the slide has moved down-slope and its
    # deposit ends at runout_x (within a cell).
    depth = read_table(report_dir / "data" / "deposit.csv")
    volume = [np.nansum(depth[k]) * 0.1 for k in ("depth_start", "depth_end")]
    particles = json.loads((out / "summary.json").read_text())["particles"]
    check(abs(volume[0] - particles * 0.01 / 4) < 1e-6 and abs(volume[1] - volume[0]) < 1e-6,
          f"deposit.csv holds every particle's volume at both ends ({volume[0]:.4f}, "
          f"{volume[1]:.4f} m^2; {particles} particles: {particles * 0.01 / 4:.4f})")
    slide = depth["x"] < 30.0  # the ice beyond x = 32 m stays where it was
    x_end = depth["x"][slide & np.isfinite(depth["depth_end"])]
    x_start = depth["x"][slide & np.isfinite(depth["depth_start"])]
    runout = json.loads((out / "summary.json").read_text())["runout_x"]
    check(x_end.max() > x_start.max() and abs(x_end.max() - runout) <= 0.1,
          f"the deposit reaches past the release to runout_x (last cell {x_end.max():.3g} m, "
          f"runout_x {runout:.3g} m, release ended at {x_start.max():.3g} m)")
    check_png(report_dir / "deposit.png")
    # H and L run from the release's top to the deposit's farthest point of the snow that moved
    # (summary.json), not to the ice that never did (report.json's ends, of every particle).
    summary = json.loads((out / "summary.json").read_text())
    check(info["deposit_far_x"] > 37.9 and summary["runout_x"] < 30.0,
          f"report.json's farthest particle is the still ice ({info['deposit_far_x']:.3g} m), "
          f"runout_x the slide's ({summary['runout_x']:.3g} m)")
    gauer = re.search(r"\(g H / 2\)\^1/2 \(Gauer\)</td><td class=num>([0-9.eE+-]+)", page)
    height = summary["release_top_y"] - summary["runout_y"]
    check(height < info["release_top_y"] - info["deposit_far_y"] - 1.0,
          f"the moved snow's drop ({height:.3g} m) is not the drop to the still ice")
    length = re.search(r"path length L \(report\)</td><td class=num>([0-9.eE+-]+)", page)
    expected = math.hypot(summary["runout_x"] - summary["release_top_x"], height)
    check(length is not None and abs(float(length.group(1)) - expected) < 1e-3 * expected,
          f"L is the moved snow's ({length and length.group(1)} m, expected {expected:.4g})")
    check(gauer is not None and abs(float(gauer.group(1)) - (9.81 * height / 2) ** 0.5) < 1e-3,
          f"the summary table gives Gauer's (g H / 2)^1/2 for H = {height:.3g} m "
          f"({gauer and gauer.group(1)} m/s)")
    check("u_m, fastest particle (report)" in page,
          "without velocity volumes u_m is the fastest particle's speed")

    # With density and velocity volumes u_m is the grid's flow speed: for this APIC slide the
    # same motion as the particles', a little below the fastest particle's own speed.
    with_volumes = run_scene(binary, work, "slide-volumes",
                             SLIDE.replace("volumes = []", 'volumes = ["density", "velocity"]'))
    firn(binary, "report", str(with_volumes), "--quiet")
    page = (with_volumes / "report" / "report.html").read_text()
    found = re.search(r"u_m, grid flow speed \(report\)</td><td class=num>([0-9.eE+-]+)", page)
    fastest = json.loads((with_volumes / "summary.json").read_text())["max_speed"]
    check(found is not None and 0.5 * fastest < float(found.group(1)) <= 1.01 * fastest,
          f"with volumes u_m is the grid flow speed ({found and found.group(1)} m/s, fastest "
          f"particle {fastest:.3g} m/s)")


def check_pulled_slab(binary, work):
    out = run_scene(binary, work, "pulled", PULLED)
    summary = json.loads((out / "summary.json").read_text())
    fractures = summary["slab_fractures"]
    check(summary["slab_fracture_count"] == len(fractures) >= 1,
          f"the pulled slab fractures ({len(fractures)} in summary.json)")
    check(all(abs(f["x"] - 0.9) < 0.25 for f in fractures[:1]),
          f"where it is pulled apart ({[f['x'] for f in fractures]})")
    metrics = read_table(out / "metrics.csv")
    check(metrics["slab_fractures"][-1] == len(fractures) and metrics["slab_blocks"][-1] >= 2,
          "metrics.csv counts the fractures and the blocks")
    firn(binary, "report", str(out), "--quiet")
    report_dir = out / "report"
    page = check_html(report_dir, expected_images=4)
    check("distance behind crack tip" in page and "No slab fracture" not in page,
          "the report lists the slab fractures")
    image = check_png(report_dir / "slab_fractures.png")
    # The fractures are grey squares, the blocks a purple line.
    purple = (image[..., 0] > 0.45) & (image[..., 2] > 0.6) & (image[..., 1] < 0.55)
    check(purple.sum() > 50, f"the block count is drawn ({purple.sum()} purple pixels)")


def check_behind_along_slope():
    """A slab fracture's distance behind the tip, from summary.json's distance along x to the
    paper's along the ground: on a profile of a 45 degree and a flat segment, 1 m along x on 45
    degrees is sqrt 2 m; the tip on the fracture's side of the crack's start; None without a
    profile."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "render"))
    import report  # noqa: E402

    class Run:
        dimension = 2
        scene = {"terrain": [{"shape": "profile", "points": [[0, 10], [10, 0], [20, 0]]}]}
        summary = {"crack_tip_steps": [{"time": 0.2, "x": 12.0}, {"time": 0.3, "x": 8.0}]}

    run = Run()
    up = report.behind_along_slope(run, {"x": 6.0, "distance_behind_crack_tip": 1.0})
    check(abs(up - math.sqrt(2.0)) < 1e-9, f"up-slope of the start, on 45 degrees ({up})")
    across = report.behind_along_slope(run, {"x": 10.5, "distance_behind_crack_tip": 1.0})
    check(abs(across - (0.5 * math.sqrt(2.0) + 0.5)) < 1e-9,
          f"across the kink: 0.5 m on 45 degrees and 0.5 m flat ({across})")
    down = report.behind_along_slope(run, {"x": 14.0, "distance_behind_crack_tip": -0.5})
    check(abs(down + 0.5) < 1e-9, f"ahead of the down-slope tip on the flat ({down})")
    began = {"x": 6.0, "distance_behind_crack_tip": 1.0, "start_time": 0.25,
             "distance_behind_crack_tip_at_start": 0.25}
    start = report.behind_distance(run, began, began=True)
    check(abs(start - 0.25 * math.sqrt(2.0)) < 1e-9, f"as it began, on 45 degrees ({start})")
    check(report.behind_distance(run, {"x": 6.0, "distance_behind_crack_tip": 1.0},
                                 began=True) is None,
          "a run written before start_time: no distance as it began")
    run.scene = {"terrain": [{"shape": "plane"}]}
    check(report.behind_along_slope(run, {"x": 6.0, "distance_behind_crack_tip": 1.0}) is None,
          "no profile: no distance along the slope")
    check(report.behind_distance(run, began, began=True) == 0.25,
          "no profile: as it began, along x")


def check_crack_origin():
    """The arrival chart's origin and front speeds on a made-up bed: a crack spreading in circles
    at 25 m/s from (5, 2) m from t = 0.2 s, and one cell at the far corner that yielded on its
    own at t = 0 (as a free corner's particle beyond its strength does): the origin is the
    circle's centre, not the lone cell, and the three fits read 25 m/s (exact data: 1e-6)."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "render"))
    import report  # noqa: E402  (render/report.py, which `firn report` runs)
    dx = 0.1
    gx, gz = np.meshgrid(np.arange(0, 101) * dx, np.arange(0, 41) * dx)
    x, z = gx.ravel(), gz.ravel()
    t = 0.2 + np.hypot(x - 5.0, z - 2.0) / 25.0
    t[np.argmin(x + z)] = 0.0
    speeds = report.arrival_speeds(x, z, t, dx)
    x0, z0, t0 = speeds["origin"]
    check(abs(x0 - 5.0) < 1e-9 and abs(z0 - 2.0) < 1e-9 and abs(t0 - 0.2) < 1e-9,
          f"the crack's origin is the circles' centre, not the lone early cell ({x0}, {z0}, {t0})")
    for way in ("up", "down", "across"):
        check(speeds[way] is not None and abs(speeds[way] - 25.0) < 1e-6,
              f"{way} front speed 25 m/s: {speeds[way]}")


def check_behind_front():
    """The 3D distance behind the crack's front on the same made-up bed (circles at 25 m/s from
    (5, 2) m from t = 0.2 s): when the front's radius is 2.05 m, a fracture 1 m from the centre
    is 1.05 m behind it and one 3 m from the centre 0.95 m ahead of it, each within one cell
    (0.1 m: the front is read off cell centres), and so is one off the bed's cells; once every cell has cracked there is no front
    left, and without crack_arrival.csv no measure."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "render"))
    import report  # noqa: E402
    dx = 0.1
    gx, gz = np.meshgrid(np.arange(0, 101) * dx, np.arange(0, 61) * dx)
    x, z = gx.ravel(), gz.ravel()
    arrival = (x, z, 0.2 + np.hypot(x - 5.0, z - 2.0) / 25.0)
    when = 0.2 + 2.05 / 25.0
    behind = report.behind_front(arrival, {"x": 5.0, "z": 3.0, "time": when}, dx)
    check(behind is not None and abs(behind - 1.05) <= dx, f"1.05 m behind the front ({behind})")
    ahead = report.behind_front(arrival, {"x": 5.0, "z": 5.0, "time": when}, dx)
    check(ahead is not None and abs(ahead + 0.95) <= dx, f"0.95 m ahead of the front ({ahead})")
    check(report.behind_front(arrival, {"x": 5.0, "z": 3.0, "time": 10.0}, dx) is None,
          "no front once the whole bed has cracked")
    outside = report.behind_front(arrival, {"x": 5.0, "z": 7.0, "time": when}, dx)
    check(outside is not None and abs(outside + 2.95) <= dx,
          f"off the bed (no cell of its own): ahead, 2.95 m ({outside})")
    check(report.behind_front(None, {"x": 5.0, "z": 3.0, "time": when}, dx) is None,
          "no crack_arrival.csv: no measure")

    class Run:  # a 3D run: where a fracture began is read against the front at start_time
        dimension = 3

        def arrival(self):
            return arrival
    Run.dx = dx
    began = report.behind_distance(Run(), {"x": 5.0, "z": 3.0, "time": 10.0,
                                        "start_time": 0.2 + 1.55 / 25.0}, began=True)
    check(began is not None and abs(began - 0.55) <= dx,
          f"as it began, 0.55 m behind the front in plan ({began})")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--firn", required=True)
    parser.add_argument("--work", required=True)
    args = parser.parse_args()
    work = pathlib.Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    check_crack_origin()
    check_behind_front()
    check_behind_along_slope()
    check_pst(args.firn, work)
    check_pst_3d(args.firn, work)
    check_slide(args.firn, work)
    check_pulled_slab(args.firn, work)
    if FAILURES:
        print(f"{len(FAILURES)} check(s) failed")
        return 1
    print("all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
