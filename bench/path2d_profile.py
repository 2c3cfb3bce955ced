#!/usr/bin/python3
"""Prints the ground profile of scenes/path2d.toml (the long 2D path of Gaume et al. 2019, Fig. 2
bottom: L = 480 m, H = 180 m, with ground roughness).

The path is a parabola y = H (1 - x/L)^2 (37 degrees at the top, flat from x = L), followed by a
flat runout to x = 600 m. Roughness: a smooth Gaussian random field (white noise filtered by a
Gaussian of the correlation length), scaled to the standard deviation, as the paper's simplex
Perlin noise; it fades in from x = 30 to 50 m so that the release rests on the smooth parabola.
Sampled every 2.5 m; the solver interpolates linearly in between.

    /usr/bin/python3 bench/path2d_profile.py [--std 0.5] [--corr 10] [--seed 1] > points.txt
"""
import argparse

import numpy as np

LENGTH, HEIGHT, END, STEP = 480.0, 180.0, 600.0, 2.5


def profile(std, corr, seed):
    x = np.arange(0.0, END + STEP / 2, STEP)
    y = np.where(x < LENGTH, HEIGHT * (1.0 - x / LENGTH) ** 2, 0.0)
    rng = np.random.RandomState(seed)
    # white noise on a fine lattice, filtered, then sampled at the profile's points
    fine = 0.25
    pad = 4.0 * corr
    xf = np.arange(-pad, END + pad + fine / 2, fine)
    noise = rng.standard_normal(xf.size)
    k = np.arange(-pad, pad + fine / 2, fine)
    kernel = np.exp(-0.5 * (k / (corr / 2.0)) ** 2)
    field = np.convolve(noise, kernel, mode="same")
    field = np.interp(x, xf, field)
    field *= std / field.std()
    fade = np.clip((x - 30.0) / 20.0, 0.0, 1.0)
    return x, y + fade * field


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--std", type=float, default=0.5, help="roughness std, m")
    ap.add_argument("--corr", type=float, default=10.0, help="correlation length, m")
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    x, y = profile(a.std, a.corr, a.seed)
    pts = [f"[{xi:.1f}, {yi:.3f}]" for xi, yi in zip(x, y)]
    lines = []
    for i in range(0, len(pts), 6):
        lines.append(", ".join(pts[i:i + 6]))
    print("points   = [" + (",\n            ".join(lines)) + "]")


if __name__ == "__main__":
    main()
