#!/usr/bin/python3
"""The flow speed of a run from its volume caches: per frame, the largest and the 99th-percentile
speed of the grid velocity at nodes holding snow denser than --min-density (default 100 kg/m^3).

This is the speed the snow moves with (particles are advected by the grid velocity) and the
velocity field of Gaume et al. (2019), Fig. 6. metrics.csv's `max_speed` is the fastest particle's
own velocity, which with pure FLIP (`flip_blend = 1`) also carries the particle noise that FLIP
does not filter: on scenes/slope2d.toml 17.4 m/s against a flow speed of 8.1 m/s. `firn report`
draws it (report.py imports this module).

    /usr/bin/python3 render/flow_speed.py OUT_DIR [--min-density 100] [--every 1] [--csv FILE]
Needs the run's volume caches with "density" and "velocity" (output.volumes).
"""
import argparse
import pathlib
import sys

import numpy as np

MIN_DENSITY = 100.0  # kg/m^3: snow, not spray at the edge of a cell


def volume_files(out_dir, every=1, at_most=None):
    """The run's volume caches in frame order, every `every`-th, thinned to `at_most`."""
    files = sorted(pathlib.Path(out_dir, "frames").glob("volume.*.vdb"))[::every]
    if at_most and len(files) > at_most:
        keep = np.unique(np.linspace(0, len(files) - 1, at_most).round().astype(int))
        files = [files[k] for k in keep]
    return files


def frame_speeds(path, min_density=MIN_DENSITY):
    """(time, speeds): the grid speed at every node of one volume cache denser than
    min_density. Raises KeyError when the cache has no density or velocity grid."""
    import pyopenvdb as vdb  # Debian's python3-openvdb

    names = {g["name"] for g in vdb.readAllGridMetadata(str(path))}
    if not {"density", "velocity"} <= names:
        raise KeyError(f"{path} has no 'density' and 'velocity' grids (output.volumes)")
    velocity = vdb.read(str(path), "velocity")
    density = vdb.read(str(path), "density").getConstAccessor()
    speeds = [np.linalg.norm(item.value) for item in velocity.citerOnValues()
              if item.count == 1 and density.getValue(item.min) > min_density]
    time = float(velocity.metadata.get("time", float("nan")))
    return time, np.array(speeds)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out_dir")
    ap.add_argument("--min-density", type=float, default=MIN_DENSITY, help="kg/m^3")
    ap.add_argument("--every", type=int, default=1, help="every n-th frame")
    ap.add_argument("--csv", help="write the table here as well")
    a = ap.parse_args()
    files = volume_files(a.out_dir, a.every)
    if not files:
        sys.exit(f"flow_speed: no volume caches in {a.out_dir}/frames (output.volumes)")
    lines = ["time_s,max_flow_speed_m_s,p99_flow_speed_m_s"]
    peak = (0.0, 0.0)
    for f in files:
        try:
            time, speeds = frame_speeds(f, a.min_density)
        except KeyError as e:
            sys.exit(f"flow_speed: {e}")
        top = float(speeds.max()) if speeds.size else 0.0
        p99 = float(np.percentile(speeds, 99)) if speeds.size else 0.0
        lines.append(f"{time:.4g},{top:.4g},{p99:.4g}")
        peak = max(peak, (top, time))
    print("\n".join(lines))
    print(f"# largest flow speed {peak[0]:.3g} m/s at t = {peak[1]:.3g} s", file=sys.stderr)
    if a.csv:
        pathlib.Path(a.csv).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
