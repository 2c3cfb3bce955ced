"""render/blender_render.py end to end: a tiny 3D cache rendered by Blender's Cycles.

    /usr/bin/python3 tests/render/test_blender.py --firn BUILD/firn --work SCRATCH_DIR

Runs a small slab of snow sliding on a 30 degree plane (about 3 500 particles, 2 frames), renders
its last frame twice at 240x135 with 8 samples, with the snow and without it (--no-snow, same
camera), and checks the image: it decodes, is not uniform, the snow's pixels differ from the bare
ground and sky, are brighter (white snow on dark ground), and lie inside the frame, clear of its
edges (the camera frames the whole deposit). Also checks that bad input exits non-zero with a
message. Skipped (exit 0) when /usr/bin/blender is missing. About 20 s on 2 cores.
"""

import os
import subprocess
import sys

import matplotlib.image
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tiny_cache import arguments, check, make_cache  # noqa: E402

BLENDER = "/usr/bin/blender"
SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "render",
                      "blender_render.py")
def blender(*args):
    command = [BLENDER, "-b", "--python", SCRIPT, "--", *args]
    return subprocess.run(command, capture_output=True, text=True)


def render(cache, out, *extra):
    result = blender(cache, "--frames", "1", "--res", "240x135", "--samples", "8",
                     "--threads", "2", "--out", out, *extra)
    if result.returncode != 0:
        print(result.stdout[-3000:], result.stderr[-3000:])
    check(result.returncode == 0, f"blender_render.py {' '.join(extra)} exits 0")
    path = os.path.join(out, "frame.0001.png")
    check(os.path.isfile(path), f"it wrote {path}")
    image = matplotlib.image.imread(path)[:, :, :3].astype(float)
    check(image.shape == (135, 240, 3), f"{path} decodes as 240x135 RGB")
    return image


def main():
    args = arguments(BLENDER)
    if args is None:
        return
    cache = make_cache(args.firn, args.work, "blender-test", 0.1, 10)
    check(os.path.isfile(os.path.join(cache, "terrain.obj")), "firn run wrote terrain.obj")

    snow = render(cache, os.path.join(args.work, "snow"))
    bare = render(cache, os.path.join(args.work, "bare"), "--no-snow")
    check(snow.std() > 0.02, f"the image is not uniform (std {snow.std():.3f})")
    changed = np.abs(snow - bare).max(axis=2) > 0.1
    share = changed.mean()
    check(share > 0.02, f"the snow changes {100 * share:.1f} % of the pixels (> 2 %)")
    rows, cols = np.nonzero(changed)
    inside = rows.min() > 2 and cols.min() > 2 and rows.max() < 132 and cols.max() < 237
    check(inside, f"the snow lies inside the frame, clear of its edges: rows "
          f"{rows.min()}..{rows.max()} of 135, columns {cols.min()}..{cols.max()} of 240")
    brighter = np.median((snow - bare).mean(axis=2)[changed])
    check(brighter > 0.1, f"the snow is brighter than the ground it covers (median "
          f"+{brighter:.2f})")

    missing = blender(os.path.join(args.work, "nothing-here"))
    check(missing.returncode != 0 and "no such folder" in missing.stderr,
          "a missing folder exits non-zero and says so")
    frames = blender(cache, "--frames", "7:9")
    check(frames.returncode != 0 and "no volume frames in 7..9" in frames.stderr,
          "frames that are not in the cache exit non-zero and say so")


if __name__ == "__main__":
    main()
