"""What the render tests share: a tiny 3D cache (a 0.6 x 0.4 m slab, 0.2 m deep, of granular snow
on a 30 degree slip plane, down-slope along +x) made by `firn run`, and a check that prints
what it checked and stops at the first failure."""

import argparse
import os
import shutil
import subprocess
import sys

SCENE = """
[simulation]
name = "{name}"
dimension = 3
end_time = {end_time}
frame_rate = {frame_rate}
gravity = [0.0, -9.81, 0.0]

[grid]
dx = 0.05
particles_per_cell = 8

[[material]]
name = "snow"
model = "granular"
density = 300.0
friction_angle = 30.0

[[terrain]]
shape = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.5, 0.8660254, 0.0]
boundary = "slip"

[[body]]
material = "snow"
shape = "layer"
thickness = 0.2
x_range = [0.0, 0.6]
z_range = [0.0, 0.4]
"""


def check(condition, what):
    print(("ok:     " if condition else "FAILED: ") + what)
    if not condition:
        sys.exit(1)


def arguments(tool):
    """The --firn and --work options of a render test, or None (after a "skipped" line) when the
    third-party `tool` it drives is not installed."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--firn", required=True)
    parser.add_argument("--work", required=True)
    args = parser.parse_args()
    if not os.path.exists(tool):
        print(f"skipped: {os.path.basename(tool)} not installed ({tool} is missing)")
        return None
    return args


def make_cache(firn, work, name, end_time, frame_rate):
    """Runs the slab into work/cache (work is emptied first); returns the cache folder."""
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    scene = os.path.join(work, "scene.toml")
    with open(scene, "w") as f:
        f.write(SCENE.format(name=name, end_time=end_time, frame_rate=frame_rate))
    cache = os.path.join(work, "cache")
    subprocess.run([firn, "run", scene, "--out", cache, "--threads", "2", "--quiet"], check=True)
    return cache
