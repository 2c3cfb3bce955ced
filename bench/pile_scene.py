#!/usr/bin/python3
"""validation.md V11's resting pile as a scene: a 2D triangle of sand on a flat Coulomb floor.

The pile of `tests/validation/flow_test.cc` (half-width R 4 m, density 1500 kg/m^3, E 5 MPa,
nu 0.3, 4 particles per cell, CFL 0.4, no sleeping, bed friction tan(phi)), with its flanks at any
angle, written as one box per particle column (the exact shape at particle resolution, as the
test seeds it). docs/limitations.md (*A granular pile with flanks at its friction angle*)
runs it at flank angles around phi and the flowing angle atan(sin phi):

    /usr/bin/python3 bench/pile_scene.py --flank 29 --dx 0.05 > pile.toml
    build/firn run pile.toml --out out/pile --threads 1

and reads the centre of mass from out/pile/metrics.csv (com_x, com_y against frame 0).
"""
import argparse
import math
import sys


def pile_scene(flank_deg, phi_deg, dx, half_width=4.0, end_time=5.0):
    top = half_width * math.tan(math.radians(flank_deg))
    text = f"""[simulation]
name = "pile-{flank_deg:g}"
dimension = 2
end_time = {end_time!r}
frame_rate = 2
gravity = [0.0, -9.81]

[grid]
dx = {dx!r}
particles_per_cell = 4
cfl = 0.4
sleep = false

[[material]]
name = "sand"
model = "granular"
density = 1500.0
youngs_modulus = 5e6
poisson_ratio = 0.3
friction_angle = {float(phi_deg)!r}

[[terrain]]
shape = "plane"
point = [0.0, 0.0]
normal = [0.0, 1.0]
boundary = "friction"
friction = {math.tan(math.radians(phi_deg))!r}
"""
    width = dx / 2  # one particle spacing at 4 particles per cell
    i = math.floor(-half_width / width)
    while i * width < half_width:
        centre = (i + 0.5) * width
        height = top * (1 - abs(centre) / half_width)
        if height >= width:
            text += (f'\n[[body]]\nmaterial = "sand"\nshape = "box"\n'
                     f"min = [{i * width!r}, 0.0]\nmax = [{(i + 1) * width!r}, {height!r}]\n")
        i += 1
    return text


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--flank", type=float, required=True, help="flank angle, degrees")
    parser.add_argument("--phi", type=float, default=30.0, help="friction angle, degrees (30)")
    parser.add_argument("--dx", type=float, default=0.05, help="grid spacing, m (0.05)")
    args = parser.parse_args()
    if not 0 < args.flank < 90 or not 0 < args.phi < 90 or not args.dx > 0:
        parser.error("--flank and --phi must lie in (0, 90) degrees and --dx be > 0")
    sys.stdout.write(pile_scene(args.flank, args.phi, args.dx))
    return 0


if __name__ == "__main__":
    sys.exit(main())
