#!/usr/bin/env python3
"""Firn study harness: runs a named study through the `firn` binary and writes results.csv and
charts (PNG and SVG) into bench/results/<study>/, with the scene, overrides, commit and machine
of every run.

    /usr/bin/python3 bench/study.py stability|accuracy|slice|channel|throughput [--quick]
                                    [--threads N]

Studies:
  stability  a stiff elastic block dropped on the ground and a cohesive Cam-Clay snow slab
             sliding on a 35 degree slope, CFL 0.1-2.0 x transfer (APIC, PIC, FLIP 0.95,
             FLIP 0.99, FLIP relaxed over 1 s) x particles per cell: each run is stable, unstable (the solver's own
             status) or inaccurate (energy gain above 5 % of the energy scale). --quick runs a
             small subset and checks that APIC at CFL 0.4 is stable on both and that the block
             at CFL 2.0 is not.
  accuracy   accuracy against cost on the validation cases with a reference: V1 sliding block
             (acceleration), V2 P-wave speed, V7 granular column collapse (Lube et al. 2005
             runout at a = 1) and V8 PST critical cut length (bisection; full run only), over
             dx x method (transfer, CFL, particles per cell): relative error against wall time
             and particle-steps, log-log, Pareto front marked; observed orders with dx in
             convergence.csv. --quick runs APIC on V1, V2, V7 and V8 (dx 0.03) and checks V1
             within 3 %, the V2 error falling with dx and within 5 %, V7 within 15 %, V8's a_c
             inside the bisection bracket (0.1, 1.0) m.
  slice      V2 and V7 in 2D and as a thin 3D slice between slip walls: error and cost side by
             side; V7 also at the aspect ratios a = 0.5, 1, 2, 4 (--aspects) at dx 0.005 against
             Lube's law. --quick: V2 at dx 0.01, 2D and 2-cell slice agree within 1 % of c_p.
  channel    V7 at a = 0.5, 1, 2, 4, 8 in 2D and in 3D channels between Coulomb side walls
             (dx 0.01): how the walls of the experiments' channels lower the large-a exponent of
             the runout (exponents.csv). --quick: a = 2 and 8 in 2D and in a 6 cm channel (wall
             mu 0.4) at dx 0.02; the channel's exponent must lie at least 0.1 below 2D's.
  throughput build/firn_bench on elastic blocks of 7 000 to 1 900 000 particles: particle-steps
             per second with 1 thread and all threads, bytes per particle; and the same block
             at the origin, 1 km away and in a domain 8 times its volume (a sparse grid must
             not care). --quick (CI) runs the two smallest blocks and asserts on memory only
             (timings are reported, never asserted).
"""
import argparse
import csv
import json
import os
import platform
import subprocess
import sys
import tempfile

from pst_resolution import bisect_cut, up_slope_reach

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

# A cohesive Cam-Clay snow slab (the former scene-format.md defaults, E 1 MPa, given in full now
# that a snow material's missing keys come from the snow parameter table) sliding down a 35 degree
# plane (mu 0.2): the second stability case, with plasticity and a free surface in motion.
SNOW_SLAB = """
[simulation]
name = "snow-slab"
dimension = 2
end_time = 0.5
frame_rate = 50
gravity = [0.0, -9.81]
[grid]
dx = 0.05
particles_per_cell = 4
max_dt = 1.0
[[material]]
name = "snow"
model = "snow"
density = 250.0
youngs_modulus = 1.0e6
poisson_ratio = 0.2
critical_state_slope = 1.0
cohesion_ratio = 0.3
initial_p0 = 2.0e4
hardening = 5.0
[[terrain]]
shape = "plane"
point = [0.0, 0.0]
normal = [0.573576, 0.819152]
boundary = "friction"
friction = 0.2
[[body]]
material = "snow"
shape = "layer"
thickness = 0.4
x_range = [0.0, 3.0]
[output]
particles = false
volumes = []
"""
STABILITY_CASES = {"block": ("Stiff elastic block dropped on the ground", STIFF_BLOCK),
                   "slab": ("Snow slab sliding on a 35 degree slope", SNOW_SLAB)}

TRANSFERS = {"apic": ["grid.transfer=apic"], "pic": ["grid.transfer=pic"],
             "flip95": ["grid.transfer=flip", "grid.flip_blend=0.95"],
             "flip99": ["grid.transfer=flip", "grid.flip_blend=0.99"],
             # The slope scenes' transfer: FLIP, its noise relaxed over 1 s.
             "flip_tau1": ["grid.transfer=flip", "grid.flip_relaxation_time=1.0"],
             # XPIC(m), Hammerquist & Nairn 2017: m - 1 extra round trips a step.
             "xpic2": ["grid.transfer=xpic", "grid.xpic_order=2"],
             "xpic4": ["grid.transfer=xpic", "grid.xpic_order=4"]}
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


def run_scene(args, scene_path, overrides, out):
    cmd = [args.firn, "run", scene_path, "--quiet", "--out", out]
    if args.threads:
        cmd += ["--threads", str(args.threads)]
    args = cmd
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
    transfers = ["apic", "flip99"] if args.quick else (args.transfers or list(TRANSFERS))
    rows = []
    with tempfile.TemporaryDirectory() as work:
        for case, (_, text) in STABILITY_CASES.items():
            scene = os.path.join(work, f"{case}.toml")
            with open(scene, "w") as f:
                f.write(text)
            for transfer in transfers:
                for ppc in ppcs:
                    for cfl in cfls:
                        overrides = TRANSFERS[transfer] + [f"grid.cfl={cfl}",
                                                           f"grid.particles_per_cell={ppc}"]
                        out = os.path.join(work, f"{case}-{transfer}-{ppc}-{cfl}")
                        code, summary, metrics = run_scene(args, scene, overrides, out)
                        outcome, drift = classify(code, summary, metrics)
                        rows.append({"case": case, "transfer": transfer,
                                     "particles_per_cell": ppc, "cfl": cfl, "outcome": outcome,
                                     "energy_drift": drift, "steps": summary["steps"],
                                     "wall_seconds": summary["wall_seconds"],
                                     "overrides": " ".join(overrides)})
                        print(f"{case:5s} {transfer:7s} ppc {ppc} cfl {cfl:4.2f}: {outcome}",
                              flush=True)
    path = os.path.join(out_dir, "results.csv")
    if args.transfers and not args.quick and os.path.exists(path):  # keep the other transfers'
        rows = [r for r in read_rows(path) if r["transfer"] not in transfers] + rows
    return rows


def fitted_acceleration(metrics):
    """a from a least-squares fit x = x0 + v0 t + a t^2 / 2 of com_x over t in [0.2, 1] s."""
    import numpy as np
    t = np.array([float(r["time"]) for r in metrics if float(r["time"]) >= 0.2 - 1e-9])
    x = np.array([float(r["com_x"]) for r in metrics if float(r["time"]) >= 0.2 - 1e-9])
    return 2.0 * np.polyfit(t, x, 2)[0]


# V2: a 0.1 m striker at 0.4 m/s hits a bar at rest between slip walls (uniaxial strain, so the
# front travels at c_p). The pulse carries v0 / 2 = 0.2 m/s, and metrics.csv's front_x (the
# largest x of particles faster than 0.1 m/s) is then the half-amplitude point of the front:
# the speed is the slope of a line fitted to front_x(t) while it crosses 0.6 to 1.6 m (the
# probes of tests/validation/kinematics_test.cc). The 3D slice adds slip walls at z = 0 and w.
WAVE_CP = 154.92  # validation.md V2: E 5 MPa, nu 0.25, rho 250


def wave_scene(dimension=2, width=0.0):
    v = (lambda *c: "[" + ", ".join(str(x) for x in (c if dimension == 3 else c[:2])) + "]")
    walls = [((0.0, 0.0, 0.0), (0.0, 1.0, 0.0)), ((0.0, 0.05, 0.0), (0.0, -1.0, 0.0))]
    if dimension == 3:
        walls += [((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)), ((0.0, 0.0, width), (0.0, 0.0, -1.0))]
    text = f"""
[simulation]
name = "wave"
dimension = {dimension}
end_time = 0.0115
frame_rate = 8000
gravity = {v(0.0, 0.0, 0.0)}
[grid]
dx = 0.01
particles_per_cell = {4 if dimension == 2 else 8}
[[material]]
name = "block"
model = "elastic"
density = 250.0
youngs_modulus = 5.0e6
poisson_ratio = 0.25
"""
    for point, normal in walls:
        text += (f'[[terrain]]\nshape = "plane"\npoint = {v(*point)}\nnormal = {v(*normal)}\n'
                 'boundary = "slip"\n')
    text += f"""[[body]]
name = "striker"
material = "block"
shape = "box"
min = {v(0.0, 0.0, 0.0)}
max = {v(0.1, 0.05, width)}
velocity = {v(0.4, 0.0, 0.0)}
[[body]]
name = "bar"
material = "block"
shape = "box"
min = {v(0.1, 0.0, 0.0)}
max = {v(1.9, 0.05, width)}
[output]
particles = false
volumes = []
"""
    return text


def wave_speed(metrics):
    import numpy as np
    t = np.array([float(r["time"]) for r in metrics if r["front_x"]])
    x = np.array([float(r["front_x"]) for r in metrics if r["front_x"]])
    inside = (x >= 0.6) & (x <= 1.6)
    if inside.sum() < 5:
        return float("nan")
    return np.polyfit(t[inside], x[inside], 1)[0]


# V7: Lube et al. (2005) planar collapse, aspect ratio a = H0 / L0 = 1: a 0.1 m square of
# cohesionless Mohr-Coulomb sand (mu(I), below) against a slip wall at x = 0 on a sticky floor,
# as in docs/validation.md's V7 case. Law: (L_inf - L0) / L0 = 1.2 a for a < 1.8. L_inf is the 99th
# percentile of the deposit's mass along x, from the last frame's density volume (nodal mass
# spread by the B-spline, so a fraction of a cell farther out than the particles).
# E = 1 MPa keeps rho g H0 / E at 1.5e-3 (rigid enough) with a time step we can afford.
COLUMN_L0, COLUMN_ASPECT = 0.1, 1.0


def column_law(aspect):
    """validation.md V7: 1.2 a for a < 1.8, 1.9 a^(2/3) for a > 2.8; between the two (a = 2) the
    large-a branch, as the V7 rows of docs/validation.md (1.2 a would be 2.4 at a = 2)."""
    return 1.2 * aspect if aspect < 1.8 else 1.9 * aspect ** (2.0 / 3.0)


COLUMN_LAW = column_law(COLUMN_ASPECT)
# The aspect-ratio sweep of the slice study (V7's a = 0.5 to 4), at dx 0.005 = 20 cells per
# column width. A taller column falls for longer (time scale sqrt(H0 / g)): end_time grows as
# sqrt(a) from a = 1, rounded up to whole frames (a = 2: 1.0 s, a = 4: 1.2 s; at dx 0.005 the
# a = 4 deposit is at rest from 0.9 s, and 0.6 s would stop it at 92 % of its runout).
SLICE_ASPECTS = (0.5, 1.0, 2.0, 4.0)
SLICE_ASPECT_DX = 0.005


# The column's friction: mu(I) fitted to Lube's law at dx 0.005 (docs/validation.md: V7), from
# 15 degrees at rest to 55 at large inertial number, grains of 1 cm. With a constant friction
# angle (30 degrees until 2026-12-03) the runout grew with every halving of dx.
COLUMN_FRICTION = """friction_angle = 15.0
dynamic_friction_angle = 55.0
grain_diameter = 0.01"""


def column_end_time(aspect):
    import math
    return round(0.2 * math.ceil(3.0 * max(1.0, aspect) ** 0.5 - 1e-9), 3)  # 5 frames/s


def column_scene(dimension=2, width=0.0, aspect=COLUMN_ASPECT, wall_friction=None):
    """The V7 column; in 3D between side walls at z = 0 and z = width, slip walls or, with
    wall_friction, Coulomb walls of that coefficient (the channel study)."""
    v = (lambda *c: "[" + ", ".join(str(x) for x in (c if dimension == 3 else c[:2])) + "]")
    walls = [((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), "sticky"), ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), "slip")]
    if dimension == 3:
        side = "slip" if wall_friction is None else "friction"
        walls += [((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), side),
                  ((0.0, 0.0, width), (0.0, 0.0, -1.0), side)]
    text = f"""
[simulation]
name = "column"
dimension = {dimension}
end_time = {column_end_time(aspect)}
frame_rate = 5
gravity = {v(0.0, -9.81, 0.0)}
[grid]
dx = 0.005
particles_per_cell = {4 if dimension == 2 else 8}
[[material]]
name = "sand"
model = "granular"
density = 1500.0
youngs_modulus = 1.0e6
poisson_ratio = 0.3
{COLUMN_FRICTION}
"""
    for point, normal, bc in walls:
        text += (f'[[terrain]]\nshape = "plane"\npoint = {v(*point)}\nnormal = {v(*normal)}\n'
                 f'boundary = "{bc}"\n')
        if bc == "friction":
            text += f"friction = {wall_friction}\n"
    text += f"""[[body]]
material = "sand"
shape = "box"
min = {v(0.0, 0.0, 0.0)}
max = {v(COLUMN_L0, round(COLUMN_L0 * aspect, 10), width)}
[output]
particles = false
volumes = ["density"]
"""
    return text


def column_runout(out, quantile=0.99):
    """Normalised runout (L - L0) / L0, L the `quantile` of the last frame's mass along x."""
    import numpy as np
    import pyopenvdb as vdb
    frames = sorted(f for f in os.listdir(os.path.join(out, "frames")) if f.startswith("volume."))
    grid = vdb.read(os.path.join(out, "frames", frames[-1]), "density")
    lo, hi = grid.evalActiveVoxelBoundingBox()
    values = np.zeros(tuple(hi[i] - lo[i] + 1 for i in range(3)), dtype=np.float32)
    grid.copyToArray(values, ijk=lo)
    mass = values.sum(axis=(1, 2))
    dx = grid.transform.voxelSize()[0]
    edges = (np.arange(len(mass)) + lo[0] + 0.5) * dx  # node i holds the mass of [x_i +- dx/2]
    runout = float(np.interp(quantile, np.cumsum(mass) / mass.sum(), edges))
    return (runout - COLUMN_L0) / COLUMN_L0


# V8: critical cut length of scenes/pst.toml (flat) by bisection on a 3 m column, as
# bench/pst_resolution.py: the cut at the right (down-slope) end; it "runs" when the crack from it
# reaches x < 0.1 m within 0.2 s (that script's up_slope_reach reads metrics.csv). Closed form of
# validation.md V8 with pst.toml's slab and weak layer (Lambda 0.884 m, tau_p 1 kPa, D 0.5 m,
# rho 250): a_c = Lambda sqrt(2 tau_p / sigma_n) = 1.129 m. A model, not truth (validation.md).
PST_AC = 1.129
PST_BRACKET = (0.1, 1.0)
PST_BISECTIONS = 5


def pst_critical_cut(args, scene, dx, overrides, work):
    totals = {"particles": 0, "steps": 0, "particle_steps": 0, "wall_seconds": 0.0}
    status = "ok"

    def runs_at(cut, i):
        nonlocal status
        out = os.path.join(work, f"pst-{dx}-{i}")
        _, summary, _ = run_scene(
            args, scene, overrides + ["body.weak.x_range=[0.0, 3.0]",
                                      "body.slab.x_range=[0.0, 3.0]", f"cut.weak.from_x={3.0 - cut}",
                                      f"cut.weak.length={cut}",
                                      "simulation.end_time=0.2", "simulation.frame_rate=100",
                                      "output.particles=false", "output.volumes=[]"], out)
        if summary["status"] != "ok":
            status = summary["status"]
        totals["particles"] = summary["particles"]
        totals["steps"] += summary["steps"]
        totals["particle_steps"] += summary["particles"] * summary["steps"]
        totals["wall_seconds"] += summary["wall_seconds"]
        # The cut is at the column's right (down-slope) end, as in the field and scenes/pst.toml:
        # the crack runs towards x = 0.
        return up_slope_reach(out, 3.0 - cut, dx) < 0.1

    stays, runs = bisect_cut(PST_BRACKET, PST_BISECTIONS, runs_at)
    return 0.5 * (stays + runs), f"{stays:.4f}-{runs:.4f}", status, totals


# Methods: one line per method in the charts. The four transfers at CFL 0.4 and 4 particles per
# cell, and APIC with the CFL or the particle count changed (one factor at a time).
METHODS = {"apic": ("apic", 0.4, 4), "pic": ("pic", 0.4, 4), "flip95": ("flip95", 0.4, 4),
           "flip99": ("flip99", 0.4, 4), "apic cfl 0.2": ("apic", 0.2, 4),
           "apic cfl 0.8": ("apic", 0.8, 4), "apic ppc 1": ("apic", 0.4, 1),
           "apic ppc 9": ("apic", 0.4, 9), "flip_tau1": ("flip_tau1", 0.4, 4),
           "xpic2": ("xpic2", 0.4, 4), "xpic4": ("xpic4", 0.4, 4)}

# Cases: what is measured, its reference, and the sweep (full; quick).
CASES = {
    "v1": {"title": "V1 sliding block (30 deg, mu 0.5): acceleration",
           "reference": SLIDING_EXPECTED, "dx": [0.1, 0.05, 0.025],
           "methods": list(METHODS), "quick": [("apic", [0.1, 0.05])]},
    "v2": {"title": "V2 P-wave speed (c_p 154.92 m/s)", "reference": WAVE_CP,
           "dx": [0.02, 0.01, 0.005, 0.0025], "methods": list(METHODS),
           "quick": [("apic", [0.02, 0.01, 0.005])]},
    "v7": {"title": "V7 column collapse a = 1 (Lube 2005): runout", "reference": COLUMN_LAW,
           "dx": [0.01, 0.005, 0.0025], "extra": [("apic", 0.00125)], "methods": list(METHODS),
           "quick": [("apic", [0.005])]},  # 20 cells per column: 0.01 is 26 % short
    "v8": {"title": "V8 PST critical cut length (closed form 1.129 m)", "reference": PST_AC,
           "dx": [0.03, 0.02, 0.015], "methods": ["apic"],
           "quick": [("apic", [0.03])]},  # end to end: a scene change that breaks it fails CI
}


def case_scene(case, work):
    path = os.path.join(work, f"{case}.toml")
    text = {"v1": lambda: SLIDING_BLOCK, "v2": wave_scene, "v7": column_scene,
            "v8": lambda: open(os.path.join(ROOT, "scenes", "pst.toml")).read()}[case]()
    with open(path, "w") as f:
        f.write(text)
    return path


def measure(args, case, scene, dx, method, work):
    transfer, cfl, ppc = METHODS[method]
    overrides = TRANSFERS[transfer] + [f"grid.dx={dx}", f"grid.cfl={cfl}",
                                       f"grid.particles_per_cell={ppc}"]
    if case == "v8":
        value, bracket, status, cost = pst_critical_cut(args, scene, dx, overrides, work)
    else:
        out = os.path.join(work, f"{case}-{method.replace(' ', '_')}-{dx}")
        code, summary, metrics = run_scene(args, scene, overrides, out)
        status, bracket = summary["status"], ""
        cost = {"particles": summary["particles"], "steps": summary["steps"],
                "particle_steps": summary["particles"] * summary["steps"],
                "wall_seconds": summary["wall_seconds"]}
        value = float("nan")
        if status == "ok":
            value = {"v1": lambda: fitted_acceleration(metrics), "v2": lambda: wave_speed(metrics),
                     "v7": lambda: column_runout(out)}[case]()
    reference = CASES[case]["reference"]
    return {"case": case, "method": method, "transfer": transfer, "dx": dx, "cfl": cfl,
            "particles_per_cell": ppc, "value": value, "reference": reference,
            "relative_error": abs(value - reference) / reference, "bracket": bracket, **cost,
            "status": status, "overrides": " ".join(overrides)}


def accuracy(args, out_dir):
    cases = args.cases or list(CASES)
    plan = []
    for case in cases:
        c = CASES[case]
        if args.quick:
            plan += [(case, m, dx) for m, dxs in c["quick"] for dx in dxs]
        else:
            methods = [m for m in c["methods"] if not args.methods or m in args.methods]
            plan += [(case, m, dx) for m in methods for dx in c["dx"]]
            plan += [(case, m, dx) for m, dx in c.get("extra", []) if m in methods]
    rows = []
    with tempfile.TemporaryDirectory() as work:
        scenes = {case: case_scene(case, work) for case in cases}
        for case, method, dx in plan:
            r = measure(args, case, scenes[case], dx, method, work)
            rows.append(r)
            print(f"{case} {method:13s} dx {dx:7.5f}: {r['value']:.5g} (ref {r['reference']:.5g}), "
                  f"error {r['relative_error']:.2e}, {r['wall_seconds']:.1f} s", flush=True)
    if not args.quick and (args.cases or args.methods):  # keep the rest of an earlier full run
        path = os.path.join(out_dir, "results.csv")
        rerun = {(case, method) for case, method, _ in plan}
        if os.path.exists(path):
            old = [r for r in read_rows(path)
                   if "case" in r and (r["case"], r.get("method")) not in rerun]
            order = list(CASES)
            rows = sorted(old + rows, key=lambda r: order.index(r["case"]))  # stable: V1 first
    write_convergence(rows, out_dir)
    return rows


def fit_order(points):
    """Slope of log(error) against log(dx), least squares; nan with fewer than 2 points."""
    import numpy as np
    pts = [(dx, e) for dx, e in points if e > 0 and e == e]
    if len(pts) < 2:
        return float("nan")
    return float(np.polyfit(np.log([p[0] for p in pts]), np.log([p[1] for p in pts]), 1)[0])


def self_order(points):
    """Observed order from the three finest dx (constant ratio r): log(|q1-q2| / |q2-q3|) / log r."""
    import math
    pts = sorted((dx, v) for dx, v in points if v == v)[:3]
    if len(pts) < 3:
        return float("nan")
    (d1, v1), (d2, v2), (d3, v3) = pts
    if v1 == v2 or v2 == v3:
        return float("nan")
    return math.log(abs(v3 - v2) / abs(v2 - v1)) / math.log(d2 / d1)


def convergence(rows):
    out = []
    for case in dict.fromkeys(r["case"] for r in rows):
        for method in dict.fromkeys(r["method"] for r in rows if r["case"] == case):
            sel = sorted((r for r in rows if r["case"] == case and r["method"] == method
                          and r["status"] == "ok"), key=lambda r: -float(r["dx"]))
            if len(sel) < 2:
                continue
            out.append({"case": case, "method": method, "points": len(sel),
                        "dx_max": sel[0]["dx"], "dx_min": sel[-1]["dx"],
                        "error_at_dx_max": sel[0]["relative_error"],
                        "error_at_dx_min": sel[-1]["relative_error"],
                        "value_at_dx_max": sel[0]["value"], "value_at_dx_min": sel[-1]["value"],
                        "reference": sel[0]["reference"],
                        "order_vs_reference": fit_order([(float(r["dx"]), float(r["relative_error"]))
                                                         for r in sel]),
                        "order_self": self_order([(float(r["dx"]), float(r["value"]))
                                                  for r in sel])})
    return out


def write_convergence(rows, out_dir):
    conv = convergence(rows)
    if not conv:
        return
    with open(os.path.join(out_dir, "convergence.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(conv[0].keys()))
        writer.writeheader()
        writer.writerows(conv)
    for c in conv:
        print(f"{c['case']} {c['method']:13s}: order {c['order_vs_reference']:.2f} against the "
              f"reference, {c['order_self']:.2f} self-convergence "
              f"(dx {c['dx_max']} to {c['dx_min']})")


# The slice study: one plane-strain case in 2D and as a thin 3D slice between slip walls (the
# scene format has no periodic boundary), same dx and the same particles per direction (4 per
# square cell in 2D, 8 per cube in 3D).
SLICE_CASES = {"v2": {"scene": wave_scene, "reference": WAVE_CP,
                      "title": "V2 P-wave speed"},
               "v7": {"scene": column_scene, "reference": COLUMN_LAW,
                      "title": "V7 column collapse: runout"}}


def slice_study(args, out_dir):
    if args.quick:
        plan = [("v2", 0.01, 0, None), ("v2", 0.01, 2, None)]
    else:
        plan = [(case, dx, cells, None if case == "v2" else COLUMN_ASPECT)
                for case, dxs in (("v2", (0.01, 0.005)), ("v7", (0.01, 0.005)))
                for dx in dxs for cells in (0, 2, 4)]
        plan += [("v7", 0.0025, 0, COLUMN_ASPECT), ("v7", 0.0025, 2, COLUMN_ASPECT)]
        # V7's aspect ratios (--aspects): 2D and a 2-cell slice at dx 0.005 (a = 1 is above).
        plan += [("v7", SLICE_ASPECT_DX, cells, a) for a in args.aspects
                 if a != COLUMN_ASPECT for cells in (0, 2)]
    rows = []
    with tempfile.TemporaryDirectory() as work:
        for case, dx, cells, aspect in plan:
            c = SLICE_CASES[case]
            width = round(cells * dx, 10)
            model = "2D" if cells == 0 else f"3D slice, {cells} cells"
            scene = os.path.join(work, f"{case}-{dx}-{cells}-{aspect}.toml")
            reference = c["reference"] if aspect is None else column_law(aspect)
            with open(scene, "w") as f:
                f.write(c["scene"](2 if cells == 0 else 3, width) if aspect is None else
                        c["scene"](2 if cells == 0 else 3, width, aspect))
            out = os.path.join(work, f"{case}-{dx}-{cells}-{aspect}")
            code, summary, metrics = run_scene(args, scene, [f"grid.dx={dx}"], out)
            value = float("nan")
            if summary["status"] == "ok":
                value = wave_speed(metrics) if case == "v2" else column_runout(out)
            rows.append({"case": case, "aspect": "" if aspect is None else aspect, "model": model,
                         "dx": dx, "slice_cells": cells, "slice_width": width, "value": value,
                         "reference": reference,
                         "relative_error": abs(value - reference) / reference,
                         "particles": summary["particles"], "steps": summary["steps"],
                         "particle_steps": summary["particles"] * summary["steps"],
                         "wall_seconds": summary["wall_seconds"], "status": summary["status"]})
            label = case if aspect is None else f"{case} a {aspect:g}"
            print(f"{label:8s} dx {dx:<6g} {model:18s}: {value:.5g} (ref {reference:.5g}), "
                  f"{summary['particles']} particles, {summary['wall_seconds']:.1f} s", flush=True)
    return rows


# V7 in a channel: Lube et al. 2005 and Balmforth & Kerswell 2005 (J. Fluid Mech. 538:399) collapsed
# their planar columns between side walls, which rub on the grains. Balmforth & Kerswell measured
# the large-a runout exponent 0.9 +- 0.1 in wide channels and 0.65 +- 0.05 in narrow slots; Lube's
# law has 2/3. The study runs the V7 column (COLUMN_FRICTION, fitted in 2D without walls) in 2D and
# between Coulomb side walls: (channel width m, wall coefficient), width 0 = 2D. dx 0.01: the a = 1
# runout is within 1.2 % of dx 0.005's (docs/validation.md, V7); the a = 8 channel of 10 cm costs ~4 min
# on 2 cores, the whole study ~25 min.
CHANNEL_ASPECTS = (0.5, 1.0, 2.0, 4.0, 8.0)
CHANNEL_WALLS = ((0.0, None), (0.1, 0.3), (0.05, 0.2), (0.1, 0.5), (0.05, 0.4), (0.03, 0.4))
CHANNEL_DX = 0.01


def channel_label(width, wall_friction):
    return ("2D (no side walls)" if width == 0 else
            f"channel {width * 100:g} cm, wall mu {wall_friction:g}")


def channel_walls(text):
    """--walls WIDTH:MU (width in m, 0 for 2D without walls) as (width, mu or None)."""
    width, _, mu = text.partition(":")
    return (float(width), None) if float(width) == 0 else (float(width), float(mu))


def channel_friction_overrides(friction):
    """--friction PHI_S PHI_2 D: the column's mu(I) as scene overrides (none: COLUMN_FRICTION)."""
    if not friction:
        return []
    phi_s, phi_2, grain = friction
    return [f"material.sand.friction_angle={phi_s}",
            f"material.sand.dynamic_friction_angle={phi_2}",
            f"material.sand.grain_diameter={grain}"]


def channel_study(args, out_dir):
    dx = 0.02 if args.quick else CHANNEL_DX
    aspects = (2.0, 8.0) if args.quick else CHANNEL_ASPECTS
    walls = ((0.0, None), (0.06, 0.4)) if args.quick else CHANNEL_WALLS
    if args.walls:
        walls = [channel_walls(w) for w in args.walls]
    friction = channel_friction_overrides(args.friction)
    rows = []
    with tempfile.TemporaryDirectory() as work:
        for width, mu in walls:
            for aspect in aspects:
                dimension = 2 if width == 0 else 3
                name = f"channel-{width}-{mu}-{aspect}"
                scene = os.path.join(work, name + ".toml")
                with open(scene, "w") as f:
                    f.write(column_scene(dimension, width, aspect, mu))
                out = os.path.join(work, name)
                _, summary, _ = run_scene(args, scene, [f"grid.dx={dx}"] + friction, out)
                ok = summary["status"] == "ok"
                value = column_runout(out) if ok else float("nan")
                reference = column_law(aspect)
                rows.append({"case": "v7", "aspect": aspect, "model": channel_label(width, mu),
                             "friction": " ".join(friction),
                             "channel_width": width, "wall_friction": 0.0 if mu is None else mu,
                             "dx": dx, "value": value,
                             "runout_p90": column_runout(out, 0.90) if ok else float("nan"),
                             "reference": reference,
                             "relative_error": (value - reference) / reference,
                             "particles": summary["particles"], "steps": summary["steps"],
                             "wall_seconds": summary["wall_seconds"], "status": summary["status"]})
                print(f"a {aspect:<4g} {channel_label(width, mu):32s}: runout {value:.4g} "
                      f"(law {reference:.4g}), {summary['particles']} particles, "
                      f"{summary['wall_seconds']:.1f} s", flush=True)
    write_exponents(rows, out_dir)
    return rows


def write_exponents(rows, out_dir):
    with open(os.path.join(out_dir, "exponents.csv"), "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["model", "aspect_from", "aspect_to", "exponent"])
        for model, a, b, exponent in channel_exponents(rows):
            writer.writerow([model, a, b, f"{exponent:.4f}"])
            print(f"{model:32s}: exponent {exponent:.3f} from a = {a:g} to {b:g}")


def channel_exponents(rows):
    """(model, a, b, exponent) for each model and each pair of consecutive aspect ratios >= 2:
    the runout's local power of a, d ln(runout) / d ln(a)."""
    import math
    result = []
    for model in dict.fromkeys(r["model"] for r in rows):
        runs = sorted((float(r["aspect"]), float(r["value"])) for r in rows if r["model"] == model)
        runs = [(a, v) for a, v in runs if a >= 2.0]
        for (a, u), (b, w) in zip(runs, runs[1:]):
            result.append((model, a, b, math.log(w / u) / math.log(b / a)))
    return result


def run_bench(bench, cells, steps, offset=0.0, domain=1.0):
    out = subprocess.run([bench, "--cells", str(cells), "--steps", str(steps),
                          "--offset", str(offset), "--domain", str(domain)],
                         capture_output=True, text=True, check=True)
    line = [l for l in out.stdout.splitlines() if l.startswith("result ")][-1]
    return {k: float(v) for k, v in (kv.split("=") for kv in line.split()[1:])}


def throughput(args, out_dir):
    bench = os.path.join(os.path.dirname(args.firn), "firn_bench")
    rows = []
    for cells in ([10, 20] if args.quick else [10, 15, 20, 30, 45, 64]):
        # The 20-cell block also 1 km from the origin, and in a domain 8 times its volume.
        variants = [(0.0, 1.0), (1000.0, 1.0), (0.0, 2.0)] if cells == 20 else [(0.0, 1.0)]
        for offset, domain in variants:
            steps = int(max(10, min(60, 4e7 / (7400 * (cells / 10) ** 3))))
            r = run_bench(bench, cells, steps, offset, domain)
            r.update({"cells": cells, "offset_m": offset, "domain_scale": domain, "steps": steps})
            rows.append(r)
            print(f"{int(r['particles']):8d} particles (offset {offset:g} m, domain x{domain:g}): "
                  f"{r['pss1'] / 1e6:.2f} M/s 1 thread, {r['pssN'] / 1e6:.2f} M/s "
                  f"{int(r['threads'])} threads, {r['bytes_per_particle_net']:.0f} B/particle",
                  flush=True)
    return rows


def pyplot():
    """matplotlib's pyplot on the Agg backend, or None (with a note) where it is missing."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib missing (Debian: python3-matplotlib): no chart")
        return None
    return plt


def chart_throughput(rows, out_dir):
    plt = pyplot()
    if plt is None:
        return
    at0 = sorted((r for r in rows if float(r["offset_m"]) == 0.0 and
                  float(r.get("domain_scale", 1.0)) == 1.0), key=lambda r: r["particles"])
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
    plt = pyplot()
    if plt is None:
        return
    ok = [r for r in rows if r["status"] == "ok" and float(r["relative_error"]) > 0]
    conv = {(c["case"], c["method"]): c for c in convergence(rows)}
    cases = [c for c in CASES if any(r["case"] == c for r in ok)]  # V1 first: all methods
    methods = list(METHODS)
    extra = ["navy", "darkgoldenrod", "magenta"]  # past tab10's ten
    colours = {m: plt.cm.tab10(i) if i < 10 else extra[(i - 10) % len(extra)]
               for i, m in enumerate(methods)}
    fig, axes = plt.subplots(len(cases), 2, figsize=(12, 3.9 * len(cases)), squeeze=False)
    for row, case in enumerate(cases):
        sel = [r for r in ok if r["case"] == case]
        for ax, cost, label in ((axes[row][0], "wall_seconds", "wall time (s, 1 thread)"),
                                (axes[row][1], "particle_steps", "particle-steps")):
            for method in methods:
                pts = sorted((float(r[cost]), float(r["relative_error"])) for r in sel
                             if r["method"] == method)
                if pts:
                    ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", ms=4, lw=1.2,
                              color=colours[method], label=method, alpha=0.85)
            points = [(float(r[cost]), float(r["relative_error"])) for r in sel]
            front = pareto(points)
            ax.loglog([points[i][0] for i in front], [points[i][1] for i in front], "k--",
                      lw=1.5, label="Pareto front", zorder=5)
            ax.axhline(0.05, color="grey", lw=0.8, ls=":")
            ax.set_xlabel(label)
            ax.set_ylabel("relative error")
            ax.grid(True, which="both", alpha=0.3)
        c = conv.get((case, "apic"), {})
        order = c.get("order_vs_reference", float("nan"))
        selfo = c.get("order_self", float("nan"))
        title = CASES.get(case, {}).get("title", case)
        axes[row][0].set_title(f"{title}\nAPIC: error ~ dx^{float(order):.2f}, "
                               f"self-convergence order {float(selfo):.2f}", fontsize="medium")
        axes[row][1].set_title(f"{title}\n(dotted: 5 % error)", fontsize="medium")
    axes[0][0].legend(fontsize="x-small", ncol=2)
    fig.suptitle("Accuracy against cost (one line per method over dx; log-log)")
    fig.tight_layout()
    for ext in ("png", "svg"):
        fig.savefig(os.path.join(out_dir, f"accuracy.{ext}"))


def chart_slice(rows, out_dir):
    plt = pyplot()
    if plt is None:
        return
    def group_of(r):  # V7 rows carry the column's aspect ratio (older results: a = 1 only)
        a = r.get("aspect", "")
        return (r["case"], float(r["dx"]),
                None if r["case"] != "v7" else float(a) if a not in ("", None) else 1.0)

    groups = list(dict.fromkeys(group_of(r) for r in rows))
    models = list(dict.fromkeys(r["model"] for r in rows))
    fig, axes = plt.subplots(1, 3, figsize=(max(14, 1.6 * len(groups)), 4.8))
    width = 0.8 / len(models)
    for k, model in enumerate(models):
        for ax, key in zip(axes, ("ratio", "wall_seconds", "particle_steps")):
            vals = []
            for group in groups:
                match = [r for r in rows if group_of(r) == group and r["model"] == model]
                r = match[0] if match else None
                vals.append(float("nan") if r is None else float(r["value"]) / float(r["reference"])
                            if key == "ratio" else float(r[key]))
            ax.bar([g + (k - (len(models) - 1) / 2) * width for g in range(len(groups))], vals,
                   width, label=model)
    for ax, label in zip(axes, ("measured / reference (V2: c_p; V7: Lube's law at a)",
                                "wall time (s, 1 thread)", "particle-steps")):
        ax.set_xticks(range(len(groups)))
        ax.set_xticklabels([f"{c.upper()}" + ("" if a is None else f" a={a:g}") + f"\ndx {dx:g}"
                            for c, dx, a in groups], fontsize="x-small")
        if label.startswith("measured"):
            ax.axhline(1.0, color="k", lw=0.8)
            ax.axhspan(0.85, 1.15, color="grey", alpha=0.15, lw=0)  # the issue's +-15 %
            ax.set_ylim(0, 1.6)
        else:
            ax.set_yscale("log")
        ax.set_title(label, fontsize="medium")
        ax.grid(True, axis="y", which="both", alpha=0.3)
    axes[0].legend(fontsize="small")
    fig.suptitle("The same plane-strain case in 2D and as a thin 3D slice between slip walls "
                 "(V2 P-wave speed, V7 column-collapse runout)")
    fig.tight_layout()
    for ext in ("png", "svg"):
        fig.savefig(os.path.join(out_dir, f"slice.{ext}"))


def chart_channel(rows, out_dir):
    plt = pyplot()
    if plt is None:
        return
    import numpy as np
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(13, 5))
    law_a = np.linspace(0.4, 10, 200)
    ax.plot(law_a[law_a < 1.8], 1.2 * law_a[law_a < 1.8], "k-", lw=1.5,
            label="Lube et al. 2005: 1.2 a (a < 1.8)")
    ax.plot(law_a[law_a > 2.8], 1.9 * law_a[law_a > 2.8] ** (2 / 3), "k--", lw=1.5,
            label="Lube et al. 2005: 1.9 a^(2/3) (a > 2.8)")
    for model in dict.fromkeys(r["model"] for r in rows):
        runs = sorted((float(r["aspect"]), float(r["value"])) for r in rows if r["model"] == model)
        ax.plot(*zip(*runs), "o-", label=model)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("aspect ratio a = H0 / L0")
    ax.set_ylabel("normalised runout (L - L0) / L0")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small")
    # Two walls take a friction of about mu_w K rho g h^2 per unit length of a flow of depth h
    # (K the lateral stress ratio) against its weight rho g h W: mu_w h / W relative to the weight.
    # Every run has the same L0, so mu_w L0 / W orders them.
    wall = {r["model"]: float(r["wall_friction"]) * COLUMN_L0 / float(r["channel_width"])
            if float(r["channel_width"]) > 0 else 0.0 for r in rows}
    bx.axhspan(0.57, 0.77, color="C2", alpha=0.2, lw=0, label="validation.md V7: 0.67 +- 0.1")
    bx.axhspan(0.8, 1.0, color="C1", alpha=0.2, lw=0,
               label="Balmforth & Kerswell 2005, wide channels: 0.9 +- 0.1")
    bx.axhspan(0.6, 0.7, color="C4", alpha=0.2, lw=0,
               label="Balmforth & Kerswell 2005, narrow slots: 0.65 +- 0.05")
    exponents = channel_exponents(rows)
    pairs = list(dict.fromkeys((a, b) for _, a, b, _ in exponents))
    for k, (lo, hi) in enumerate(pairs):
        points = sorted((wall[m], e) for m, a, b, e in exponents if (a, b) == (lo, hi))
        bx.plot(*zip(*points), "os^v"[k % 4] + "-", color="k", alpha=0.4 + 0.6 * k / len(pairs),
                label=f"Firn, a = {lo:g} to {hi:g}")
    bx.set_xlabel("wall friction mu_w L0 / W (0: 2D, no side walls)")
    bx.set_ylabel("large-a exponent d ln(runout) / d ln(a)")
    bx.set_ylim(0.4, 1.2)
    bx.legend(fontsize="small", loc="lower left")
    bx.grid(True, alpha=0.3)
    dx, friction = rows[0]["dx"], rows[0].get("friction")
    fig.suptitle(f"V7 column collapse in 2D and between Coulomb side walls (dx {float(dx):g}, "
                 + ("mu(I) fitted in 2D without walls)" if not friction else
                    friction.replace("material.sand.", "") + ")"))
    fig.tight_layout()
    for ext in ("png", "svg"):
        fig.savefig(os.path.join(out_dir, f"channel.{ext}"))


def chart_stability(rows, out_dir):
    plt = pyplot()
    if plt is None:
        return
    colours = {"stable": "tab:green", "inaccurate": "tab:orange", "unstable": "tab:red"}
    cases = [c for c in STABILITY_CASES if any(r.get("case", "block") == c for r in rows)]
    labels = sorted({(r["transfer"], r["particles_per_cell"]) for r in rows})
    fig, axes = plt.subplots(1, len(cases), figsize=(6 * len(cases), 0.5 * len(labels) + 1.8),
                             sharey=True, squeeze=False)
    for ax, case in zip(axes[0], cases):
        for y, (transfer, ppc) in enumerate(labels):
            for r in rows:
                if (r.get("case", "block"), r["transfer"], r["particles_per_cell"]) == (
                        case, transfer, ppc):
                    ax.scatter(r["cfl"], y, c=colours[r["outcome"]], s=120, marker="s")
        ax.set_yticks(range(len(labels)))
        ax.set_yticklabels([f"{t}, {p} ppc" for t, p in labels])
        ax.set_xlabel("CFL number")
        ax.set_title(STABILITY_CASES[case][0], fontsize="medium")
    for outcome, colour in colours.items():
        axes[0][-1].scatter([], [], c=colour, marker="s", label=outcome)
    axes[0][-1].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")
    fig.suptitle("Stability map: stable, unstable (solver status) or inaccurate "
                 f"(energy gain > {100 * DRIFT_LIMIT:.0f} % of the energy scale)", fontsize="small")
    fig.tight_layout()
    for ext in ("png", "svg"):
        fig.savefig(os.path.join(out_dir, f"stability.{ext}"))


NUMERIC = {"cfl", "particles_per_cell", "dx", "relative_error", "wall_seconds",
           "particle_steps", "acceleration", "energy_drift", "steps", "particles", "pss1",
           "pssN", "threads", "speedup", "bytes_per_particle", "bytes_per_particle_net", "cells",
           "offset_m", "domain_scale", "value", "reference", "slice_cells", "slice_width",
           "aspect", "channel_width", "wall_friction", "runout_p90"}


def read_rows(path):
    with open(path) as f:
        rows = [{k: (float(v) if k in NUMERIC and v != "" else v) for k, v in r.items()}
                for r in csv.DictReader(f)]
    for r in rows:
        if "particles_per_cell" in r:
            r["particles_per_cell"] = int(r["particles_per_cell"])
    return rows


def quick_check(study, rows):
    """The assertion of each study's quick mode (run in CI)."""
    if study == "throughput":
        # Timings are reported, never asserted. Memory is: the 58 000-particle block's own
        # footprint (peak RSS less the libraries) measured 216 bytes per particle; fixed costs
        # (grid, scratch) weigh more on small blocks, so 300 leaves room without hiding a
        # regression to the ~400 a second copy of the particle state would cost.
        block = [r for r in rows if r["cells"] == 20 and float(r["offset_m"]) == 0.0 and
                 float(r.get("domain_scale", 1.0)) == 1.0][0]
        if not (block["pss1"] > 0 and block["bytes_per_particle_net"] < 300):
            print(f"check failed: {block['bytes_per_particle_net']:.0f} bytes per particle "
                  "for the 58 000-particle block (limit 300)")
            return False
        return True
    if study == "stability":
        outcome = {(r["case"], r["transfer"], r["cfl"]): r["outcome"] for r in rows}
        if outcome[("block", "apic", 0.4)] != "stable" or \
                outcome[("block", "apic", 2.0)] == "stable":
            print("check failed: APIC must be stable at CFL 0.4 and not at CFL 2.0 (block)")
            return False
        if outcome[("slab", "apic", 0.4)] != "stable":
            print("check failed: APIC must be stable at CFL 0.4 (snow slab)")
            return False
        return True
    if study == "channel":
        # Side walls take momentum from the tall columns' fast flows more than from the short
        # ones', so the runout grows more slowly with a than in 2D. From a = 2 to 8 the 5 cm
        # channel (wall mu 0.4) measured 0.77 against 2D's 1.00 at dx 0.01, and the quick run's
        # 6 cm channel 0.79 against 1.04 at dx 0.02: a drop of 0.24; 0.1 fails a channel whose
        # walls have lost more than half of their grip.
        exponent = {m: e for m, a, b, e in channel_exponents(rows)}
        flat, walled = exponent["2D (no side walls)"], exponent[channel_label(0.06, 0.4)]
        if not walled < flat - 0.1:
            print(f"check failed: the channel's exponent {walled:.3f} must lie at least 0.1 "
                  f"below 2D's {flat:.3f}")
            return False
        return True
    ok = True
    if study == "slice":
        by = {r["model"]: r for r in rows}
        flat, thin = by["2D"], by["3D slice, 2 cells"]
        if not (flat["relative_error"] < 0.05 and thin["relative_error"] < 0.05):
            print("check failed: the P-wave speed must be within V2's 5 % in 2D and in the slice")
            ok = False
        if not abs(flat["value"] - thin["value"]) / WAVE_CP < 0.01:
            print(f"check failed: 2D ({flat['value']:.2f} m/s) and the slice "
                  f"({thin['value']:.2f} m/s) must agree within 1 % of c_p (both plane strain)")
            ok = False
        if not thin["particle_steps"] > flat["particle_steps"]:
            print("check failed: the slice must cost more particle-steps than 2D")
            ok = False
        return ok
    by_case = {}
    for r in rows:
        by_case.setdefault(r["case"], []).append(r)
    if "v1" in by_case:
        worst = max(r["relative_error"] for r in by_case["v1"])
        if not worst < 0.03:  # validation.md V1: 3 %
            print(f"check failed: V1 acceleration error {worst:.3g} above the 3 % of V1")
            ok = False
    if "v2" in by_case:
        errors = [r["relative_error"] for r in sorted(by_case["v2"], key=lambda r: -r["dx"])]
        if not all(b < a for a, b in zip(errors, errors[1:])) or not errors[-1] < 0.05:
            print(f"check failed: V2 wave-speed errors {errors} must fall with dx and end "
                  "within V2's 5 %")
            ok = False
    if "v7" in by_case:
        runs = sorted(by_case["v7"], key=lambda r: -r["dx"])
        # The issue's +-15 % at 20 cells per column (validation.md V7 allows 25 %; measured
        # -6 % with Mohr-Coulomb, so 15 % still fails a return of the plane-strain cone's error).
        if not all(abs(r["relative_error"]) < 0.15 for r in runs):
            print(f"check failed: V7 runout errors {[r['relative_error'] for r in runs]} "
                  "outside 15 %")
            ok = False
    if "v8" in by_case:
        # validation.md V8: the flat critical cut length inside the field range 0.1-1 m (the
        # study's bracket is [0.1, 1.0] m: a value at either end means it never changed side).
        values = [r["value"] for r in by_case["v8"]]
        if not all(0.11 < v < 0.98 and r["status"] == "ok" for v, r in zip(values, by_case["v8"])):
            print(f"check failed: V8 critical cut lengths {values} must lie inside (0.1, 1.0) m")
            ok = False
    return ok


def main():
    parser = argparse.ArgumentParser(description="Firn study harness")
    parser.add_argument("study",
                        choices=["stability", "accuracy", "throughput", "slice", "channel"])
    parser.add_argument("--quick", action="store_true", help="small subset with a check (CI)")
    parser.add_argument("--firn", default=os.path.join(ROOT, "build", "firn"))
    parser.add_argument("--out", default=None, help="results folder (default bench/results/<study>)")
    parser.add_argument("--threads", type=int, default=None,
                        help="firn worker threads (default: firn's, all cores)")
    parser.add_argument("--cases", nargs="+", choices=list(CASES), default=None,
                        help="accuracy: run only these cases (a full run keeps the others' rows)")
    parser.add_argument("--methods", nargs="+", choices=list(METHODS), default=None,
                        help="accuracy: run only these methods (keeps the others' rows)")
    parser.add_argument("--transfers", nargs="+", choices=list(TRANSFERS), default=None,
                        help="stability: run only these transfers (keeps the others' rows)")
    parser.add_argument("--aspects", nargs="+", type=float, default=list(SLICE_ASPECTS),
                        help="slice: V7 aspect ratios a = H0 / L0 at dx 0.005, 2D and a 2-cell "
                             "slice (default 0.5 1 2 4; a = 1 also at dx 0.01 and 0.0025)")
    parser.add_argument("--walls", nargs="+", metavar="WIDTH:MU",
                        help="channel: side walls to run, width in m and Coulomb coefficient "
                             "(0 for 2D without walls; default the study's six)")
    parser.add_argument("--friction", nargs=3, type=float, metavar=("PHI_S", "PHI_2", "D"),
                        help="channel: the column's mu(I), static and dynamic friction angles "
                             "(degrees) and grain diameter (m) (default COLUMN_FRICTION)")
    parser.add_argument("--chart-only", action="store_true",
                        help="redraw the charts from an existing results.csv")
    args = parser.parse_args()
    out_dir = args.out or os.path.join(ROOT, "bench", "results", args.study)
    os.makedirs(out_dir, exist_ok=True)
    studies = {"stability": (stability, chart_stability), "accuracy": (accuracy, chart_accuracy),
               "throughput": (throughput, chart_throughput), "slice": (slice_study, chart_slice),
               "channel": (channel_study, chart_channel)}
    run, chart = studies[args.study]
    if args.chart_only:
        rows = read_rows(os.path.join(out_dir, "results.csv"))
        if args.study == "accuracy":
            write_convergence(rows, out_dir)
        if args.study == "channel":
            write_exponents(rows, out_dir)
        chart(rows, out_dir)
        return 0
    rows = run(args, out_dir)
    fields = list(dict.fromkeys(k for r in rows for k in r))
    with open(os.path.join(out_dir, "results.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
    scene = {"stability": {case: text for case, (_, text) in STABILITY_CASES.items()},
             "accuracy": {"v1": SLIDING_BLOCK, "v2": wave_scene(),
                          "v7": column_scene(), "v8": "scenes/pst.toml"},
             "throughput": "bench/bench_core.cc blockScene()",
             "slice": {"v2": wave_scene(), "v7": column_scene(),
                       "3D slice": "the same with dimension 3, 8 particles per cell and slip "
                                   "walls at z = 0 and z = cells * dx",
                       "v7 aspects": f"column height a * L0 for a in {list(args.aspects)}, "
                                     "end_time 0.2 ceil(3 sqrt(max(1, a))) s, dx 0.005"},
             "channel": {"v7": column_scene(),
                         "channel": "the same with dimension 3, 8 particles per cell, Coulomb "
                                    "walls at z = 0 and z = width (CHANNEL_WALLS or --walls "
                                    f"{args.walls}), a in {list(CHANNEL_ASPECTS)}, dx {CHANNEL_DX}",
                         "friction": channel_friction_overrides(args.friction) or COLUMN_FRICTION}
             }[args.study]
    with open(os.path.join(out_dir, "run.json"), "w") as f:
        json.dump({"study": args.study, "quick": args.quick, "commit": commit(),
                   "machine": platform.platform(), "processor": platform.processor(),
                   "cpus": os.cpu_count(), "threads": args.threads,
                   "cases": sorted({r["case"] for r in rows if "case" in r}),
                   "scene": scene}, f, indent=2)
    chart(rows, out_dir)
    if args.quick and not quick_check(args.study, rows):
        return 1
    print(f"wrote {out_dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
