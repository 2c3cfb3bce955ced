"""OpenVDB's own renderer reads our volume cache: vdb_render (Debian's libopenvdb-tools) renders
the `density` grid of a volume.NNNN.vdb file.

    /usr/bin/python3 tests/render/test_vdb_render.py --firn BUILD/firn --work SCRATCH_DIR

Runs a small slab of snow on a 30 degree plane (one frame), points vdb_render's camera at the
centre of the snow's active voxels from above and the side, renders 160x120 to PPM and checks
that the snow is there: the pixels at the image centre (where the snow's centre projects) are
lit, a fair share of the image is snow, and the image border is background (black), so the
whole slab is in view. Under a second on 2 cores.
"""

import os
import re
import subprocess
import sys

import numpy as np
import pyopenvdb

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tiny_cache import arguments, check, make_cache  # noqa: E402

VDB_RENDER = "/usr/bin/vdb_render"
def read_ppm(path):
    """A binary (P6) PPM with 8-bit samples, as an H x W x 3 uint8 array."""
    with open(path, "rb") as f:
        data = f.read()
    # Header: magic, width, height, maxval, each after whitespace; one whitespace byte, then
    # the samples (which may themselves start with whitespace bytes).
    header = re.match(rb"P6\s+(\d+)\s+(\d+)\s+(\d+)\s", data)
    check(header is not None and int(header[3]) == 255, f"{path} is an 8-bit binary PPM")
    width, height = int(header[1]), int(header[2])
    pixels = np.frombuffer(data, np.uint8, 3 * width * height, header.end())
    return pixels.reshape(height, width, 3)


def vector_arg(v):
    return ",".join(f"{x:.6g}" for x in v)


def main():
    args = arguments(VDB_RENDER)
    if args is None:
        return
    cache = make_cache(args.firn, args.work, "vdb-render-test", 0.05, 20)
    volume = os.path.join(cache, "frames", "volume.0001.vdb")

    density = pyopenvdb.read(volume, "density")
    lo, hi = (np.array(density.transform.indexToWorld(ijk))
              for ijk in density.evalActiveVoxelBoundingBox())
    centre = 0.5 * (lo + hi)
    # From above, across the slope and a little down it, 3 slab sizes away: the slab fills about
    # a third of the default 44.8 degree field of view.
    eye = centre + 3.0 * np.linalg.norm(hi - lo) * np.array([0.3, 0.6, 1.0]) / np.linalg.norm(
        [0.3, 0.6, 1.0])
    image_path = os.path.join(args.work, "density.ppm")
    command = [VDB_RENDER, volume, image_path, "-name", "density", "-res", "160x120",
               "-translate", vector_arg(eye), "-lookat", vector_arg(centre), "-up", "0,1,0",
               # Densities are kg/m^3 (~300): small coefficients keep the snow from being a
               # black silhouette, so it shows shading.
               "-absorb", "0.05,0.05,0.05", "-scatter", "0.2,0.2,0.2", "-cpus", "2"]
    result = subprocess.run(command, capture_output=True, text=True)
    print(result.stdout + result.stderr, end="")
    check(result.returncode == 0, "vdb_render " + " ".join(command[1:]) + " exits 0")
    image = read_ppm(image_path)
    check(image.shape == (120, 160, 3), "the image is 160x120")

    snow = image.max(axis=2) > 20
    centre_patch = image[55:65, 75:85]
    check(centre_patch.min() > 40, f"the snow's centre, at the image centre, is lit (darkest "
          f"{centre_patch.min()} of 255)")
    check(0.05 < snow.mean() < 0.6, f"the snow covers {100 * snow.mean():.0f} % of the image")
    border = np.concatenate([snow[0], snow[-1], snow[:, 0], snow[:, -1]])
    check(not border.any(), "the image border is background: the whole slab is in view")


if __name__ == "__main__":
    main()
