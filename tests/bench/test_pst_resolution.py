#!/usr/bin/python3
"""bench/pst_resolution.py's pure parts: the closed form against validation.md V8's example values,
the bisection (its simulation replaced), its "run" reading of metrics.csv (a crack counts only
when it reaches back to the cut: a free up-slope end yielding on its own under a steep slope's
load is not the cut's crack), the up-slope front's speed, and --weak-thickness's overrides read
from scenes/pst.toml."""
import csv
import importlib.util
import math
import os
import sys
import tempfile
import tomllib

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, '..', '..')
spec = importlib.util.spec_from_file_location(
    'pst_resolution', os.path.join(ROOT, 'bench', 'pst_resolution.py'))
pst = importlib.util.module_from_spec(spec)
spec.loader.exec_module(pst)

failures = []


def check(what, ok, detail):
    print(f'{"ok  " if ok else "FAIL"} {what}: {detail}')
    if not ok:
        failures.append(what)


# validation.md V8: a_c = 1.129, 0.865, 0.622, 0.401, 0.300, 0.244 m at 0-38 degrees, quoted to
# 1 mm; pst.toml's 6 cm layer of G 0.2 MPa has the example's D_wl / G_wl, so the same Lambda.
for slope, want in ((0, 1.129), (10, 0.865), (20, 0.622), (30, 0.401), (35, 0.300), (38, 0.244)):
    got = pst.closed_form_ac(slope)
    check(f'closed form at {slope} deg', abs(got - want) <= 5e-4, f'{got:.4f} against {want} m')


def metrics(work, name, rows):
    """A metrics.csv with the crack extent's columns only: rows of (time, min_x, max_x)."""
    out = os.path.join(work, name)
    os.makedirs(out)
    with open(os.path.join(out, 'metrics.csv'), 'w', newline='') as f:
        writer = csv.writer(f)
        writer.writerow(['frame', 'time', 'crack_tip_min_x', 'crack_tip_max_x'])
        for frame, (time, lo, hi) in enumerate(rows):
            writer.writerow([frame, time, '' if lo is None else lo, '' if hi is None else hi])
    return out


# A 3 m column cut over its last 0.5 m (tip at x = 2.5 m), dx 0.03.
TIP, DX = 2.5, 0.03
with tempfile.TemporaryDirectory() as work:
    runs = metrics(work, 'runs', [(0.0, None, None), (0.05, 1.6, 2.49), (0.1, 0.02, 2.49)])
    reach = pst.up_slope_reach(runs, TIP, DX)
    check('the cut\'s crack reaches the up-slope end', reach == 0.02, f'reach {reach} m')

    # The free up-slope end yields alone (the extent is that one particle's cell): before
    # 2026-12-05 this read as a run at any cut.
    lone = metrics(work, 'lone', [(0.0, 0.015, 0.015), (0.1, 0.015, 0.015)])
    reach = pst.up_slope_reach(lone, TIP, DX)
    check('a lone yield at the free end is no crack', math.isinf(reach), f'reach {reach}')

    stops = metrics(work, 'stops', [(0.0, 2.4, 2.49), (0.1, 1.2, 2.49), (0.2, 1.2, 2.49)])
    reach = pst.up_slope_reach(stops, TIP, DX)
    check('an arrested crack reaches where it stopped', reach == 1.2, f'reach {reach} m')

    # The up-slope end at 1.6 m at 0.05 s and 0.2 m at 0.1 s (28 m/s between): from 1.6 to
    # 0.5 m, passed at 0.05 s and 0.05 + 1.1 / 28 s, interpolated, it runs at 28 m/s.
    rows = [(0.0, 2.45, 2.49), (0.05, 1.6, 2.49), (0.1, 0.2, 2.49)]
    speed = pst.front_speed(metrics(work, 'front', rows), 1.6, 0.5)
    check('front speed interpolated between frames', abs(speed - 28.0) < 1e-9, f'{speed} m/s')

# The bisection, with the simulation replaced by a column whose crack runs from any cut of
# 0.31 m or more (not a bisection point): it must close in on 0.31 m, cut at the down-slope end,
# and run each simulation for --ac-end-time (a slow crack in a 0.2 s run reads as arrested: a
# slab of 0.5 MPa read a flat a_c of 0.56-0.60 m that way, 0.19-0.23 m with 0.8 s).
calls = []


def fake_run(firn, overrides, out, extra=()):
    calls.append(list(overrides) + list(extra))
    return {}, 1.0


def fake_reach(out, tip, dx):
    cut = 3.0 - tip
    return 0.0 if cut >= 0.31 else math.inf


real_run, real_reach = pst.run, pst.up_slope_reach
pst.run, pst.up_slope_reach = fake_run, fake_reach
try:
    stays, runs, _ = pst.critical_cut('firn', 0.03, 30.0, '/nonexistent', ['k=v'], 'run', 5,
                                      (0.0, 1.2), end_time=0.8)
finally:
    pst.run, pst.up_slope_reach = real_run, real_reach
bracketed = stays < 0.31 <= runs and runs - stays <= 1.2 / 2 ** 5 + 1e-9
check('the bisection brackets the critical cut', bracketed,
      f'{stays}-{runs} m after {len(calls)} runs')
check('every run lasts --ac-end-time', all('simulation.end_time=0.8' in c for c in calls),
      str(sorted({o for c in calls for o in c if o.startswith('simulation.end_time')})))


def override(run_overrides, key):
    return float(next(o for o in run_overrides if o.startswith(key + '=')).split('=')[1])


check('the cut is at the down-slope end of the 3 m column',
      all(abs(override(c, 'cut.weak.from_x') + override(c, 'cut.weak.length') - 3.0) < 1e-9
          for c in calls), f'{len(calls)} runs')
check('the scene overrides reach every run', all('k=v' in c for c in calls), f'{len(calls)} runs')

# --ac-column: the bisection on a longer column (bench/pst_slope3d_layers.toml's cuts reach
# 1.6 m), the cut still at its down-slope end and the layers as long as the column.
calls.clear()
pst.run, pst.up_slope_reach = fake_run, lambda out, tip, dx: 0.0 if 8.0 - tip >= 1.03 else math.inf
try:
    stays, runs, _ = pst.critical_cut('firn', 0.05, 26.8, '/nonexistent', [], 'run', 5,
                                      (0.0, 1.6), end_time=0.3, length=8.0)
finally:
    pst.run, pst.up_slope_reach = real_run, real_reach
check('an 8 m column brackets its critical cut', stays < 1.03 <= runs, f'{stays}-{runs} m')
check('the cut is at the down-slope end of the 8 m column',
      all(abs(override(c, 'cut.weak.from_x') + override(c, 'cut.weak.length') - 8.0) < 1e-9
          and 'body.slab.x_range=[0.0, 8.0]' in c for c in calls), f'{len(calls)} runs')

with open(os.path.join(ROOT, 'scenes', 'pst.toml'), 'rb') as f:
    scene = tomllib.load(f)
thickness = next(b for b in scene['body'] if b['name'] == 'weak')['thickness']
softening = next(m for m in scene['material'] if m['name'] == 'weak')['softening']
check('the scene\'s own thickness needs no override', pst.weak_thickness_overrides(thickness) == [],
      str(pst.weak_thickness_overrides(thickness)))
doubled = pst.weak_thickness_overrides(2 * thickness)
want = [f'body.weak.thickness={2 * thickness}', f'material.weak.softening={2 * softening:g}',
        f'material.weak.softening_length={2 * thickness}']
check('twice the thickness: twice the softening, the band at the layer', doubled == want,
      str(doubled))

sys.exit(1 if failures else 0)
