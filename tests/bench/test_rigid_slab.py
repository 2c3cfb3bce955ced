#!/usr/bin/python3
"""bench/rigid_slab.py against closed forms: a sheet on a straight plane slides at
a = g (sin theta - mu cos theta) (V1), stays at rest where mu >= tan theta, and its frictionless
bound is sqrt(2 g h) for the centre of mass h above the plane's foot; its what-ifs (--x-range,
--profile-power) release the part of the slab asked and keep the profile's drop."""
import importlib.util
import math
import os
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
spec = importlib.util.spec_from_file_location(
    'rigid_slab', os.path.join(HERE, '..', '..', 'bench', 'rigid_slab.py'))
rigid_slab = importlib.util.module_from_spec(spec)
spec.loader.exec_module(rigid_slab)

# A 30 degree plane from x = 0 to 40 m, flat from there; a 0.4 m slab over x = 2-10 m and a
# 0.5 m disc riding on it (2D), both above the slip surface.
TAN30 = math.tan(math.radians(30))
SCENE = f'''
[simulation]
dimension = 2
[[material]]
name = "slab"
density = 250.0
[[material]]
name = "weak"
density = 100.0
[[material]]
name = "ball"
density = 400.0
[[terrain]]
shape = "profile"
points = [[0.0, {40 * TAN30}], [40.0, 0.0], [60.0, 0.0]]
[[body]]
name = "weak"
material = "weak"
shape = "layer"
thickness = 0.1
x_range = [2.0, 10.0]
[[body]]
name = "slab"
material = "slab"
shape = "layer"
thickness = 0.4
x_range = [2.0, 10.0]
slides_on = "weak"
[[body]]
name = "ball"
material = "ball"
shape = "sphere"
center = [6.0, 20.0]
radius = 0.5
slides_on = "weak"
'''

failures = []


def check(what, got, want, tolerance):
    ok = abs(got - want) <= tolerance
    print(f'{"ok  " if ok else "FAIL"} {what}: {got:.5f} against {want:.5f} (tolerance {tolerance:g})')
    if not ok:
        failures.append(what)


with tempfile.TemporaryDirectory() as work:
    path = os.path.join(work, 'plane.toml')
    with open(path, 'w') as f:
        f.write(SCENE)
    sheet = rigid_slab.Sheet(path)
    g, s, c = rigid_slab.G, 0.5, math.cos(math.radians(30))
    slab, ball = 250 * 0.4 * 8 / c, 400 * math.pi * 0.25  # kg per metre of width
    check('released mass (kg/m)', sheet.mass.sum(), slab + ball, 1e-6 * (slab + ball))
    # Centre of mass above the foot (x = 40 m): the slab's middle (x = 6 m) and the ball's centre
    # both lie over x = 6 m, 34 m up the plane.
    check('centre-of-mass height (m)', sheet.height, 34 * TAN30, 1e-3)
    # Released at 0.5 s; after 1 s of sliding, still on the plane (the sheet moves < 5 m).
    # Tolerance: one step of the integrator (1e-3 s) at the acceleration, should the release or
    # the sampled time fall one step off.
    for mu in (0.0, 0.2, 0.5):
        a = g * (s - mu * c)
        v = sheet.slide(mu, 0.5, 1.5, [1.5])[1.5]
        check(f'speed after 1 s at mu {mu}', v, a * 1.0, a * 1e-3 + 1e-9)
    # mu above tan 30 (0.577): held still.
    check('speed at mu 0.6 (held)', sheet.slide(0.6, 0.0, 1.0, [1.0])[1.0], 0.0, 0.0)

    # --x-range: only the slab over x = 2-6 m releases (the ball rides on regardless).
    part = rigid_slab.Sheet(path, x_range=(0.0, 6.0))
    check('released mass over x = 2-6 m (kg/m)', part.mass.sum(), slab / 2 + ball,
          1e-6 * (slab + ball))
    # --profile-power 1 is the plane itself: the same closed form.
    line = rigid_slab.Sheet(path, profile_power=1.0)
    a = g * (s - 0.2 * c)
    check('speed after 1 s at mu 0.2, power 1', line.slide(0.2, 0.5, 1.5, [1.5])[1.5], a,
          a * 1e-3 + 1e-9)
    # Power 2: the parabola through the same drop and length, twice the plane's slope at the top
    # and flat at the foot (x = 40 m), the drop unchanged. Tolerance 1 %: the first of the
    # profile's 200 segments reads its mean slope, 0.25 % below the derivative at the top.
    points = rigid_slab.power_profile(rigid_slab.scene_geometry(path)[2], 2.0)
    top_slope = -(points[1, 1] - points[0, 1]) / (points[1, 0] - points[0, 0])
    check('power 2: slope at the top', top_slope, 2 * TAN30, 2 * TAN30 * 0.01)
    check('power 2: drop (m)', points[0, 1] - points[:, 1].min(), 40 * TAN30, 1e-9)

if failures:
    sys.exit(f'{len(failures)} check(s) failed: ' + ', '.join(failures))
