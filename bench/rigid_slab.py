#!/usr/bin/python3
"""What a released slab could do on its slope: a rigid-slab Coulomb reference.

Reads a scene with a `profile` terrain and a body above a slip surface (`slides_on`), treats the
released slab (and any sphere riding on the same surface, the trigger) as one rigid sheet that
keeps its shape along the ground, and integrates

    a = g <sin(theta)> - mu <g cos(theta) + v^2 kappa>

(mass-weighted means over the sheet at its current place; kappa the ground's curvature, which on a
concave slope presses the slab harder), from rest at the release time, for each friction mu.
Prints the slab's centre-of-mass height above the lowest ground point and the frictionless bound
sqrt(2 g h) on its speed, the speed against time for each mu, and, with --run, the run's
`slab_speed` beside it. docs/slope-scale.md uses it for scenes/slope3d.toml.
What-ifs: --x-range LO HI releases only the slab between x = LO and HI (a release of part of the
slope); --profile-power N replaces the ground by y = H (1 - x/L)^N through the profile's own
drop H and length L (to its lowest point; flat beyond): N = 2 is the parabola of slope3d, a larger
N a more concave slope, steeper at the top (N = 2.44 gives 45 degrees there for L 22, H 9).

    /usr/bin/python3 bench/rigid_slab.py scenes/slope3d.toml [--friction 0 0.1 0.3 0.5 0.69]
                     [--release 0.3] [--end 3] [--bodies slab block] [--run OUT_DIR]
                     [--x-range LO HI] [--profile-power N]
"""
import argparse
import csv
import math
import sys
import tomllib

import numpy as np


def power_profile(points, power):
    """y = H (1 - x/L)^power from the profile's first point to its lowest, flat beyond."""
    x0, top = points[0]
    low = int(np.argmin(points[:, 1]))
    length, bottom = points[low, 0] - x0, points[low, 1]
    xs = np.linspace(x0, x0 + length, 201)
    ys = bottom + (top - bottom) * (1.0 - (xs - x0) / length)**power
    return np.vstack([np.column_stack([xs, ys]), points[low + 1:]])


def scene_geometry(path, names=None):
    with open(path, 'rb') as f:
        scene = tomllib.load(f)
    dim = scene['simulation'].get('dimension', 3)
    densities = {m['name']: m['density'] for m in scene['material']}
    profile = next((t for t in scene.get('terrain', []) if t.get('shape') == 'profile'), None)
    if profile is None:
        sys.exit(f'{path}: no [[terrain]] with shape = "profile"')
    bodies = scene.get('body', [])
    riders = [b for b in bodies if (b['name'] in names if names else 'slides_on' in b)]
    slabs = [b for b in riders if b.get('shape') == 'layer']
    if not slabs:
        sys.exit(f'{path}: no layer body with slides_on (the released slab); name it with --bodies')
    return dim, densities, np.array(profile['points'], float), slabs, riders


G = 9.81


class Sheet:
    """The released mass along the ground: positions (arc length) and masses of its elements."""

    def __init__(self, path, names=None, x_range=None, profile_power=None):
        dim, densities, points, slabs, riders = scene_geometry(path, names)
        if profile_power is not None:
            points = power_profile(points, profile_power)
        xs = np.linspace(points[0, 0], points[-1, 0], 40001)
        ys = np.interp(xs, points[:, 0], points[:, 1])
        slope = np.gradient(ys, xs)
        self.arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(xs), np.diff(ys)))])
        self.theta = np.arctan(-slope)  # down-slope angle, positive where the ground falls along +x
        # Curvature where the ground is concave (presses the slab harder); none where convex.
        self.kappa = np.clip(np.gradient(np.arctan(slope), self.arc), 0.0, None)
        self.dim = dim
        at, mass = [], []
        for b in slabs:
            lo, hi = b['x_range']
            if x_range is not None:
                lo, hi = max(lo, x_range[0]), min(hi, x_range[1])
            x = np.linspace(lo, hi, 2000)
            if 'thickness_profile' in b:
                tp = np.array(b['thickness_profile'], float)
                h = np.interp(x, tp[:, 0], tp[:, 1])
            else:
                h = np.full_like(x, b['thickness'])
            width = (b['z_range'][1] - b['z_range'][0]) if dim == 3 else 1.0
            ds = np.gradient(np.interp(x, xs, self.arc))
            ds[0] /= 2.0  # trapezoid weights: the end samples stand for half an interval
            ds[-1] /= 2.0
            at.append(x)
            mass.append(densities[b['material']] * h * ds * width)
        for b in riders:
            if b.get('shape') == 'sphere':
                r = b['radius']
                volume = 4.0 / 3.0 * math.pi * r**3 if dim == 3 else math.pi * r * r
                at.append(np.array([b['center'][0]]))
                mass.append(np.array([densities[b['material']] * volume]))
        x0 = np.concatenate(at)
        self.mass = np.concatenate(mass)
        self.s0 = np.interp(x0, xs, self.arc)
        self.height = np.sum(self.mass * (np.interp(x0, xs, ys) - ys.min())) / self.mass.sum()

    def slide(self, mu, release, end, times, dt=1e-3):
        """Speed of the rigid sheet at `times`, released from rest at `release`, friction mu."""
        d, v, speeds = 0.0, 0.0, {}
        m = self.mass
        for n in range(int(round(end / dt)) + 1):
            t = n * dt
            for tt in times:
                if abs(t - tt) < dt / 2:
                    speeds[round(tt, 3)] = v
            if t < release:
                continue
            s = self.s0 + d
            th, k = np.interp(s, self.arc, self.theta), np.interp(s, self.arc, self.kappa)
            drive = G * np.sum(m * np.sin(th)) / m.sum()
            resist = mu * np.sum(m * (G * np.cos(th) + v * v * k)) / m.sum()
            if v > 0.0 or drive > resist:  # a slab at rest stays while friction holds it
                v = max(v + (drive - resist) * dt, 0.0)
            d += v * dt
        return speeds


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('scene')
    ap.add_argument('--friction', type=float, nargs='+', default=[0.0, 0.1, 0.3, 0.5, 0.69])
    ap.add_argument('--release', type=float, default=0.0, help='s: when the slab starts to move')
    ap.add_argument('--end', type=float, default=3.0, help='s')
    ap.add_argument('--bodies', nargs='+', help='the released bodies (default: those with slides_on)')
    ap.add_argument('--run', help='an output folder: its metrics.csv slab_speed is printed beside')
    ap.add_argument('--x-range', type=float, nargs=2, metavar=('LO', 'HI'),
                    help='m: release only the slab between these x')
    ap.add_argument('--profile-power', type=float, metavar='N',
                    help='replace the ground by y = H (1 - x/L)^N through the same H and L')
    args = ap.parse_args()
    sheet = Sheet(args.scene, args.bodies, args.x_range, args.profile_power)
    print(f'{args.scene}: released mass {sheet.mass.sum():.0f} kg{"" if sheet.dim == 3 else "/m"}, '
          f'centre of mass {sheet.height:.2f} m above the lowest ground; frictionless bound '
          f'sqrt(2 g h) = {math.sqrt(2 * G * sheet.height):.2f} m/s')
    times = np.arange(0.0, args.end + 1e-9, 0.5)
    columns = {f'mu {mu:g}': sheet.slide(mu, args.release, args.end, times) for mu in args.friction}
    if args.run:
        with open(f'{args.run}/metrics.csv') as f:
            rows = list(csv.DictReader(f))
        t_run = np.array([float(r['time']) for r in rows])
        v_run = np.array([float(r['slab_speed'] or 0) for r in rows])
        columns['run'] = {round(t, 3): float(np.interp(t, t_run, v_run)) for t in times
                          if t <= t_run[-1] + 1e-9}
    print('t (s)  ' + '  '.join(f'{c:>8s}' for c in columns))
    for t in times:
        key = round(t, 3)
        print(f'{t:5.1f}  ' + '  '.join(
            f'{columns[c][key]:8.2f}' if key in columns[c] else f'{"":8s}' for c in columns))


if __name__ == '__main__':
    main()
