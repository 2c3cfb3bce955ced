#!/usr/bin/env python3
"""Slab fractures behind the running crack on scenes/slope2d.toml (issue 10: the paper's
"en-echelon" fractures, < 1 m behind the weak-layer crack tip in the steep part of the slope).

    /usr/bin/python3 bench/slab_fracture_study.py [--variants NAME ...] [--firn build/firn]
        [--threads N] [--end-time 0.45] [--out DIR] [--seeds S ...]

Runs the scene to --end-time (200 frames per second, eta volumes only) for each variant below
and reports, from summary.json and the eta volumes (read with pyopenvdb):
- the crack's speed along the 45 degree section (its up-slope end's first passes of x = 10 and
  x = 5 m, along the slope), when it reaches the top of the layer (x <= 0.6 m) and its mean
  speed along the slope from the up-slope end of the layer that failed in settling (under the
  snowman) to the top, stalls included (speed_to_top);
- the process zone at x = 7.5 m: how long after softening starts there (the column's largest
  voxel eta >= 0.01, the paper's crack tip) the layer has softened to a third of its cohesion
  (eta >= 1.0; p0 reaches 0 at eta = 1.445 for slope2d's 88 kg/m^3 layer in 2D), and, in the
  frame where softening starts there, how far down the slope the layer is softened that far
  (along the 45 degree slope);
- the slab fractures that go through while the crack runs (before it reaches the top) up-slope
  of the block (x < 10.5 m): position, distance behind the up-slope tip (along the slope, from
  the tip's position timed to the step; summary.json's distance_behind_crack_tip is along x),
  start depth (0: at the weak
  layer, 1: at the surface), where the tip was then and how long after the tip had passed the
  fracture's position it went through; and when each began (its first fractured particle,
  summary.json's start_time) and how far behind the tip it then was.
The variants whose row names another scene (the 3D slope's plane-strain cut, bench/slope3d_cut.toml)
are measured the same way, up-slope of their own snowman (CONTACT_X); the 45 degree section and
the process zone are slope2d's and left empty for them. With --seeds, the distances of the
fractures 3 m or more up-slope of the snowman are pooled per variant and printed at the end.
Writes results.csv into bench/results/slab-fracture/ (or --out); a run of some variants replaces
their rows and keeps the others. With --seeds each variant runs once per seed (`simulation.seed`:
the particles' jitter), its rows named VARIANT@seedS: how much of a row is the seeding's scatter.
"""
import argparse
import csv
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib

import pyopenvdb as vdb

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SLOPE2D = os.path.join(ROOT, "scenes", "slope2d.toml")
CUT_SCENE = os.path.join(ROOT, "bench", "slope3d_cut.toml")
# Where the snowman touches the slab: fractures within 2 m up-slope of it (its edge, where its
# load bends the slab) are left out of the table's "while the crack runs" columns, within 3 m of
# it out of the pooled distances (--variants ... --seeds ...).
CONTACT_X = {SLOPE2D: 12.5, CUT_SCENE: 8.5}
FRAME_RATE = 200.0
SLAB_P0 = 22440.0  # the table's slab initial_p0 at 250 kg/m^3 (firn check scenes/slope2d.toml)

# The trigger until 2026-12-04 (eleventh session): the block dropped 0.3 m onto the slab, landing
# at t = 0.2 s, its snow weak (p0 2 kPa) so that it shattered.
DROPPED = ["body.block.center=[13.0, 4.67]", "material.block.initial_p0=2000"]
# The snowman at rest as the first seed studies of it placed it (2 mm from the shipped centre).
EARLY_REST = ["body.block.center=[12.848, 4.441]"]
# The scene until 2026-12-04: an 88 kg/m^3 weak layer with the table's alpha, the table's slab,
# the dropped block.
BEFORE = DROPPED + ["material.weak.density=88", "material.weak.softening=100",
                    "material.slab.hardening=0.5"]
WEAKER_SLAB = {0.3: ["material.slab.cohesion_ratio=0.3", f"material.slab.initial_p0={SLAB_P0}"],
               0.2: ["material.slab.cohesion_ratio=0.2", f"material.slab.initial_p0={SLAB_P0}"]}


def before(*overrides):
    """The scene until 2026-12-04 with `overrides` (a later --set of the same key wins)."""
    return BEFORE + [o for group in overrides for o in group]


def resting_block(radius):
    """The block resting on the slab (half a cell clear of it) at the shipped block's point of
    the slope (slab surface at x 12.50 m, local slope 34 degrees), with this radius."""
    gap = radius + 0.025
    return [f"body.block.radius={radius}",
            f"body.block.center=[{12.497 + 0.559 * gap:.3f}, {3.924 + 0.829 * gap:.3f}]"]


def points_override(points):
    """The --set that gives slope2d's ground these (x, z) points; profile_points reads it back."""
    return "terrain.slope.points=[" + ", ".join(f"[{x:g}, {z:g}]" for x, z in points) + "]"


def straight_top():
    """slope2d's profile with its convex top (x < 5.5 m, 25 to 45 degrees) replaced by the
    45 degree line continued up to x = 0 (15.0 m high there): a profile with no convexity, as
    the 3D slope's parabola."""
    with open(SLOPE2D, "rb") as f:
        points = tomllib.load(f)["terrain"][0]["points"]
    x0, z0 = 5.5, next(z for x, z in points if x == 5.5)
    points = [[x, round(z0 + (x0 - x), 3) if x < x0 else z] for x, z in points]
    return [points_override(points)]


def concave_top(knots, contact_x, radius=0.6):
    """A profile read from the paper's words (Gaume et al. 2019, sec. 3: "convexities (close to
    the snowman) ... concavities (top of the slope)"): steepest at the top, easing to a bench,
    steepening again over a convex roll where the snowman stands, then easing to the flat.
    `knots` are (x, slope angle in degrees) joined by cosine blends; the profile is integrated
    every 1 cm, flat from the last knot on, and sampled every 0.5 m to x = 24 m. The snowman
    rests on the slab (the 0.75 m of base, weak layer and slab, half a cell clear) at contact_x.
    Returns the scene overrides."""
    def angle(x):
        for (x0, a0), (x1, a1) in zip(knots, knots[1:]):
            if x <= x1:
                return a0 + (a1 - a0) * (0.5 - 0.5 * math.cos(math.pi * (x - x0) / (x1 - x0)))
        return knots[-1][1]
    step, depth = 0.01, [0.0]
    for k in range(2400):
        depth.append(depth[-1] + step * math.tan(math.radians(angle((k + 0.5) * step))))
    height = [depth[-1] - d for d in depth]  # 0 at x = 24 m, flat beyond
    points = [[k * 0.5, round(height[50 * k], 3)] for k in range(49)] + [[45.0, 0.0]]
    slope = math.radians(angle(contact_x))
    surface = height[int(round(contact_x / step))] + 0.75 / math.cos(slope)
    gap = radius + 0.025
    center = [contact_x + math.sin(slope) * gap, surface + math.cos(slope) * gap]
    return [points_override(points), f"body.block.center=[{center[0]:.3f}, {center[1]:.3f}]"]


# The concave-top profiles measured (2026-12-05, seventeenth session; H 12.8 and 12.7 m): 45
# degrees at x 1.5-3.5 m, a bench of 30 or 32 degrees at x 8-10 m, a convex roll to 38 or 40
# degrees where the snowman stands, flat from x 20 or 19 m; and the first one tried.
CONCAVE_TOP = {
    30: concave_top([(0, 36), (1.5, 45), (3.5, 45), (8, 30), (10, 30), (12.5, 38), (13.5, 38),
                     (20, 0)], 12.75),
    32: concave_top([(0, 38), (1.5, 45), (3, 45), (7.5, 32), (9.5, 32), (12, 40), (13, 40),
                     (19, 0)], 12.5),
    # tried first: 45 degrees from the very top, a 24 degree bench, H 13.1 m
    24: concave_top([(0, 45), (2.5, 45), (8, 24), (10.5, 24), (13.5, 36), (15, 36), (23, 0)],
                    12.5),
}

# The 3D slope's plane-strain cut's differences from slope2d (bench/slope3d_cut.toml), each one a
# variant below and together `cut-all`. A thicker layer or slab lifts the snowman by the 0.1 m
# added, along the slope normal at its point (34 degrees) from the shipped [12.846, 4.442].
CUT = {"ppc8": ["grid.particles_per_cell=8"],
       "weak0.3": ["body.weak.thickness=0.3", "material.weak.softening=500"],
       "slab0.5": ["body.slab.thickness=0.5"],
       "weak90": ["material.weak.density=90"],
       "gentler6": ["simulation.gravity=[-1.02542, -9.75626]"]}
THICKENS = {"weak0.3": 0.1, "slab0.5": 0.1}
# The slip surface of scenes/slope3d.toml and its cut: the slab and the trigger above the weak layer.
SLIP = ['body.slab.slides_on="weak"', 'body.block.slides_on="weak"']
# The cut itself (bench/slope3d_cut.toml, 4th entry of its VARIANTS rows) as bench/README.md's
# runs of it: its whole profile at dx 0.05, a 90 kg/m^3 layer with the band's alpha 500, the
# brittle slab and the standing snowman of the 3D slope (radius 0.45 m, touching at x 8.5 m),
# without the slip surface; TILTED turns gravity 6 degrees so that its top is 45 degrees, as
# slope2d's steep section.
CUT_RUN = ["material.weak.softening=500", "material.weak.density=90",
           "material.slab.hardening=5", "material.block.initial_p0=20000",
           "body.block.radius=0.45", "body.block.center=[8.713, 4.775]"]
TILTED = ["simulation.gravity=[1.02542, -9.75626]"]


def lifted(lift):
    """The snowman lifted `lift` m along the slope normal (none for 0)."""
    if not lift:
        return []
    return [f"body.block.center=[{12.846 + 0.559 * lift:.3f}, {4.442 + 0.829 * lift:.3f}]"]


def cut(*names):
    """The cut's differences `names` together, the snowman lifted for the thicker ones."""
    return ([o for name in names for o in CUT[name]]
            + lifted(sum(THICKENS.get(name, 0.0) for name in names)))


def cut_all_but(left_out=None):
    """All the cut's differences but `left_out`."""
    return cut(*[name for name in CUT if name != left_out])


# name: (dx, overrides of scenes/slope2d.toml, what it tests[, another scene])
VARIANTS = {
    "shipped": (0.05, [], "the shipped scene: the PST's weak layer (100 kg/m^3) with alpha 333 "
                "(its fracture energy per area in a 0.2 m band), a brittle slab (xi 5), the "
                "snowman standing on the slab"),
    "dropped": (0.05, DROPPED, "the shipped scene until 2026-12-04 (eleventh session): the "
                "block dropped 0.3 m onto the slab"),
    "before": (0.05, before(), "until 2026-12-04: weak layer 88 kg/m^3, the table's alpha 100 "
               "and slab (xi 0.5, sigma_t 10.1 kPa)"),
    "alpha333": (0.05, before(["material.weak.softening=333"]),
                 "alpha scaled to the PST layer's fracture energy: a 0.2 m band, 0.2/0.06 x 100"),
    "alpha333-beta0.3": (0.05, before(["material.weak.softening=333"], WEAKER_SLAB[0.3]),
                         "and a slab with beta 0.3 at the same p0 (sigma_t 8.0 kPa)"),
    "alpha333-beta0.2": (0.05, before(["material.weak.softening=333"], WEAKER_SLAB[0.2]),
                         "and a slab with beta 0.2 at the same p0 (sigma_t 6.4 kPa)"),
    "alpha100-beta0.3": (0.05, before(WEAKER_SLAB[0.3]),
                         "the table's alpha with the beta 0.3 slab"),
    "slab-xi2": (0.05, before(["material.slab.hardening=2"]),
                 "the table's alpha, a more brittle slab: xi 2 (table 0.5), same strength"),
    "slab-xi5": (0.05, before(["material.slab.hardening=5"]),
                 "the table's alpha, slab xi 5 (scene-format.md's default), same strength"),
    "slab-xi20": (0.05, before(["material.slab.hardening=20"]), "the table's alpha, slab xi 20"),
    "alpha200-slab-xi5": (0.05, before(["material.weak.softening=200",
                                        "material.slab.hardening=5"]),
                          "alpha 200 and slab xi 5"),
    "alpha200-slab-xi20": (0.05, before(["material.weak.softening=200",
                                         "material.slab.hardening=20"]),
                           "alpha 200 and slab xi 20"),
    "alpha333-slab-xi5": (0.05, before(["material.weak.softening=333",
                                        "material.slab.hardening=5"]),
                          "alpha 333 and slab xi 5"),
    "alpha333-slab-xi20": (0.05, before(["material.weak.softening=333",
                                         "material.slab.hardening=20"]),
                           "alpha 333 and slab xi 20"),
    "alpha333-slab-xi5-beta0.3": (0.05, before(["material.weak.softening=333",
                                                "material.slab.hardening=5"], WEAKER_SLAB[0.3]),
                                  "alpha 333, slab xi 5 and beta 0.3 (sigma_t 8.0 kPa)"),
    "alpha333-slab-xi5-beta0.2": (0.05, before(["material.weak.softening=333",
                                                "material.slab.hardening=5"], WEAKER_SLAB[0.2]),
                                  "alpha 333, slab xi 5 and beta 0.2 (sigma_t 6.4 kPa)"),
    "weak100-alpha333": (0.05, DROPPED + ["material.slab.hardening=0.5"],
                         "the shipped weak layer with the table's slab (xi 0.5)"),
    "weak94-slab-xi5": (0.05, DROPPED + ["material.weak.density=94"],
                        "the shipped scene with a 94 kg/m^3 weak layer"),
    "weak97-slab-xi5": (0.05, DROPPED + ["material.weak.density=97"],
                        "the shipped scene with a 97 kg/m^3 weak layer"),
    "slab-xi2-shipped": (0.05, DROPPED + ["material.slab.hardening=2"],
                         "the shipped scene with a less brittle slab, xi 2"),
    "snowman-p0-2k": (0.05, EARLY_REST + ["material.block.initial_p0=2000"],
                      "the snowman with the dropped block's weak snow (p0 2 kPa): it yields "
                      "under its own weight at t = 0"),
    "snowman-r0.45": (0.05, resting_block(0.45), "a smaller snowman, radius 0.45 m"),
    "snowman-r0.35": (0.05, resting_block(0.35), "a smaller snowman, radius 0.35 m"),
    "snowman-weak106": (0.05, EARLY_REST + ["material.weak.density=106"],
                        "the snowman on a 106 kg/m^3 weak layer"),
    "snowman-weak110": (0.05, EARLY_REST + ["material.weak.density=110"],
                        "the snowman on a 110 kg/m^3 weak layer"),
    # One difference each from the 3D slope's plane-strain cut (bench/slope3d_cut.toml), whose
    # slab does not break within 1 m behind the running crack (docs/limitations.md): its 8
    # particles per cell, its 0.3 m weak layer (alpha 500, the crack band's) and its slab up to
    # 0.5 m deep. A thicker layer or slab lifts the snowman by the 0.1 m added, along the normal.
    "ppc8": (0.05, cut("ppc8"), "8 particles per cell (the 3D slope's cut)"),
    "weak0.3": (0.05, cut("weak0.3"),
                "a 0.3 m weak layer with the crack band's alpha 500 (the 3D slope's cut)"),
    "weak0.1": (0.05, ["body.weak.thickness=0.1", "material.weak.softening=167",
                       "body.block.center=[12.790, 4.359]"],
                "a 0.1 m weak layer (the issue's first try) with the crack band's alpha 167"),
    "slab0.5": (0.05, cut("slab0.5"), "a 0.5 m slab (the 3D slope's deepest)"),
    "weak90": (0.05, cut("weak90"),
               "a 90 kg/m^3 weak layer (the one that runs the crack on the 3D slope's cut)"),
    "gentler6": (0.05, cut("gentler6"),
                 "gravity tilted 6 degrees up-slope: 39 degrees at the steepest, as the 3D "
                 "slope's profile"),
    "straight-top": (0.05, straight_top(),
                     "no convexity: the 45 degree section continued to the top (15 m high)"),
    # The cut has one more difference the variants above leave out: the slip surface
    # (`slides_on`), which the 3D slope and its cut use and slope2d does not.
    "slip": (0.05, SLIP, "the slab and the snowman above a slip surface on the weak layer "
             "(slides_on, slip_friction the default 0.69), as the 3D slope and its cut"),
    # The cut's five differences above together (the snowman lifted 0.2 m), and each left out
    # in turn: whether their combination breaks the slab from the surface 2-3 m behind the tip,
    # as the cut does, and which of them it needs.
    "cut-all": (0.05, cut_all_but(),
                "all five of the cut's differences: 8 particles per cell, a 0.3 m layer of "
                "90 kg/m^3 with alpha 500, a 0.5 m slab, 39 degrees at the steepest"),
    **{f"cut-all-no-{name}": (0.05, cut_all_but(name), f"cut-all without {name}")
       for name in CUT},
    # The cut itself, with slope2d's rules for the fractures (CONTACT_X): are its fractures
    # farther behind the tip than slope2d's, or only fewer?
    "cut-whole": (0.05, CUT_RUN, "the 3D slope's plane-strain cut, whole profile, dx 0.05, "
                  "weak 90 with alpha 500, no slip surface", CUT_SCENE),
    "cut-whole-tilted": (0.05, CUT_RUN + TILTED, "the same with gravity tilted 6 degrees: 45 "
                         "degrees at the top", CUT_SCENE),
    "concave-top30": (0.05, CONCAVE_TOP[30],
                      "the paper's curvatures: 45 degrees at the top, a 30 degree bench at x "
                      "8-10 m, a convex roll to 38 degrees under the snowman (x 12.75 m)"),
    "concave-top24": (0.05, CONCAVE_TOP[24],
                      "45 degrees from the top (x 0-2.5 m), a 24 degree bench at x 8-10.5 m, a "
                      "convex roll to 36 degrees, the snowman at x 12.5 m (33 degrees)"),
    "concave-top32": (0.05, CONCAVE_TOP[32],
                      "the same with a 32 degree bench and 40 degrees under the snowman "
                      "(x 12.5 m)"),
    # The PST sweep's layers weak in tension with a high cap (bench/studies.md: "A layer weak in
    # tension and strong under confinement"), alpha scaled to the 0.2 m layer (x 0.2 / 0.06).
    "weak-B": (0.05, ["material.weak.cohesion_ratio=0.01",
                      "material.weak.critical_state_slope=0.35",
                      "material.weak.initial_p0=27600", "material.weak.softening=1333"],
               "the PST sweep's layer B (beta 0.01, M 0.35, p0 27.6 kPa, alpha 400 on 6 cm)"),
    "weak-D": (0.05, ["material.weak.cohesion_ratio=0.01",
                      "material.weak.critical_state_slope=0.337",
                      "material.weak.initial_p0=27600", "material.weak.softening=1333"],
               "the PST sweep's layer D (beta 0.01, M 0.337, p0 27.6 kPa, alpha 400 on 6 cm)"),
    "fine": (0.025, DROPPED + ["material.weak.softening=250"],
             "dx 0.025: the shipped scene with the dropped block, alpha for its 6-cell (0.15 m) "
             "band"),
    "slab-beta0.3": (0.05, WEAKER_SLAB[0.3],
                     "the shipped scene with a slab of beta 0.3 at the same p0 (sigma_t 8.0 kPa)"),
    "slab-beta0.2": (0.05, WEAKER_SLAB[0.2],
                     "the shipped scene with a slab of beta 0.2 at the same p0 (sigma_t 6.4 kPa)"),
    "fine-snowman": (0.025, ["material.weak.softening=250"],
                     "dx 0.025: the shipped scene (the snowman), alpha for its 6-cell (0.15 m) "
                     "band"),
    "slab-E2.5": (0.05, ["material.slab.youngs_modulus=2.5e6"],
                  "the shipped scene with a slab of E 2.5 MPa (c_s 65 m/s; the table's 4.8)"),
    "slab-E1.25": (0.05, ["material.slab.youngs_modulus=1.25e6"],
                   "the shipped scene with a slab of E 1.25 MPa (c_s 46 m/s)"),
    "fine-before-alpha250": (0.025, before(["material.weak.softening=250"]),
                             "dx 0.025: the scene before, alpha for a 6-cell (0.15 m) band"),
    "fine-before-alpha250-beta0.3": (0.025, before(["material.weak.softening=250"],
                                                   WEAKER_SLAB[0.3]),
                                     "dx 0.025: the scene before, alpha 250, beta 0.3 slab"),
    "fine-before-alpha250-slab-xi5": (0.025, before(["material.weak.softening=250",
                                                     "material.slab.hardening=5"]),
                                      "dx 0.025: the scene before, alpha 250, slab xi 5"),
}


def run(firn, scene, dx, overrides, out, end_time, threads):
    args = [firn, "run", scene, "--quiet", "--out", out,
            "--set", f"grid.dx={dx}", "--set", f"simulation.end_time={end_time}",
            "--set", f"simulation.frame_rate={FRAME_RATE:g}", "--set", "output.particles=false",
            "--set", 'output.volumes=["eta"]']
    if threads:
        args += ["--threads", str(threads)]
    for o in overrides:
        args += ["--set", o]
    start = time.time()
    subprocess.run(args, check=True)
    with open(os.path.join(out, "summary.json")) as f:
        return json.load(f), time.time() - start


def profile_points(scene, overrides=()):
    """The ground profile a run stands on: the scene's, or the one its overrides give."""
    for o in overrides:
        if o.startswith("terrain.slope.points="):
            return json.loads(o.split("=", 1)[1])
    with open(scene, "rb") as f:
        return tomllib.load(f)["terrain"][0]["points"]


def along_slope(points, x0, x1):
    """Length of the ground profile between x0 and x1 (> 0 when x1 > x0): distances along the
    slope, as the paper's "< 1 m behind the tip", not along x."""
    lo, hi = min(x0, x1), max(x0, x1)
    length = 0.0
    for (xa, ya), (xb, yb) in zip(points, points[1:]):
        a, b = max(lo, xa), min(hi, xb)
        if b > a:
            length += (b - a) * math.hypot(1.0, (yb - ya) / (xb - xa))
    return length if x1 >= x0 else -length


def upslope_tips(summary, out):
    """The crack's up-slope end as (time, x): summary.json's crack_tip_steps (timed to the
    step) where the leading end runs up-slope (slope2d), else metrics.csv's crack_tip_min_x at
    each frame (the cut, whose leading end runs down to the layer's end)."""
    tips = [(t["time"], t["x"]) for t in summary["crack_tip_steps"]]
    if tips and tips[-1][1] < tips[0][1]:
        return tips
    with open(os.path.join(out, "metrics.csv")) as f:
        return [(float(r["time"]), float(r["crack_tip_min_x"])) for r in csv.DictReader(f)
                if r["crack_tip_min_x"]]


def first_pass(tips, x):
    """Time the crack's up-slope end first reached x (tips: upslope_tips)."""
    return next((t for t, tip_x in tips if tip_x <= x), None)


def ms_after_tip(tips, fracture):
    """Milliseconds from the tip's first pass of the fracture's x to the fracture ("ahead" when
    the tip had not got there)."""
    passed = first_pass(tips, fracture["x"])
    if passed is None or passed > fracture["time"]:
        return "ahead"
    return f"{1000.0 * (fracture['time'] - passed):.0f}"


def behind_along_slope(points, fracture, key):
    """How far behind the up-slope tip a fracture lies along the slope, m: summary.json's
    `key` (distance_behind_crack_tip, or ..._at_start) is along x from the step-timed end on
    the fracture's side; None without a crack then."""
    d = fracture.get(key)
    return None if d is None else along_slope(points, fracture["x"] - d, fracture["x"])


def joined(values, fmt="{:.2f}"):
    return " ".join("" if v is None else fmt.format(v) for v in values)


def column_eta(out, frames, dx, x):
    """Per frame, the largest voxel eta in the grid column at x (voxel size dx, index i)."""
    i = int(round(x / dx))
    values = []
    for k in range(frames):
        path = os.path.join(out, "frames", f"volume.{k:04d}.vdb")
        grid = vdb.read(path, "eta")
        lo, hi = grid.evalActiveVoxelBoundingBox()
        acc = grid.getConstAccessor()
        values.append(max((acc.getValue((i, j, 0)) for j in range(lo[1], hi[1] + 1)),
                          default=0.0))
    return values


def softened_front(out, frame, dx, x_from, threshold=1.0):
    """Smallest x >= x_from of a grid column whose largest voxel eta is >= threshold in that
    frame: the up-slope end of the layer softened that far below x_from (None when none is)."""
    grid = vdb.read(os.path.join(out, "frames", f"volume.{frame:04d}.vdb"), "eta")
    acc = grid.getConstAccessor()
    lo, hi = grid.evalActiveVoxelBoundingBox()
    for i in range(max(lo[0], int(round(x_from / dx))), hi[0] + 1):
        if any(acc.getValue((i, j, 0)) >= threshold for j in range(lo[1], hi[1] + 1)):
            return i * dx
    return None


def first_frame_at_least(values, threshold):
    return next((k / FRAME_RATE for k, v in enumerate(values) if v >= threshold), None)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=list(VARIANTS))
    parser.add_argument("--firn", default=os.path.join(ROOT, "build", "firn"))
    parser.add_argument("--threads", type=int)
    parser.add_argument("--end-time", type=float, default=0.45)
    parser.add_argument("--out", default=os.path.join(ROOT, "bench", "results", "slab-fracture"))
    parser.add_argument("--seeds", nargs="+", type=int,
                        help="run each variant once per seed (rows VARIANT@seedS)")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    results = os.path.join(args.out, "results.csv")
    kept = {}
    if os.path.exists(results):  # a subset of variants replaces only its own rows
        with open(results) as f:
            kept = {row["variant"]: row for row in csv.DictReader(f)}
    rows, pooled = [], {}
    with tempfile.TemporaryDirectory() as work:
        runs = [(name, name, []) for name in args.variants]
        if args.seeds:
            runs = [(f"{name}@seed{seed}", name, [f"simulation.seed={seed}"])
                    for name in args.variants for seed in args.seeds]
        for name, variant, seed_override in runs:
            dx, overrides, note, *other = VARIANTS[variant]
            scene = other[0] if other else SLOPE2D
            overrides = overrides + seed_override
            points = profile_points(scene, overrides)
            out = os.path.join(work, name)
            summary, seconds = run(args.firn, scene, dx, overrides, out, args.end_time,
                                   args.threads)
            tips = upslope_tips(summary, out)
            top = first_pass(tips, 0.6)
            section_speed = lag = front = None
            if scene == SLOPE2D:  # its 45 degree section, and the process zone at x = 7.5 m
                t10, t5 = first_pass(tips, 10.0), first_pass(tips, 5.0)
                if t10 is not None and t5 is not None and t5 > t10:
                    section_speed = 5.0 * math.sqrt(2.0) / (t5 - t10)
                frames = int(round(args.end_time * FRAME_RATE)) + 1
                eta = column_eta(out, frames, dx, 7.5)
                onset, softened = first_frame_at_least(eta, 0.01), first_frame_at_least(eta, 1.0)
                lag = softened - onset if onset is not None and softened is not None else None
                front = (softened_front(out, int(round(onset * FRAME_RATE)), dx, 7.5)
                         if onset is not None else None)
            contact = CONTACT_X[scene]
            running = [f for f in summary["slab_fractures"]
                       if f["x"] < contact - 2.0 and (top is None or f["time"] <= top)]
            behind = [behind_along_slope(points, f, "distance_behind_crack_tip") for f in running]
            at_start = [behind_along_slope(points, f, "distance_behind_crack_tip_at_start")
                        for f in running]
            pooled.setdefault(variant, []).extend(
                (b, a) for f, b, a in zip(running, behind, at_start)
                if f["x"] < contact - 3.0 and b is not None)
            row = {
                "variant": name, "dx": dx, "overrides": " ".join(overrides), "note": note,
                "mean_crack_speed": round(summary["mean_crack_speed"] or 0.0, 1),
                "section_speed_45deg": round(section_speed, 1) if section_speed else "",
                "top_time": round(top, 4) if top is not None else "",
                "speed_to_top": round(along_slope(points, 0.6, summary["settle_overloaded_x_min"])
                                      / top, 1) if top else "",
                "softening_lag_s": round(lag, 4) if lag is not None else "",
                "process_zone_m": round((front - 7.5) * math.sqrt(2.0), 2) if front else "",
                "fractures_while_running": len(running),
                "fracture_x": joined(f["x"] for f in running),
                "fracture_time": joined((f["time"] for f in running), "{:.3f}"),
                "behind_tip_m": joined(behind),
                "start_depth": joined(f["start_depth_fraction"] for f in running),
                "tip_at_fracture": joined(
                    None if f.get("distance_behind_crack_tip") is None
                    else f["x"] - f["distance_behind_crack_tip"] for f in running),
                "ms_after_tip_passed": " ".join(ms_after_tip(tips, f) for f in running),
                "wall_seconds": round(seconds, 1),
                "scene": os.path.relpath(scene, ROOT),
                "fracture_start_time": joined((f.get("start_time") for f in running), "{:.3f}"),
                "behind_tip_at_start_m": joined(at_start),
                "settle_overloaded_particles": summary.get("settle_overloaded_particles"),
                "settle_overloaded_x": joined((summary.get("settle_overloaded_x_min"),
                                               summary.get("settle_overloaded_x_max"))),
            }
            rows.append(row)
            print(row, flush=True)
    for variant, distances in pooled.items():
        through = sorted(b for b, _ in distances)
        started = sorted(a for _, a in distances if a is not None)
        print(f"{variant}: {len(through)} fractures 3 m or more up-slope of the snowman while the "
              f"crack runs; behind the tip as they go through: median "
              f"{statistics.median(through) if through else float('nan'):.2f} m, nearest "
              f"{min(through, default=float('nan')):.2f} m; as they start: median "
              f"{statistics.median(started) if started else float('nan'):.2f} m, nearest "
              f"{min(started, default=float('nan')):.2f} m")
    fresh = {row["variant"]: row for row in rows}
    names = list(VARIANTS) + sorted((set(fresh) | set(kept)) - set(VARIANTS))
    ordered = [fresh.get(name) or kept[name] for name in names if name in fresh or name in kept]
    with open(results, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        writer.writerows(ordered)
    print(f"wrote {results}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
