#!/usr/bin/python3
"""Charts and report.html for a run folder; `firn report OUT_DIR` calls it.

Reads OUT_DIR/metrics.csv, summary.json, scene.toml and the tables that `firn report` reduced
from the particle caches (OUT_DIR/report/data: weak_layer.csv, map_frames.csv, report.json).
Writes OUT_DIR/report/*.png and OUT_DIR/report/report.html, a single file with the images
embedded, so that it can be mailed or archived on its own.

Figures follow Gaume et al. (2019, Cold Reg. Sci. Technol. 168:102847): Fig. A1 (weak layer
seen from above), Fig. 3 bottom (crack speed along the slope, grey bars at slab fractures),
Fig. 7 (McClung & Gauer 2018).
"""
import argparse
import base64
import html
import json
import math
import pathlib
import sys
import tomllib

import numpy as np
import matplotlib

matplotlib.use("Agg")  # no display: files only
import matplotlib.pyplot as plt  # noqa: E402  (after the backend is chosen)
import matplotlib.ticker  # noqa: E402

import flow_speed  # noqa: E402  (render/flow_speed.py, beside this script)

DPI = 120
# One colour map per quantity, the same in every chart. Fig. A1 shows failed weak layer white
# on black elastic, p from black to yellow and slab speed from white to red.
CMAP_FAILED = "gray"
CMAP_P = "inferno"
CMAP_SPEED = "Reds"
CMAP_SLAB_P = "RdBu_r"  # diverging: the slab's p changes sign where it is pulled apart
# Cells without weak layer (the saw cut, outside the layer) are drawn in this colour, distinct
# from both ends of the grey failed/elastic scale.
NO_LAYER = "#c9d6e3"
# McClung & Gauer (2018) as quoted by Gaume et al. (2019): u_m ~ 1.5 L^(1/2), alpha 20-30 deg.
MG_COEFFICIENT = 1.5
SLAB_FRACTURE_COLOUR = "0.6"  # grey, as the bars of Fig. 3 bottom
ALPHA_BAND = (20.0, 30.0)
# The flow speed is read from at most this many volume caches, evenly spread (python per voxel).
FLOW_SPEED_FRAMES = 60


class ReportError(Exception):
    """A file the report needs is missing or malformed."""


def read_csv(path):
    """Columns of a CSV file with a header row as float arrays (empty cells: NaN)."""
    try:
        with open(path, encoding="utf-8") as f:
            header = f.readline().strip().split(",")
            rows = [line.rstrip("\n").split(",") for line in f if line.strip()]
    except OSError as e:
        raise ReportError(f"cannot read {path}: {e.strerror}") from e
    if header == [""]:
        raise ReportError(f"{path}: empty file, expected a header row")
    columns = {}
    for c, name in enumerate(header):
        try:
            columns[name] = np.array([float(r[c]) if r[c] != "" else np.nan for r in rows])
        except (ValueError, IndexError) as e:
            raise ReportError(f"{path}: column '{name}': {e}") from e
    return columns


def read_json(path):
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except OSError as e:
        raise ReportError(f"cannot read {path}: {e.strerror}") from e
    except json.JSONDecodeError as e:
        raise ReportError(f"{path}: line {e.lineno}: {e.msg}") from e


class Run:
    """Everything the charts draw from, read once."""

    def __init__(self, out_dir, data_dir=None):
        """data_dir: where `firn report` (or `firn compare`) wrote the tables; default
        OUT_DIR/report/data."""
        self.out_dir = pathlib.Path(out_dir)
        self.report_dir = self.out_dir / "report"
        data = pathlib.Path(data_dir) if data_dir else self.report_dir / "data"
        self.metrics = read_csv(self.out_dir / "metrics.csv")
        self.summary = read_json(self.out_dir / "summary.json")
        self.info = read_json(data / "report.json")
        self.weak = read_csv(data / "weak_layer.csv")
        maps = read_csv(data / "map_frames.csv")
        self.map_frames = maps["frame"].astype(int)
        self.map_times = maps["time"]
        try:
            with open(self.out_dir / "scene.toml", "rb") as f:
                self.scene = tomllib.load(f)
        except (OSError, tomllib.TOMLDecodeError) as e:
            raise ReportError(f"cannot read {self.out_dir / 'scene.toml'}: {e}") from e
        self.name = self.scene.get("simulation", {}).get("name", self.out_dir.name)
        self.dimension = int(self.info["dimension"])
        self.dx = float(self.info["dx"])

    def column(self, name):
        if name not in self.metrics:
            raise ReportError(f"{self.out_dir / 'metrics.csv'}: no column '{name}'")
        return self.metrics[name]

    def flow_speed(self):
        """(times, largest grid speed in the snow) from the volume caches (render/flow_speed.py),
        or None when the run wrote no density and velocity volumes."""
        if not hasattr(self, "_flow"):
            self._flow = None
            files = flow_speed.volume_files(self.out_dir, at_most=FLOW_SPEED_FRAMES)
            try:
                frames = [flow_speed.frame_speeds(f) for f in files]
            except KeyError:
                frames = []
            if frames:
                self._flow = (np.array([t for t, _ in frames]),
                              np.array([v.max() if v.size else 0.0 for _, v in frames]))
        return self._flow

    def arrival(self):
        """crack_arrival.csv as (x, z, time) arrays (3D runs with a crack), or None."""
        if not hasattr(self, "_arrival"):
            self._arrival = crack_arrival(self)
        return self._arrival

    def max_flow_speed(self):
        """u_m for the charts: the largest grid speed in the snow when the volumes hold it, else
        summary.json max_speed (the fastest particle); and which one it is."""
        flow = self.flow_speed()
        if flow is not None:
            return float(flow[1].max()), "grid flow speed"
        return self.summary.get("max_speed"), "fastest particle"

    @property
    def has_weak_layer(self):
        return self.info["weak_layer_materials"] != ""

    @property
    def has_map_data(self):
        return self.weak["frame"].size > 0

    @property
    def slab_fractures(self):
        """summary.json slab_fractures: one dict per fracture (none in older runs)."""
        return self.summary.get("slab_fractures") or []

    @property
    def has_slab(self):
        """A material with model "snow": the slab that fractures."""
        return any(m.get("model") == "snow" for m in self.scene.get("material", []))

    @property
    def has_slab_metrics(self):
        return "slab_blocks" in self.metrics

    @property
    def has_crack(self):
        return bool(np.isfinite(self.column("crack_tip_x")).any())

    def path_ends(self):
        """(x, y) of the release's highest point and of the deposit's farthest one, or None.
        Of the snow that moved, from summary.json (release_top_x/y, runout_x/y, since
        2026-12-03), so that a base or a slope that never moved is neither; for older runs, of
        every particle, from the report's first and last particle frames (report.json)."""
        if "runout_y" in self.summary:
            source, far = self.summary, ("runout_x", "runout_y")
        else:
            source, far = self.info, ("deposit_far_x", "deposit_far_y")
        ends = [source.get(k) for k in ("release_top_x", "release_top_y") + far]
        return None if any(v is None for v in ends) else ((ends[0], ends[1]), (ends[2], ends[3]))

    def fall_height(self):
        """H: the drop from the release's highest point to the deposit's farthest one, m."""
        ends = self.path_ends()
        if ends is None:
            return None
        (_, top), (_, far) = ends
        return None if top <= far else top - far

    def gauer_speed(self):
        """Gauer's estimate of the maximum flow speed, u_max = (g H / 2)^(1/2), m/s, with H the
        fall height above (as quoted by Gaume et al. 2019, sec. 3.2)."""
        height = self.fall_height()
        gravity = self.scene.get("simulation", {}).get("gravity", [0.0, -9.81])
        g = math.hypot(*gravity)
        return None if height is None else math.sqrt(g * height / 2.0)

    def deposit(self):
        """(x, depth at the first frame, depth at the last) from report/data/deposit.csv, or
        None (no particle caches, or tables written before 2026-12-03)."""
        path = self.report_dir / "data" / "deposit.csv"
        if not path.exists():
            return None
        d = read_csv(path)
        return (d["x"], d["depth_start"], d["depth_end"]) if d.get("x", np.empty(0)).size else None

    def path_length(self):
        """L: straight distance from the release's highest point to the deposit's farthest one."""
        ends = self.path_ends()
        if ends is None:
            return None
        (x0, y0), (x1, y1) = ends
        return math.hypot(x1 - x0, y1 - y0)


def ground_profile(run):
    """Slope angle (degrees) and curvature (1/m) of the scene's first `profile` terrain along x,
    or None (planes and heightfields have no single line). The points are the user's: angle per
    segment at its midpoint, curvature from the change of angle between neighbouring segments
    (positive where the slope eases down-slope: concave, where the paper's crack speeds up)."""
    pts = profile_points(run)
    if pts is None or len(pts) < 3:
        return None
    dx, dy = np.diff(pts[:, 0]), np.diff(pts[:, 1])
    angle = np.arctan2(-dy, dx)  # positive where the ground falls with x
    length = np.hypot(dx, dy)
    mid = pts[:-1, 0] + dx / 2
    curvature = -np.diff(angle) / ((length[:-1] + length[1:]) / 2)
    return mid, np.degrees(angle), pts[1:-1, 0], curvature


def profile_points(run):
    """The scene's first `profile` terrain's points as an (n, 2) array, or None."""
    for terrain in run.scene.get("terrain", []):
        if terrain.get("shape") == "profile":
            pts = np.asarray(terrain.get("points", []), dtype=float)
            return pts if pts.ndim == 2 and len(pts) >= 2 else None
    return None


def save(fig, path):
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def shared_range(values, low=1.0, high=99.0):
    """Colour range from percentiles, so that a few extreme particles do not wash a map out."""
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return 0.0, 1.0
    lo, hi = np.percentile(finite, [low, high])
    return (float(lo), float(hi)) if hi > lo else (float(lo), float(lo) + 1.0)


def cell_index(coord, dx):
    """Cell centres (i + 0.5) dx back to the integer i."""
    return np.rint(coord / dx - 0.5).astype(int)


# Failure maps ----------------------------------------------------------------------------------

# (column of weak_layer.csv, title, colour map, colour-bar label, short name for small panels),
# in Fig. A1's order: the weak layer failed and its p, the slab failed and its p, the slab's speed.
MAP_ROWS = (
    ("failed_fraction", "weak layer failed (white) / elastic (black)", CMAP_FAILED,
     "failed fraction", "failed / elastic"),
    ("p", "weak-layer pressure p", CMAP_P, "p (kPa)", "pressure p"),
    ("slab_failed_fraction", "slab above: failed (white) / elastic (black)", CMAP_FAILED,
     "failed fraction", "slab failed"),
    ("slab_p", "slab above: pressure p (blue: tension)", CMAP_SLAB_P, "p (kPa)", "slab p"),
    ("slab_speed", "slab speed above the weak layer", CMAP_SPEED, "speed (m/s)", "slab speed"),
)
FRACTION_KEYS = ("failed_fraction", "slab_failed_fraction")
PRESSURE_KEYS = ("p", "slab_p")


def map_value(run, key):
    values = run.weak[key]
    return values / 1000.0 if key in PRESSURE_KEYS else values  # Pa -> kPa reads better


def map_ranges(run, frames_mask):
    ranges = {}
    for key, *_ in MAP_ROWS:
        values = map_value(run, key)[frames_mask]
        if key in FRACTION_KEYS:
            ranges[key] = (0.0, 1.0)
        elif key == "slab_speed":
            ranges[key] = (0.0, max(shared_range(values)[1], 1e-3))
        elif key == "slab_p":
            # Centred on zero, so that the slab's tension and compression read apart.
            reach = max(np.abs(shared_range(values)).max(), 1e-3)
            ranges[key] = (-reach, reach)
        else:
            ranges[key] = shared_range(values)
    return ranges


def failure_maps_3d(run, path):
    """Fig. A1 style: top views (x along the slope, z across) at the map times."""
    w = run.weak
    ix, iz = cell_index(w["x"], run.dx), cell_index(w["z"], run.dx)
    x0, z0 = ix.min(), iz.min()
    shape = (iz.max() - z0 + 1, ix.max() - x0 + 1)
    extent = ((x0) * run.dx, (ix.max() + 1) * run.dx, z0 * run.dx, (iz.max() + 1) * run.dx)
    mask_all = np.isin(w["frame"].astype(int), run.map_frames)
    ranges = map_ranges(run, mask_all)
    n = len(run.map_frames)
    width = extent[1] - extent[0]
    height = extent[3] - extent[2]
    panel_w = 3.6
    panel_h = max(0.9, min(3.6, panel_w * height / max(width, 1e-9))) + 0.7
    rows = len(MAP_ROWS)
    fig, axes = plt.subplots(rows, n, figsize=(panel_w * n + 1.2, panel_h * rows), squeeze=False,
                             constrained_layout=True)
    for r, (key, _, cmap, unit, short) in enumerate(MAP_ROWS):
        values = map_value(run, key)
        image = None
        for c, frame in enumerate(run.map_frames):
            ax = axes[r][c]
            sel = w["frame"].astype(int) == frame
            grid = np.full(shape, np.nan)
            grid[iz[sel] - z0, ix[sel] - x0] = values[sel]
            cm = plt.get_cmap(cmap).copy()
            cm.set_bad(NO_LAYER)
            image = ax.imshow(grid, origin="lower", extent=extent, cmap=cm,
                              vmin=ranges[key][0], vmax=ranges[key][1], interpolation="nearest",
                              aspect="equal")
            ax.set_title(f"{short}, t = {run.map_times[c]:.3f} s", fontsize=10)
            ax.set_xlabel("x, down-slope (m)")
            if c == 0:
                ax.set_ylabel("z, across (m)")
        fig.colorbar(image, ax=list(axes[r]), label=unit, shrink=0.9)
    return save(fig, path)


def xt_grid(run, key):
    """A (frame, x cell) image of one quantity, 2D runs: every frame was binned."""
    w = run.weak
    frames = np.unique(w["frame"].astype(int))
    ix = cell_index(w["x"], run.dx)
    x0 = ix.min()
    grid = np.full((frames.size, ix.max() - x0 + 1), np.nan)
    row = np.searchsorted(frames, w["frame"].astype(int))
    grid[row, ix - x0] = map_value(run, key)
    times = np.array([w["time"][w["frame"].astype(int) == f][0] for f in frames])
    x_extent = (x0 * run.dx, (ix.max() + 1) * run.dx)
    return grid, times, x_extent


def failure_maps_2d(run, path):
    """x-time images: the weak layer along the slope (horizontal) as time goes on (upwards)."""
    fig, axes = plt.subplots(3, 2, figsize=(15, 13.0), constrained_layout=True)
    axes = axes.ravel()
    for ax in axes[len(MAP_ROWS):]:
        ax.axis("off")
    ranges = map_ranges(run, np.ones(run.weak["frame"].size, dtype=bool))
    tip_t, tip_x = run.column("time"), run.column("crack_tip_x")
    for ax, (key, title, cmap, unit, _) in zip(axes, MAP_ROWS):
        grid, times, (xa, xb) = xt_grid(run, key)
        dt = times[1] - times[0] if times.size > 1 else 1.0
        cm = plt.get_cmap(cmap).copy()
        cm.set_bad(NO_LAYER)
        image = ax.imshow(grid, origin="lower", aspect="auto", cmap=cm,
                          extent=(xa, xb, times[0] - dt / 2, times[-1] + dt / 2),
                          vmin=ranges[key][0], vmax=ranges[key][1], interpolation="nearest")
        ax.plot(tip_x, tip_t, color="#1f77b4", lw=1.2, label="crack tip (metrics.csv)")
        for t in run.map_times:
            ax.axhline(t, color="#2ca02c", lw=0.8, ls="--")
        ax.set_xlim(xa, xb)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("x, down-slope (m)")
        ax.set_ylabel("time (s)")
        fig.colorbar(image, ax=ax, label=unit)
    axes[0].legend(loc="upper left", fontsize=8)
    return save(fig, path)


def failure_profiles_2d(run, path):
    """The same quantities along x at the map times, as lines."""
    w = run.weak
    fig, axes = plt.subplots(len(MAP_ROWS), 1, figsize=(10, 2.5 * len(MAP_ROWS)), sharex=True,
                             constrained_layout=True)
    colours = plt.get_cmap("viridis")(np.linspace(0, 0.9, max(len(run.map_frames), 1)))
    for ax, (key, title, _, unit, _) in zip(axes, MAP_ROWS):
        values = map_value(run, key)
        for colour, frame, t in zip(colours, run.map_frames, run.map_times):
            sel = w["frame"].astype(int) == frame
            order = np.argsort(w["x"][sel])
            ax.plot(w["x"][sel][order], values[sel][order], color=colour, lw=1.3,
                    label=f"t = {t:.3f} s")
        ax.set_ylabel(unit)
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
        if key in FRACTION_KEYS:
            ax.set_ylim(-0.05, 1.05)
    axes[0].legend(fontsize=8, ncol=min(len(run.map_frames), 4))
    axes[-1].set_xlabel("x, down-slope (m)")
    return save(fig, path)


def strength_used_chart(run, path):
    """The weak layer's static load in the first frame (t = 0: settled, before any trigger) as
    the share of its strength the stress uses (weak_layer.csv strength_used): along x in 2D, a
    top view in 3D. Where it reaches 1 the layer fails under its own load."""
    w = run.weak
    first = w["frame"].astype(int) == int(w["frame"].min())
    time = float(w["time"][first][0])
    used = w["strength_used"][first]
    finite = used[np.isfinite(used)]
    top = max(1.05, float(np.percentile(finite, 99)) if finite.size else 1.05)
    title = (f"weak layer at t = {time:.3g} s: share of its initial strength the static load uses "
             "(green: failed under it)")
    if run.dimension == 3:
        ix, iz = cell_index(w["x"][first], run.dx), cell_index(w["z"][first], run.dx)
        grid = np.full((iz.max() - iz.min() + 1, ix.max() - ix.min() + 1), np.nan)
        grid[iz - iz.min(), ix - ix.min()] = used
        extent = (ix.min() * run.dx, (ix.max() + 1) * run.dx, iz.min() * run.dx,
                  (iz.max() + 1) * run.dx)
        width, height = extent[1] - extent[0], extent[3] - extent[2]
        fig, a = plt.subplots(figsize=(10, max(2.2, min(8.0, 9.0 * height / width)) + 1.0),
                              constrained_layout=True)
        cm = plt.get_cmap("magma").copy()
        cm.set_bad(NO_LAYER)
        image = a.imshow(grid, origin="lower", extent=extent, cmap=cm, vmin=0.0, vmax=top,
                         interpolation="nearest", aspect="equal")
        failed = np.zeros(grid.shape)
        failed[iz - iz.min(), ix - ix.min()] = w["failed_fraction"][first]
        if failed.max() >= 0.5:
            a.contour(failed, levels=[0.5], extent=extent, colors="#2ca02c", linewidths=1.2)
        fig.colorbar(image, ax=a, label="strength used", shrink=0.9)
        a.set_xlabel("x, down-slope (m)")
        a.set_ylabel("z, across (m)")
    else:
        fig, a = plt.subplots(figsize=(12, 3.6), constrained_layout=True)
        order = np.argsort(w["x"][first])
        a.plot(w["x"][first][order], used[order], color="#7b3294", lw=1.3, label="strength used")
        failed = w["failed_fraction"][first][order] >= 0.5
        if failed.any():
            a.fill_between(w["x"][first][order], 0, 1, where=failed, color="#2ca02c", alpha=0.2,
                           step="mid", transform=a.get_xaxis_transform(),
                           label="failed under it (half its particles or more)")
        a.axhline(1.0, color="#d62728", lw=0.9, ls="--", label="its strength")
        a.set_ylim(0.0, top)
        a.set_xlabel("x, down-slope (m)")
        a.set_ylabel("strength used")
        a.legend(fontsize=8, loc="upper right")
        a.grid(alpha=0.3)
    a.set_title(title, fontsize=10)
    return save(fig, path)


# Crack, flow, McClung & Gauer -----------------------------------------------------------------

def along_ground(run, x0, x1):
    """Length (m) of the scene's first `profile` terrain between x0 and x1, or None without one."""
    pts = profile_points(run)
    if pts is None:
        return None
    lo, hi = min(x0, x1), max(x0, x1)
    # Past its ends the profile goes on along its end segments: their slopes hold out there.
    xs = np.concatenate(([min(lo, pts[0, 0])], pts[:, 0], [max(hi, pts[-1, 0])]))
    slopes = np.diff(pts[:, 1]) / np.diff(pts[:, 0])
    slopes = np.concatenate(([slopes[0]], slopes, [slopes[-1]]))
    length = 0.0
    for xa, xb, slope in zip(xs[:-1], xs[1:], slopes):
        a, b = max(lo, xa), min(hi, xb)
        if b > a:
            length += (b - a) * math.hypot(1.0, slope)
    return length


def behind_along_slope(run, fracture, key="distance_behind_crack_tip"):
    """A slab fracture's distance behind the crack tip along the ground (the paper's measure),
    from summary.json's distance along x (`key`: as it went through, or
    distance_behind_crack_tip_at_start, as it began): the tip is the crack's end on the
    fracture's side of where the crack started (its first step-timed position). None without a
    distance, a profile terrain or the crack's start."""
    d = fracture.get(key)
    steps = run.summary.get("crack_tip_steps") or []
    if d is None or not steps:
        return None
    side = -1.0 if fracture["x"] < steps[0]["x"] else 1.0
    length = along_ground(run, fracture["x"], fracture["x"] + side * d)
    return None if length is None else math.copysign(length, d)


def tip_steps(run):
    """The leading crack tip timed to the step (summary.json crack_tip_steps): times, x; or None
    for runs written before it existed."""
    steps = run.summary.get("crack_tip_steps") or []
    if len(steps) < 2:
        return None
    return (np.array([s["time"] for s in steps], dtype=float),
            np.array([s["x"] for s in steps], dtype=float))


def windowed_speed(times, xs, window):
    """Speed of a monotone tip over each `window` metres of its advance, at the window's middle:
    (middle x, m/s). A jump (a crack that started on its own ahead joining) shows as a fast
    window, not as an infinite speed."""
    travel = np.abs(xs - xs[0])
    mids, speeds = [], []
    for k in range(len(xs)):
        j = np.searchsorted(travel, travel[k] + window)
        if j >= len(xs):
            break
        dt = times[j] - times[k]
        if dt > 0:
            mids.append(0.5 * (xs[k] + xs[j]))
            speeds.append((travel[j] - travel[k]) / dt)
    return np.array(mids), np.array(speeds)


def crack_arrival(run):
    """(x, z, time) arrays of crack_arrival.csv (3D runs), or None when absent or empty."""
    path = run.out_dir / "crack_arrival.csv"
    if not path.exists():
        return None
    a = read_csv(path)
    return (a["x"], a["z"], a["time"]) if a.get("x", np.empty(0)).size else None


def behind_front(arrival, fracture, dx):
    """A slab fracture's distance behind the weak-layer crack's front in 3D, m, in plan (x, z):
    from where it went through to the nearest bed cell the crack had not reached by then (> 0,
    behind the front), or, when the crack had not reached the fracture's own place, minus the
    distance to the nearest cell it had (< 0, ahead of it). The front is the arrival isochrone
    at the fracture's time, in any direction, where the 2D measure (`behind_along_slope`) reads
    along x only. None without crack_arrival.csv, or when the crack had already reached every
    cell it ever reached (no front left to be behind)."""
    if arrival is None:
        return None
    x, z, t = arrival
    distance = np.hypot(x - fracture["x"], z - fracture["z"])
    reached = t <= fracture["time"]
    ahead = ~reached
    if not ahead.any() or not reached.any():
        return None
    # The fracture's own bed cell (fractures and arrival are binned on the same dx lattice): an
    # absent cell (no layer there, or never cracked) has not been reached.
    own = (np.abs(x - fracture["x"]) <= 0.51 * dx) & (np.abs(z - fracture["z"]) <= 0.51 * dx)
    if (own & reached).any():
        return float(distance[ahead].min())
    return -float(distance[reached].min())


def behind_distance(run, fracture, began=False):
    """The distance behind the crack a fracture's label shows: behind the front in plan in 3D
    (`behind_front`), else along the ground profile, else along x (summary.json); as it went
    through, or with `began` as it began (start_time; None for runs written before it existed)."""
    key = "distance_behind_crack_tip_at_start" if began else "distance_behind_crack_tip"
    if began and fracture.get("start_time") is None:
        return None
    if run.dimension == 3 and run.arrival() is not None:
        at = {**fracture, "time": fracture["start_time"]} if began else fracture
        return behind_front(run.arrival(), at, run.dx)
    d = behind_along_slope(run, fracture, key)
    return fracture.get(key) if d is None else d


def front_speed(distance, time, near=0.5, span=1.0):
    """The crack front's speed along one direction, m/s: the least-squares slope of distance
    against arrival time over the cells more than `near` m from the origin (inside, the trigger
    loads the layer at once). None where that is no measure of a front: the cells span less than
    `span` m (a narrow slope: its free sides crack on their own), or no time, or the fit does
    not move outwards."""
    far = distance > near
    if far.sum() < 3 or np.ptp(distance[far]) < span or np.ptp(time[far]) <= 0:
        return None
    speed = float(np.polyfit(time[far], distance[far], 1)[0])
    return speed if speed > 0 else None


def crack_origin(x, z, t, dx):
    """Index of the cell where the crack started: the earliest by the median of its 3 x 3
    neighbourhood (cracked cells only), its own time breaking ties. A lone cell that yields on its
    own long before its neighbours (a particle beyond its strength at a free corner at t = 0) has
    its neighbours' late median; where the crack started, most cells around crack together."""
    ix = np.rint((x - x.min()) / dx).astype(int)
    iz = np.rint((z - z.min()) / dx).astype(int)
    grid = np.full((iz.max() + 3, ix.max() + 3), np.nan)  # a ring of empty cells around
    grid[iz + 1, ix + 1] = t
    around = np.stack([grid[1 + a:grid.shape[0] - 1 + a, 1 + b:grid.shape[1] - 1 + b]
                       for a in (-1, 0, 1) for b in (-1, 0, 1)])
    median = np.nanmedian(around, axis=0)[iz, ix]
    return int(np.lexsort((t, median))[0])


def arrival_speeds(x, z, t, dx):
    """The crack's origin (`crack_origin`) and its front speeds from there: up-slope and
    down-slope along the origin's row (cells within half a cell of its z), across the slope
    (anti-plane) along its column (within half a cell of its x), both ways pooled."""
    k = crack_origin(x, z, t, dx)
    x0, z0, t0 = x[k], z[k], t[k]
    row = np.abs(z - z0) < 0.5 * dx
    col = np.abs(x - x0) < 0.5 * dx
    up = row & (x < x0)
    down = row & (x > x0)
    return {"origin": (x0, z0, t0),
            "up": front_speed(x0 - x[up], t[up]),
            "down": front_speed(x[down] - x0, t[down]),
            "across": front_speed(np.abs(z[col] - z0), t[col]),
            "rows": (up, down, col)}


def crack_arrival_chart(run, path, arrival):
    """Plan map of the crack's arrival time over the bed (x down-slope, z across) with
    isochrones, and arrival time against distance from the origin along and across the slope."""
    x, z, t = arrival
    dx = run.dx
    speeds = arrival_speeds(x, z, t, dx)
    x0, z0, t0 = speeds["origin"]
    ix = np.rint((x - x.min()) / dx).astype(int)
    iz = np.rint((z - z.min()) / dx).astype(int)
    grid = np.full((iz.max() + 1, ix.max() + 1), np.nan)
    grid[iz, ix] = t
    fig, (a, b) = plt.subplots(1, 2, figsize=(14, 4.6), constrained_layout=True,
                               gridspec_kw={"width_ratios": [1.6, 1]})
    extent = (x.min() - dx / 2, x.max() + dx / 2, z.min() - dx / 2, z.max() + dx / 2)
    cm = plt.get_cmap("viridis").copy()
    cm.set_bad(NO_LAYER)
    image = a.imshow(grid, origin="lower", extent=extent, cmap=cm, interpolation="nearest",
                     aspect="equal")
    levels = np.linspace(t.min(), t.max(), 9)[1:-1]
    if np.ptp(t) > 0:
        gx = x.min() + dx * np.arange(grid.shape[1])
        gz = z.min() + dx * np.arange(grid.shape[0])
        a.contour(gx, gz, np.ma.masked_invalid(grid), levels=levels, colors="w", linewidths=0.7)
    a.plot(x0, z0, "r*", ms=12, label=f"first crack, t = {t0:.3f} s")
    a.set_xlabel("x, down-slope (m)")
    a.set_ylabel("z, across the slope (m)")
    a.set_title("crack arrival time (crack_arrival.csv), isochrones in white", fontsize=10)
    a.legend(fontsize=8, loc="upper right")
    fig.colorbar(image, ax=a, label="arrival time (s)")
    up, down, col = speeds["rows"]

    def label(name, v):
        return f"{name}: {v:.0f} m/s" if v is not None else f"{name}: no front to measure"

    b.plot(t[up], x0 - x[up], ".", color="#1f77b4", label=label("up-slope", speeds["up"]))
    b.plot(t[down], x[down] - x0, ".", color="#ff7f0e", label=label("down-slope", speeds["down"]))
    b.plot(t[col], np.abs(z[col] - z0), ".", color="#2ca02c",
           label=label("across (anti-plane)", speeds["across"]))
    b.axhline(0.5, color="0.6", lw=0.8, ls="--")
    b.set_xlabel("arrival time (s)")
    b.set_ylabel("distance from the first crack (m)")
    b.set_title("front speeds: least-squares slopes beyond 0.5 m", fontsize=10)
    b.legend(fontsize=8, loc="upper left")
    b.grid(alpha=0.3)
    return save(fig, path), speeds


def crack_chart(run, path):
    """Fig. 3 bottom: crack tip against time, crack speed against position along the slope."""
    t, tip, speed = run.column("time"), run.column("crack_tip_x"), run.column("crack_speed")
    profile = ground_profile(run)
    if profile is None:
        fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.2), constrained_layout=True)
    else:
        fig = plt.figure(figsize=(12, 6.0), constrained_layout=True)
        grid = fig.add_gridspec(3, 2)
        a = fig.add_subplot(grid[:, 0])
        b = fig.add_subplot(grid[:2, 1])
        g = fig.add_subplot(grid[2, 1], sharex=b)
    a.plot(t, tip, "o-", ms=3, color="#1f77b4", label="leading tip (frames)")
    steps = tip_steps(run)
    if steps is not None:
        a.step(steps[0], steps[1], where="post", color="#ff7f0e", lw=1.0,
               label="leading tip, timed to the step")
    for name, style in (("crack_tip_min_x", ":"), ("crack_tip_max_x", "--")):
        if name in run.metrics:
            a.plot(t, run.metrics[name], style, color="0.4", lw=1,
                   label=name.replace("crack_tip_", "extent ").replace("_x", ""))
    # Where the layer's cohesion is gone (p0 = 0): behind the eta > 0 extent by the process zone.
    for name, style in (("collapse_min_x", ":"), ("collapse_max_x", "--")):
        if name in run.metrics and np.isfinite(run.metrics[name]).any():
            a.plot(t, run.metrics[name], style, color="#9467bd", lw=1.2,
                   label=name.replace("collapse_", "collapsed ").replace("_x", ""))
    a.set_xlabel("time (s)")
    a.set_ylabel("crack tip x (m)")
    a.set_title("crack tip position")
    a.legend(fontsize=8)
    a.grid(alpha=0.3)
    moving = np.isfinite(speed) & np.isfinite(tip)
    # Points, not a line: a crack that runs both ways would be joined across the slope.
    b.plot(tip[moving], speed[moving], "o", ms=3.5, color="#d62728", label="between frames")
    if steps is not None:
        mids, speeds = windowed_speed(steps[0], steps[1], 0.5)
        if mids.size:
            b.plot(mids, speeds, ".", ms=3, color="#ff7f0e",
                   label="over 0.5 m of advance (timed to the step)")
        if mids.size >= 5:
            # A zone that fails at once (a trigger's static overload at t = 0, a layer loaded to
            # its strength) registers in a step or two: speeds of hundreds of m/s that are not
            # propagation and would flatten the chart. The axis stops at 3 x the median window;
            # what lies beyond is drawn on its edge.
            cap = 3.0 * float(np.median(speeds))
            beyond = speeds > cap
            if beyond.any():
                b.plot(mids[beyond], np.full(int(beyond.sum()), cap), "^", ms=5, color="#ff7f0e",
                       label=f"beyond {cap:.0f} m/s ({int(beyond.sum())}: a zone failing at once)")
                b.set_ylim(0.0, 1.05 * cap)
    for k, f in enumerate(run.slab_fractures):
        b.axvspan(f["x"] - run.dx / 2, f["x"] + run.dx / 2, color=SLAB_FRACTURE_COLOUR,
                  alpha=0.6, lw=0, label="slab fracture" if k == 0 else None)
    mean = run.summary.get("mean_crack_speed")
    if mean:
        b.axhline(mean, color="k", ls="--", lw=1, label=f"steady mean {mean:.1f} m/s")
    b.set_xlabel("crack tip x (m)")
    b.set_ylabel("crack speed (m/s)")
    b.set_title("crack speed along the slope")
    b.legend(fontsize=8)
    b.grid(alpha=0.3)
    if profile is not None:
        # Fig. 3 bottom reads the speed against the slope angle and the curvature beneath it.
        mid, angle, knots, curvature = profile
        g.plot(mid, angle, color="0.3", lw=1.3, label="slope angle")
        g.set_ylabel("slope (deg)")
        g.set_xlabel("x (m)")
        g.grid(alpha=0.3)
        c = g.twinx()
        c.plot(knots, curvature, color="#2ca02c", lw=1.0, label="curvature")
        c.axhline(0.0, color="#2ca02c", lw=0.6, ls=":")
        c.set_ylabel("curvature (1/m), > 0 concave", color="#2ca02c")
        moving_x = tip[moving]
        if moving_x.size:
            pad = max(1.0, 0.05 * (moving_x.max() - moving_x.min()))
            b.set_xlim(moving_x.min() - pad, moving_x.max() + pad)
        g.legend(loc="upper right", fontsize=8)
    return save(fig, path)


def slab_fracture_chart(run, path):
    """Where and when the slab fractured against the crack tip, the depth each started from, and
    the blocks the slab broke into."""
    fractures = run.slab_fractures
    fig, (a, b, c) = plt.subplots(1, 3, figsize=(16, 4.4), constrained_layout=True)
    t, tip = run.column("time"), run.column("crack_tip_x")
    steps = tip_steps(run)
    if steps is not None:
        a.step(steps[0], steps[1], where="post", color="#1f77b4", lw=1.2,
               label="weak-layer crack tip (timed to the step)")
    elif np.isfinite(tip).any():
        a.plot(t, tip, "-", color="#1f77b4", lw=1.2, label="weak-layer crack tip")
    if fractures:
        ft = [f["time"] for f in fractures]
        fx = [f["x"] for f in fractures]
        a.plot(ft, fx, "s", ms=6, color="0.35", label="slab fracture (x, time)", clip_on=False)
        for f in fractures:
            d = behind_distance(run, f)
            if d is not None:
                a.annotate(f"{d:.2f} m", (f["time"], f["x"]), textcoords="offset points",
                           xytext=(4, -10), fontsize=7, color="0.3")
    started = [f for f in fractures if f.get("start_time") is not None]
    if started:
        a.plot([f["start_time"] for f in started], [f["x"] for f in started], "s", ms=6,
               mfc="none", color="0.35", label="where it started (first fractured particle)",
               clip_on=False)
        for f in started:
            a.plot([f["start_time"], f["time"]], [f["x"], f["x"]], "-", color="0.6", lw=0.8)
    a.set_xlim(t[0], t[-1])
    low, high = a.get_ylim()
    if high - low < 1.0:  # a lone fracture: show a metre around it
        middle = 0.5 * (low + high)
        a.set_ylim(middle - 0.5, middle + 0.5)
    a.set_xlabel("time (s)")
    a.set_ylabel("x (m)")
    a.set_title("slab fractures and the crack tip")
    a.legend(fontsize=8, loc="best")
    a.grid(alpha=0.3)

    if fractures:
        b.plot([f["x"] for f in fractures], [f["start_depth_fraction"] for f in fractures], "s",
               ms=6, color="0.35")
    b.set_ylim(-0.05, 1.05)
    b.set_yticks([0.0, 0.25, 0.5, 0.75, 1.0])
    b.set_yticklabels(["0 (weak-layer interface)", "0.25", "0.5", "0.75", "1 (top surface)"])
    b.set_xlabel("x (m)")
    b.set_ylabel("start depth, fraction of the slab thickness")
    b.set_title("where each slab fracture started")
    b.grid(alpha=0.3)

    if run.has_slab_metrics:
        c.plot(t, run.column("slab_blocks"), "o-", ms=3, color="#9467bd", label="blocks")
        c.set_ylabel("slab blocks")
        c.yaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
        mass = c.twinx()
        unit = "kg/m" if run.dimension == 2 else "kg"
        mass.plot(t, run.column("largest_block_mass"), "--", color="#8c564b",
                  label=f"largest block ({unit})")
        mass.plot(t, run.column("median_block_mass"), ":", color="#8c564b",
                  label=f"median block ({unit})")
        mass.set_ylabel(f"block mass ({unit})")
        mass.legend(fontsize=8, loc="center right")
    c.set_xlabel("time (s)")
    c.set_title("slab blocks (intact slab, face-connected cells)")
    c.legend(fontsize=8, loc="upper left")
    c.grid(alpha=0.3)
    return save(fig, path)


def deposit_chart(run, path, deposit):
    """The snow's depth along x at the first and the last frame: where the release left and
    where the deposit lies."""
    x, start, end = deposit
    fig, a = plt.subplots(figsize=(12, 3.8), constrained_layout=True)
    s0, s1 = np.nan_to_num(start), np.nan_to_num(end)
    a.fill_between(x, s0, s1, where=s1 < s0, color="#1f77b4", alpha=0.25, step="mid",
                   label="left (release, erosion)")
    a.fill_between(x, s0, s1, where=s1 > s0, color="#d62728", alpha=0.25, step="mid",
                   label="arrived (deposit)")
    t0, t1 = run.info.get("deposit_start_time"), run.info.get("deposit_end_time")
    a.step(x, s0, where="mid", color="#1f77b4", lw=1.2,
           label="first frame" if t0 is None else f"first frame, t = {t0:.3g} s")
    a.step(x, s1, where="mid", color="#d62728", lw=1.2,
           label="last frame" if t1 is None else f"last frame, t = {t1:.3g} s")
    runout = run.summary.get("runout_x")
    if isinstance(runout, (int, float)):
        a.axvline(runout, color="0.4", ls="--", lw=0.9, label=f"runout_x {runout:.1f} m")
    a.set_xlabel("x, down-slope (m)")
    a.set_ylabel("vertical snow depth (m)")
    a.set_title("snow depth along the path (report/data/deposit.csv)", fontsize=10)
    a.legend(fontsize=8, loc="upper right")
    a.grid(alpha=0.3)
    return save(fig, path)


def slab_fracture_table(run):
    plan = run.dimension == 3 and run.arrival() is not None
    rows = "\n".join(
        f"<tr><td class=num>{k + 1}</td><td class=num>{format_value(f['x'])}</td>"
        f"<td class=num>{format_value(f['z'])}</td><td class=num>{format_value(f['time'])}</td>"
        f"<td class=num>{format_value(f['start_depth_fraction'])}</td>"
        f"<td class=num>{format_value(f.get('distance_behind_crack_tip'))}</td>"
        f"<td class=num>{format_value(behind_along_slope(run, f))}</td>"
        + (f"<td class=num>{format_value(behind_front(run.arrival(), f, run.dx))}</td>" if plan else "")
        + f"<td class=num>{format_value(f.get('start_time'))}</td>"
        f"<td class=num>{format_value(behind_distance(run, f, began=True))}</td>"
        + "</tr>"
        for k, f in enumerate(run.slab_fractures))
    return ("<table>\n<tr><th>#</th><th>x (m)</th><th>z (m)</th><th>time (s)</th>"
            "<th>start depth fraction</th><th>distance behind crack tip, along x (m)</th>"
            "<th>along the slope (m)</th>"
            + ("<th>behind the crack's front, in plan (m)</th>" if plan else "")
            + "<th>started (s)</th><th>behind the crack as it started ("
            + ("in plan" if plan else "along the slope; along x off a profile") + ") (m)</th>"
            "</tr>\n"
            f"{rows}\n</table>")


def flow_chart(run, path):
    t = run.column("time")
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.2), constrained_layout=True)
    flow = run.flow_speed()
    if flow is not None:
        a.plot(flow[0], flow[1], color="#d62728", label="grid flow speed (volume caches)")
    a.plot(t, run.column("max_speed"), color="#d62728" if flow is None else "0.6",
           lw=1.5 if flow is None else 1.0, label="fastest particle (metrics.csv max_speed)")
    gauer = run.gauer_speed()
    if gauer is not None:
        a.axhline(gauer, color="k", ls="--", lw=1.0,
                  label=f"Gauer: $(gH/2)^{{1/2}}$ = {gauer:.1f} m/s (H = {run.fall_height():.1f} m)")
    if "slab_speed" in run.metrics and np.isfinite(run.column("slab_speed")).any():
        a.plot(t, run.column("slab_speed"), color="#2ca02c",
               label="slab's centre of mass (metrics.csv slab_speed)")
    if gauer is not None:  # room for the legend above the line
        a.set_ylim(0.0, max(a.get_ylim()[1], 1.3 * gauer))
    a.set_xlabel("time (s)")
    a.set_ylabel("speed (m/s)")
    a.set_title("maximum flow speed")
    a.legend(fontsize=8, loc="upper right")
    a.grid(alpha=0.3)
    b.plot(t, run.column("kinetic_energy") / 1000.0, color="#1f77b4")
    b.set_xlabel("time (s)")
    b.set_ylabel("kinetic energy (kJ/m)" if run.dimension == 2 else "kinetic energy (kJ)")
    b.set_title("kinetic energy")
    b.grid(alpha=0.3)
    return save(fig, path)


def mcclung_gauer_chart(run, path):
    """Fig. 7: u_m against sqrt(L) with the fit u_m = 1.5 sqrt(L); u_m against alpha."""
    u_m, _ = run.max_flow_speed()
    alpha = run.summary.get("alpha_angle_deg")
    length = run.path_length()
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.4), constrained_layout=True)
    root = math.sqrt(length) if length else 0.0
    s = np.linspace(0.0, max(10.0, 1.3 * root), 100)
    a.plot(s, MG_COEFFICIENT * s, "k--", label="McClung & Gauer (2018): $u_m = 1.5\\,L^{1/2}$")
    if length and u_m is not None:
        a.plot(root, u_m, "o", ms=9, color="#d62728", label=f"this run (L = {length:.1f} m)")
    a.set_xlabel("$L^{1/2}$ (m$^{1/2}$)")
    a.set_ylabel("maximum flow speed $u_m$ (m/s)")
    a.set_title("maximum speed against path length")
    a.set_xlim(0, s[-1])
    a.set_ylim(0, max(MG_COEFFICIENT * s[-1], 1.2 * (u_m or 0)))
    a.legend(fontsize=8, loc="upper left")
    a.grid(alpha=0.3)
    b.axvspan(*ALPHA_BAND, color="#2ca02c", alpha=0.2, label="α 20–30° (Gaume et al. 2019)")
    if alpha is not None and u_m is not None:
        b.plot(alpha, u_m, "o", ms=9, color="#d62728", label=f"this run (α = {alpha:.1f}°)")
    b.set_xlim(0, 60 if alpha is None else max(60, alpha + 5))
    b.set_ylim(0, max(10.0, 1.2 * (u_m or 0)))
    b.set_xlabel("α-angle (°)")
    b.set_ylabel("maximum flow speed $u_m$ (m/s)")
    b.set_title("maximum speed against α-angle")
    b.legend(fontsize=8, loc="upper right")
    b.grid(alpha=0.3)
    return save(fig, path)


# HTML -------------------------------------------------------------------------------------------

UNITS = {
    "end_time": "s", "wall_seconds": "s", "particle_steps_per_second": "1/s",
    "peak_rss_bytes": "B", "bytes_per_particle": "B", "mass_initial": "kg",
    "mass_final": "kg", "max_speed": "m/s", "max_crack_speed": "m/s",
    "mean_crack_speed": "m/s", "crack_propagation_distance": "m", "runout_x": "m",
    "alpha_angle_deg": "°", "first_slab_fracture_time": "s",
    "final_largest_block_mass": "kg",
}


def format_value(value):
    if isinstance(value, float):
        return f"{value:.6g}"
    return "—" if value is None else str(value)


def summary_table(run):
    rows = []
    for key, value in run.summary.items():
        if isinstance(value, list):  # slab_fractures: a table of its own
            value = f"{len(value)} entries (see below)"
        unit = UNITS.get(key, "")
        if (key.startswith("mass_") or key.endswith("_block_mass")) and run.dimension == 2:
            unit = "kg/m"
        rows.append((key, format_value(value), unit))
    u_m, source = run.max_flow_speed()
    if u_m is not None:
        rows.append((f"u_m, {source} (report)", f"{u_m:.6g}", "m/s"))
    length = run.path_length()
    gauer = run.gauer_speed()
    if gauer is not None:
        rows.append(("fall height H (report)", f"{run.fall_height():.6g}", "m"))
        rows.append(("(g H / 2)^1/2 (Gauer)", f"{gauer:.6g}", "m/s"))
    if length is not None:
        rows.append(("path length L (report)", f"{length:.6g}", "m"))
        rows.append(("1.5 L^1/2 (McClung & Gauer)", f"{MG_COEFFICIENT * math.sqrt(length):.6g}",
                     "m/s"))
    body = "\n".join(f"<tr><td>{html.escape(k)}</td><td class=num>{html.escape(v)}</td>"
                     f"<td>{html.escape(u)}</td></tr>" for k, v, u in rows)
    return f"<table>\n<tr><th>quantity</th><th>value</th><th>unit</th></tr>\n{body}\n</table>"


def figure(path, caption):
    data = base64.b64encode(pathlib.Path(path).read_bytes()).decode("ascii")
    return (f'<figure><img alt="{html.escape(pathlib.Path(path).name)}" '
            f'src="data:image/png;base64,{data}">\n'
            f"<figcaption>{caption}</figcaption></figure>")


STYLE = """
body { font-family: sans-serif; max-width: 1400px; margin: 1em auto; padding: 0 1em; color: #222; }
table { border-collapse: collapse; font-size: 0.9em; }
td, th { border: 1px solid #ccc; padding: 2px 8px; text-align: left; }
td.num { text-align: right; font-family: monospace; }
figure { margin: 1em 0 2em 0; }
img { max-width: 100%; border: 1px solid #eee; }
figcaption { font-size: 0.9em; color: #444; max-width: 60em; }
"""


def read_ascii_grid(path):
    """An ESRI ASCII grid: (values with rows from the north, west, south, cell size)."""
    header = {}
    try:
        with open(path, encoding="utf-8") as f:
            while True:
                pos = f.tell()
                words = f.readline().split()
                if len(words) != 2 or not words[0][0].isalpha():
                    f.seek(pos)
                    break
                header[words[0].lower()] = float(words[1])
            values = np.loadtxt(f, ndmin=2)
    except (OSError, ValueError) as e:
        raise ReportError(f"cannot read {path}: {e}") from e
    cell = header.get("cellsize", header.get("dx"))
    if cell is None or "ncols" not in header:
        raise ReportError(f"{path}: not an ESRI ASCII grid (no ncols/cellsize)")
    west = header.get("xllcorner", header.get("xllcenter", 0.0) - 0.5 * cell)
    south = header.get("yllcorner", header.get("yllcenter", 0.0) - 0.5 * cell)
    if "nodata_value" in header:
        values = np.where(values == header["nodata_value"], np.nan, values)
    return values, west, south, cell


def hillshade(elevation, cell, azimuth=315.0, altitude=45.0):
    """Lambertian hillshade of a north-up grid (rows from the north), 0..1, light from the NW."""
    dz_dy, dz_dx = np.gradient(elevation, cell)
    dz_dy = -dz_dy  # rows run south: northing decreases down the array
    slope = np.arctan(np.hypot(dz_dx, dz_dy))
    aspect = np.arctan2(-dz_dx, dz_dy)
    az, alt = math.radians(azimuth), math.radians(altitude)
    shade = (math.sin(alt) * np.cos(slope) +
             math.cos(alt) * np.sin(slope) * np.cos(az - aspect))
    return np.clip(shade, 0.0, 1.0)


HAZARD_MAPS = (("pft", "peak flow thickness", "m", "viridis"),
               ("pfv", "peak flow speed", "m/s", "plasma"),
               ("ppr", "peak pressure", "kPa", "inferno"))


def hazard_maps(run, path):
    """pft, pfv, ppr over a hillshade of the DEM, with the release's outline."""
    rasters = run.out_dir / "rasters"
    dem, west, south, cell = read_ascii_grid(rasters / "dem.asc")
    release = read_ascii_grid(rasters / "release.asc")[0]
    rows, cols = dem.shape
    extent = (west, west + cols * cell, south, south + rows * cell)
    shade = hillshade(dem, cell)
    fig, axes = plt.subplots(len(HAZARD_MAPS), 1, figsize=(9, 3.0 * len(HAZARD_MAPS)),
                             constrained_layout=True)
    for ax, (name, label, unit, cmap) in zip(axes, HAZARD_MAPS):
        values = read_ascii_grid(rasters / f"{name}.asc")[0]
        ax.imshow(shade, cmap="gray", extent=extent, vmin=0.0, vmax=1.0)
        shown = np.ma.masked_where(~(values > 0.0), values)
        image = ax.imshow(shown, cmap=cmap, extent=extent, alpha=0.85, interpolation="nearest")
        if (release > 0).any():
            ax.contour(np.flipud(release > 0).astype(float), levels=[0.5], colors="white",
                       linewidths=1.2, extent=extent, origin="lower")
        ax.set_title(f"{name}: {label}, max {np.nanmax(values):.3g} {unit}")
        ax.set_xlabel("easting (m)")
        ax.set_ylabel("northing (m)")
        ax.ticklabel_format(useOffset=False, style="plain")
        fig.colorbar(image, ax=ax, label=unit, shrink=0.9)
    return save(fig, path)


def hazard_section(run, out, written):
    if not (run.out_dir / "rasters" / "pft.asc").is_file():
        return ["<p>No hazard maps: they are written on a DEM's grid, for scenes on a "
                "<code>heightfield</code> terrain (<code>output.rasters</code>).</p>"]
    written.append(hazard_maps(run, out / "hazard_maps.png"))
    return [figure(written[-1], (
        "Hazard maps (<code>rasters/</code>, AvaFrame's names) over a hillshade of the DEM, in "
        "the DEM's coordinates; white: the release's outline. pft: peak flow thickness normal "
        "to the terrain; pfv: peak of the cell's mass-weighted mean speed; ppr: peak pressure "
        "ρu² in kPa. Transparent: cells the snow never reached. The same rasters open in QGIS "
        "as GeoTIFF (<code>.tif</code>) or ESRI ASCII grid (<code>.asc</code>)."))]


def render_section(run):
    """The renderer's contact sheet (`firn render`), when the run has been rendered."""
    render_dir = run.out_dir / "render"
    contact = render_dir / "contact.png"
    if contact.is_file():
        return [figure(contact, "Contact sheet of the rendered frames (<code>firn render</code>): "
                                "the run from start to end.")]
    frames = sorted(render_dir.glob("frame.*.png"))
    if not frames:
        return []
    picks = sorted({frames[0], frames[len(frames) // 2], frames[-1]})
    return [figure(f, f"Rendered frame <code>{html.escape(f.name)}</code> "
                      "(<code>firn render</code>).") for f in picks]


def map_section(run, out, written):
    if not run.has_weak_layer:
        return ["<p>This scene has no weak layer (no material with model "
                "<code>weak_layer</code>), so there are no failure maps.</p>"]
    if not run.has_map_data:
        return ["<p>The run wrote no particle cache (<code>output.particles = false</code>), so "
                "there are no failure maps.</p>"]
    how = ("chosen with <code>--times</code>" if run.info["map_times"] == "requested" else
           "4 frames evenly spaced while the crack runs (over the whole run if it does not)")
    times = ", ".join(f"{t:.3f}" for t in run.map_times)
    common = (f"Weak-layer particles binned on cells of the grid spacing (dx = {run.dx:g} m): "
              "the share of them that have yielded at least once (white: failed, black: "
              "elastic) and their mean pressure p; of the slab particles in the same column "
              "(above the weak layer's mean height there), the share that have yielded, their "
              "mean pressure p (red: compression, blue: tension, where the slab is pulled "
              f"apart) and their mean speed. Pale blue: no weak layer there (saw cut, or outside the layer). "
              f"Map times ({how}): {times} s. After Gaume et al. (2019), Fig. A1.")
    parts = []
    if run.dimension == 3:
        written.append(failure_maps_3d(run, out / "failure_maps.png"))
        parts.append(figure(written[-1], "Failure maps, top view of the weak layer (x down-slope, "
                                         "z across). " + common))
    else:
        written.append(failure_maps_2d(run, out / "failure_maps.png"))
        parts.append(figure(written[-1], "Failure maps of a 2D run as x–time images: the weak "
                                         "layer along the slope (horizontal) as time goes on "
                                         "(upwards); the blue line is the crack tip, dashed green "
                                         "lines the map times. " + common))
        written.append(failure_profiles_2d(run, out / "failure_profiles.png"))
        parts.append(figure(written[-1], "The same quantities along the slope at the map times."))
    if "strength_used" in run.weak:
        written.append(strength_used_chart(run, out / "strength_used.png"))
        parts.append(figure(written[-1], (
            "The weak layer's static load before anything triggers it (the first frame: the "
            "settled state at t = 0): weak_layer.csv <code>strength_used</code>, each cell's mean "
            "over its weak-layer particles of the share of their initial Cam-Clay surface (eq. 1: "
            "<code>initial_p0</code>, M, β) that their stress uses, scaling the stress from zero "
            "until it reaches the surface. 1: on the surface. Where the static load exceeds the "
            "strength the layer has already yielded and softened (green: cells where half the "
            "particles or more failed, which settling's report names), so its stress sits on a "
            "smaller surface and reads below 1 there. Elsewhere, the closer to 1, the less a "
            "trigger has to add.")))
    return parts


def slab_section(run, out, written):
    if not run.has_slab:
        return ["<p>This scene has no slab (no material with model <code>snow</code>), so there "
                "are no slab fractures.</p>"]
    if not run.has_slab_metrics:
        return ["<p>This run's metrics.csv has no slab fracture columns (written before they "
                "existed).</p>"]
    parts = []
    if not run.slab_fractures:
        parts.append("<p>No slab fracture: no slab column fractured through 80 % of its "
                     "thickness.</p>")
    written.append(slab_fracture_chart(run, out / "slab_fractures.png"))
    parts.append(figure(written[-1], (
        "Slab fractures (summary.json <code>slab_fractures</code>): a slab particle (model "
        "<code>snow</code>) is fractured once its cohesion p<sub>0</sub> has softened through "
        "dilation to half its initial value; a fracture goes through the slab where fractured "
        "particles fill 80 % of the slab's thickness (cells of dx along the bed, rows of dx "
        "normal to it). Left: position and time where each went through (filled), joined to "
        "where and when it began (open: the window's first fractured particle; the table gives "
        "how far behind the tip that was), with the weak-layer "
        "crack tip (labels: distance behind the tip that passed it, along the ground profile; "
        "along x on other terrain; in 3D, behind the crack's front in plan, from "
        "crack_arrival.csv: to the nearest bed cell the crack had not reached when the fracture "
        "went through, negative when it had not reached the fracture's own cell; "
        "the paper finds &lt; 1 m). Middle: the depth "
        "where each started, from the weak-layer interface (0) to the top surface (1): Gaume et "
        "al. (2019) find the crown fracture starting at the interface at the slope scale "
        "(Fig. 5) and from the top in the PST. Right: blocks of intact slab (face-connected "
        "cells of dx) against time, and the mass of the largest and the median one, as the slab "
        "granulates.")))
    if run.slab_fractures:
        parts.append(slab_fracture_table(run))
    return parts


def write_report(run, quiet):
    out = run.report_dir
    written = []
    sections = [f"<h1>Firn report: {html.escape(str(run.name))}</h1>",
                f"<p>Run folder <code>{html.escape(str(run.out_dir))}</code>, "
                f"{run.dimension}D, status <b>{html.escape(str(run.summary.get('status')))}</b>."
                "</p>", "<h2>Summary</h2>", summary_table(run)]

    sections.append("<h2>Weak layer failure maps</h2>")
    sections += map_section(run, out, written)

    sections.append("<h2>Crack propagation</h2>")
    if run.has_crack:
        written.append(crack_chart(run, out / "crack.png"))
        sections.append(figure(written[-1], (
            "Left: the crack tip (leading end of the weak-layer region with anticrack strain "
            "η > 0, metrics.csv <code>crack_tip_x</code>) and the extent's two ends against "
            "time; orange: the leading tip timed to the step (summary.json "
            "<code>crack_tip_steps</code>, from each weak-layer particle's crack time: a jump "
            "is a crack that started on its own ahead of the tip joining it). Right: the crack "
            "speed (the tip's advance between frames, <code>crack_speed</code>; orange: over "
            "each 0.5 m of the step-timed tip's advance) against the tip position along the "
            "slope, as in Gaume "
            "et al. (2019), Fig. 3 bottom; dashed: the steady mean speed of summary.json; grey "
            "bars: slab fractures (summary.json <code>slab_fractures</code>), one cell wide.")))
    else:
        sections.append("<p>No crack: no weak-layer particle reached η &gt; 0.</p>")
    arrival = run.arrival()
    if arrival is not None:
        chart, speeds = crack_arrival_chart(run, out / "crack_arrival.png", arrival)
        written.append(chart)
        ratio = (f"{speeds['across'] / speeds['up']:.2f}"
                 if speeds["across"] is not None and speeds["up"] else "n/a")
        sections.append(figure(written[-1], (
            "Left: where and when the weak layer cracked, seen from above the bed "
            "(crack_arrival.csv: each dx cell of the bed's plan, the time its weak layer first "
            "cracked, from the particles' crack times, timed to the step), with isochrones. "
            "Right: arrival time against distance from the first crack up-slope and down-slope "
            "along its row and across the slope along its column; the front speed is the "
            "least-squares slope beyond 0.5 m, where the cells there span at least 1 m. "
            "Across / up-slope: " + ratio + " (Gaume et al. "
            "2019: the anti-plane crack runs at about half the slope-wise speed).")))

    sections.append("<h2>Slab fractures</h2>")
    sections += slab_section(run, out, written)

    sections.append("<h2>Flow</h2>")
    written.append(flow_chart(run, out / "flow.png"))
    unit = " per metre of width (2D)" if run.dimension == 2 else ""
    sections.append(figure(written[-1], (
        "Left: the flow speed against time, the largest grid velocity where the snow is denser "
        "than 100 kg/m³ (the volume caches, up to 60 frames; the speed the snow moves with, "
        "the field of Gaume et al. 2019, Fig. 6), and the fastest particle's own speed "
        "(metrics.csv <code>max_speed</code>; with pure FLIP it also carries particle noise); "
        "with a slab on a weak layer, the speed of the slab's centre of mass (metrics.csv "
        "<code>slab_speed</code>: 0 while it rests, rising as the released slab leaves its bed); "
        "dashed: Gauer's estimate of the maximum speed, (g H / 2)<sup>1/2</sup>, with H the drop "
        "from the release's highest point to the deposit's farthest, both of the snow that moved "
        "(summary.json <code>release_top_y</code>, <code>runout_y</code>; Gaume et al. 2019 compare "
        "with it: ≈ 8 m/s on their 25 m and 22 m slopes, ≈ 27 m/s on the 480 m path). "
        "Right: total kinetic energy" + unit + " (metrics.csv).")))
    deposit = run.deposit()
    if deposit is not None:
        written.append(deposit_chart(run, out / "deposit.png", deposit))
        sections.append(figure(written[-1], (
            "The snow's vertical depth along the path in the first and the last particle frame "
            "(report/data/deposit.csv: the volume of the particles in each dx cell along x, as "
            "seeded, per metre along x" + (" and per metre of the width that holds snow there"
            if run.dimension == 3 else "") + "; densification is not counted): blue where snow "
            "left (the release and what it eroded), red where it arrived (the deposit); dashed: "
            "summary.json <code>runout_x</code>.")))

    sections.append("<h2>McClung &amp; Gauer diagram and α-angle</h2>")
    written.append(mcclung_gauer_chart(run, out / "mcclung_gauer.png"))
    sections.append(figure(written[-1], (
        "As in Gaume et al. (2019), Fig. 7. Left: maximum flow speed u<sub>m</sub> (the grid "
        "flow speed of the Flow chart; summary.json <code>max_speed</code>, the fastest particle, "
        "when the run wrote no density and velocity volumes) against the square root of the "
        "path length L, with the "
        "relation u<sub>m</sub> ≈ 1.5 L<sup>1/2</sup> of McClung &amp; Gauer (2018) that the "
        "paper quotes; their field data points are not bundled, only this fit. Here L is the "
        "straight distance from the highest point of the release (first frame) to the farthest "
        "point of the deposit along x (last frame), the two points that define the α-angle. "
        "Right: u<sub>m</sub> against the α-angle (summary.json <code>alpha_angle_deg</code>), "
        "with the 20–30° band that the paper finds for all its simulations.")))

    sections.append("<h2>Hazard maps</h2>")
    sections += hazard_section(run, out, written)

    rendered = render_section(run)
    if rendered:
        sections.append("<h2>Rendered frames</h2>")
        sections += rendered

    page = ("<!DOCTYPE html>\n<html lang=en><head><meta charset=utf-8>"
            f"<title>Firn report: {html.escape(str(run.name))}</title>"
            f"<style>{STYLE}</style></head><body>\n" + "\n".join(sections) +
            "\n</body></html>\n")
    target = out / "report.html"
    tmp = out / ".report.html.tmp"
    tmp.write_text(page, encoding="utf-8")
    tmp.replace(target)  # appears only complete
    if not quiet:
        for path in written + [target]:
            print(f"report.py: wrote {path}", file=sys.stderr)
    return target


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir", help="a run folder on which `firn report` has written "
                                        "report/data")
    parser.add_argument("--quiet", action="store_true", help="no progress lines")
    args = parser.parse_args()
    try:
        write_report(Run(args.out_dir), args.quiet)
    except ReportError as e:
        print(f"report.py: error: {e}", file=sys.stderr)
        return 3
    return 0


if __name__ == "__main__":
    sys.exit(main())
