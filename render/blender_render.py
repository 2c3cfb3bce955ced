"""Render a Firn output folder with Blender's Cycles, headless, to PNG.

Usage (Blender 3.4 or later; Debian's `blender` package):

    blender -b --python render/blender_render.py -- OUT_DIR [options]

OUT_DIR is the folder of a `firn run`: the snow is its frames/volume.NNNN.vdb sequence, read
untouched as a Blender Volume object (a file sequence) with a Principled Volume driven by the
`density` grid; the ground is its terrain.obj. A sun, a sky and a camera that frames the snow
over the rendered frames, with the ground under it, are added. 3D runs are seen from the side
across the slope and above, in perspective; 2D runs (one voxel thick, in the x-y plane) from
the side along -z with an orthographic camera. Firn's y-up world is turned z-up as a whole.

Options (after the `--`):
    --frames A:B         frames to render, inclusive, by cache frame number; "A:" or ":B" leave
                         one end open, "A" renders one frame (default: every cached frame)
    --res WxH            image size in pixels (default: 960x540)
    --samples N          Cycles samples per pixel (default: 32); denoising is off (Debian's
                         Blender lacks OpenImageDenoise)
    --out DIR            where frame.NNNN.png are written (default: OUT_DIR/blender)
    --density-scale S    extinction per metre per kg/m^3 of the density grid (default: chosen so
                         that snow at the scene's largest material density has an optical depth
                         of 1.5 per voxel in 3D, 4 per voxel in 2D, so a few voxels read opaque)
    --threads N          CPU threads for Cycles (default: 0, all)
    --no-snow            leave the snow out (the camera still frames it): the bare ground, for
                         compositing and to compare against
    -h, --help           print this and exit

Exit status: 0 when every frame was written; 1 when OUT_DIR is not a cache folder, has no
volume frames, or the frames asked for are not there (with a message saying so); 2 on a bad
option.
"""

import argparse
import math
import os
import re
import sys
import traceback

try:
    import tomllib  # Python 3.11: Debian's Blender 3.4, upstream Blender 4.1 and later
except ImportError:
    tomllib = None

import bpy
import numpy as np
from mathutils import Matrix, Vector

PROG = "blender_render.py"
SKY = (0.55, 0.65, 0.8)
SNOW = (0.92, 0.94, 0.97)
GROUND = (0.12, 0.11, 0.10)
OPTICAL_DEPTH_PER_VOXEL = {2: 4.0, 3: 1.5}
# Firn is y-up, Blender z-up: a quarter turn about x takes (x, y, z) to (x, -z, y), the same
# turn Blender's OBJ importer makes by default (forward -Z, up Y).
Y_UP_TO_Z_UP = Matrix.Rotation(math.radians(90.0), 4, "X")


class InputError(Exception):
    """Something about OUT_DIR or the options that the user can fix."""


def parse_args(argv):
    parser = argparse.ArgumentParser(
        prog="blender -b --python render/blender_render.py --",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("out_dir", metavar="OUT_DIR", help="a firn run's output folder")
    parser.add_argument("--frames", default=":", help="A:B, A: , :B or A (default: all)")
    parser.add_argument("--res", default="960x540", help="WxH pixels (default 960x540)")
    parser.add_argument("--samples", type=int, default=32, help="samples per pixel (32)")
    parser.add_argument("--out", help="output folder (default OUT_DIR/blender)")
    parser.add_argument("--density-scale", type=float,
                        help="extinction per metre per kg/m^3 (default: from scene.toml)")
    parser.add_argument("--threads", type=int, default=0, help="CPU threads (0: all)")
    parser.add_argument("--no-snow", action="store_true", help="render the ground alone")
    args = parser.parse_args(argv)
    match = re.fullmatch(r"(\d+)x(\d+)", args.res)
    if not match or int(match[1]) < 1 or int(match[2]) < 1:
        parser.error(f"--res: expected WxH such as 960x540, got {args.res!r}")
    args.size = (int(match[1]), int(match[2]))
    match = re.fullmatch(r"(\d*)(:?)(\d*)", args.frames)
    if not match or (match[2] == "" and match[1] == ""):
        parser.error(f"--frames: expected A:B, A:, :B or A, got {args.frames!r}")
    first = int(match[1]) if match[1] else 0
    last = int(match[3]) if match[3] else (first if match[2] == "" else math.inf)
    args.frame_range = (first, last)
    if args.samples < 1:
        parser.error(f"--samples: must be at least 1, got {args.samples}")
    if args.density_scale is not None and not args.density_scale > 0:
        parser.error(f"--density-scale: must be positive, got {args.density_scale}")
    return args


def volume_frames(out_dir, frame_range):
    """Frame numbers of frames/volume.NNNN.vdb within frame_range, sorted."""
    if not os.path.isdir(out_dir):
        raise InputError(f"{out_dir}: no such folder")
    frames_dir = os.path.join(out_dir, "frames")
    names = os.listdir(frames_dir) if os.path.isdir(frames_dir) else []
    cached = sorted(int(m[1]) for m in map(re.compile(r"volume\.(\d{4,})\.vdb").fullmatch, names)
                    if m)
    if not cached:
        raise InputError(f"{frames_dir}: no volume.NNNN.vdb frames (is this a firn output "
                         "folder, and was the run's output.volumes empty?)")
    first, last = frame_range
    chosen = [f for f in cached if first <= f <= last]
    if not chosen:
        raise InputError(f"no volume frames in {first}..{last} (the cache has frames "
                         f"{cached[0]}..{cached[-1]})")
    return cached, chosen


def read_scene(out_dir):
    """Dimension, grid spacing and the largest material density of OUT_DIR/scene.toml."""
    if tomllib is None:
        raise InputError(f"this Blender's Python {sys.version.split()[0]} cannot read TOML "
                         "(tomllib needs 3.11): use Blender 4.1 or later, or Debian's")
    path = os.path.join(out_dir, "scene.toml")
    try:
        with open(path, "rb") as f:
            scene = tomllib.load(f)
    except (OSError, tomllib.TOMLDecodeError) as error:
        raise InputError(f"cannot read {path}: {error}") from error
    dimension = scene.get("simulation", {}).get("dimension", 3)
    dx = scene.get("grid", {}).get("dx", 0.05)
    densities = [m.get("density", 250.0) for m in scene.get("material", [])] or [250.0]
    return dimension, dx, max(densities)


def reset_scene(args):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = args.samples
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = args.size
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    if args.threads > 0:
        scene.render.threads_mode = "FIXED"
        scene.render.threads = args.threads
    world = bpy.data.worlds.new("sky")
    world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (*SKY, 1.0)
    background.inputs["Strength"].default_value = 0.6
    scene.world = world
    return scene


def add_snow(scene, out_dir, cached, density_scale):
    """The volume sequence: Blender swaps the file's digits for (scene frame - frame_start + 1 +
    frame_offset), so frame_start 0 and offset -1 make scene frame N read volume.N.vdb."""
    volume = bpy.data.volumes.new("snow")
    volume.filepath = os.path.join(out_dir, "frames", f"volume.{cached[0]:04d}.vdb")
    volume.is_sequence = True
    volume.frame_start = 0
    volume.frame_offset = -1
    volume.frame_duration = cached[-1] + 1
    volume.sequence_mode = "CLIP"
    material = bpy.data.materials.new("snow")
    material.use_nodes = True
    nodes = material.node_tree.nodes
    nodes.clear()
    shader = nodes.new("ShaderNodeVolumePrincipled")
    shader.inputs["Color"].default_value = (*SNOW, 1.0)
    shader.inputs["Density"].default_value = density_scale
    shader.inputs["Density Attribute"].default_value = "density"
    # Some back-scatter: the sun is on the camera's side, and an isotropic volume would look
    # grey next to a matte ground under the same light.
    shader.inputs["Anisotropy"].default_value = -0.4
    output = nodes.new("ShaderNodeOutputMaterial")
    material.node_tree.links.new(shader.outputs["Volume"], output.inputs["Volume"])
    volume.materials.append(material)
    snow = bpy.data.objects.new("snow", volume)
    snow.matrix_world = Y_UP_TO_Z_UP
    scene.collection.objects.link(snow)
    return snow


def add_ground(scene, out_dir):
    path = os.path.join(out_dir, "terrain.obj")
    if not os.path.isfile(path):
        print(f"{PROG}: note: no {path} (a cache from before terrain export?): no ground drawn")
        return None
    bpy.ops.wm.obj_import(filepath=path, forward_axis="NEGATIVE_Z", up_axis="Y")
    ground = bpy.context.selected_objects[0]
    material = bpy.data.materials.new("ground")
    material.use_nodes = True
    bsdf = material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*GROUND, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.9
    ground.data.materials.clear()
    ground.data.materials.append(material)
    return ground


def snow_bounds(scene, snow, frames):
    """World-space box (lo, hi) of the snow over the frames; frames without snow add nothing."""
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for frame in frames:
        scene.frame_set(frame)
        evaluated = snow.evaluated_get(bpy.context.evaluated_depsgraph_get())
        corners = np.array([evaluated.matrix_world @ Vector(c) for c in evaluated.bound_box])
        if np.ptp(corners, axis=0).max() > 0:
            lo, hi = np.minimum(lo, corners.min(0)), np.maximum(hi, corners.max(0))
    if not np.all(np.isfinite(lo)):
        raise InputError(f"the volume frames {frames[0]}..{frames[-1]} hold no snow")
    return lo, hi


def ground_under(ground, lo, hi):
    """Grows the box (lo, hi) to hold the ground below and around it: the terrain vertices
    within 10 % of the box's horizontal size of its footprint."""
    if ground is None:
        return lo, hi
    mesh = ground.data
    local = np.empty(3 * len(mesh.vertices))
    mesh.vertices.foreach_get("co", local)
    local = np.c_[local.reshape(-1, 3), np.ones(len(mesh.vertices))]
    world = (local @ np.array(ground.matrix_world).T)[:, :3]
    margin = 0.1 * max(hi[0] - lo[0], hi[1] - lo[1])
    near = np.all((world[:, :2] >= lo[:2] - margin) & (world[:, :2] <= hi[:2] + margin), axis=1)
    if not near.any():
        return lo, hi
    return np.minimum(lo, world[near].min(0)), np.maximum(hi, world[near].max(0))


def add_camera(scene, lo, hi, dimension):
    """A camera that sees the whole box (lo, hi) with 10 % to spare."""
    aspect = scene.render.resolution_x / scene.render.resolution_y
    centre, size = 0.5 * (lo + hi), hi - lo
    corners = np.array(np.meshgrid(*zip(lo, hi))).T.reshape(-1, 3) - centre
    camera = bpy.data.cameras.new("camera")
    camera.sensor_fit = "HORIZONTAL"
    margin = 1.1
    if dimension == 2:
        # Nearly along Firn's -z (Blender's +y), 15 degrees from above, orthographic: the
        # extruded ground in front of the snow's plane then projects below the snow, never
        # over it, and shows as a band under it.
        towards_camera = Vector((0.0, -math.cos(math.radians(15)), math.sin(math.radians(15))))
    else:
        # Across the slope (Firn's +z is Blender's -y), a little down-slope, from above.
        towards_camera = Vector((0.35, -1.0, 0.7)).normalized()
    right = (-towards_camera).cross(Vector((0.0, 0.0, 1.0))).normalized()
    up = right.cross(-towards_camera)
    across, along, depth = corners @ np.array(right), corners @ np.array(up), corners @ np.array(
        towards_camera)
    if dimension == 2:
        camera.type = "ORTHO"
        camera.ortho_scale = margin * max(np.ptp(across), np.ptp(along) * aspect)
        # Centre the projected box, then stand well clear of it.
        centre = centre + 0.5 * (across.max() + across.min()) * np.array(right) + 0.5 * (
            along.max() + along.min()) * np.array(up)
        distance = float(depth.max() + np.linalg.norm(size) + 1.0)
    else:
        tan_x = math.tan(0.5 * camera.angle)
        tan_y = tan_x / aspect
        distance = float(np.max(np.maximum(depth + margin * np.abs(across) / tan_x,
                                           depth + margin * np.abs(along) / tan_y)))
    camera.clip_start = 1e-3 * distance
    camera.clip_end = 10.0 * distance + float(np.linalg.norm(size))
    obj = bpy.data.objects.new("camera", camera)
    obj.location = Vector(centre) + distance * towards_camera
    obj.rotation_euler = (-towards_camera).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(obj)
    scene.camera = obj


def add_sun(scene):
    sun = bpy.data.lights.new("sun", "SUN")
    sun.energy = 5.0
    sun.angle = math.radians(5.0)
    obj = bpy.data.objects.new("sun", sun)
    # From above, on the camera's side of the slope and from up-slope.
    obj.rotation_euler = (math.radians(40.0), 0.0, math.radians(-30.0))
    scene.collection.objects.link(obj)


def main(argv):
    args = parse_args(argv)
    out_dir = os.path.abspath(args.out_dir)
    cached, frames = volume_frames(out_dir, args.frame_range)
    dimension, dx, density = read_scene(out_dir)
    density_scale = args.density_scale or OPTICAL_DEPTH_PER_VOXEL[dimension] / (density * dx)
    images = os.path.abspath(args.out or os.path.join(out_dir, "blender"))
    os.makedirs(images, exist_ok=True)

    scene = reset_scene(args)
    snow = add_snow(scene, out_dir, cached, density_scale)
    ground = add_ground(scene, out_dir)
    lo, hi = ground_under(ground, *snow_bounds(scene, snow, frames))
    add_camera(scene, lo, hi, dimension)
    add_sun(scene)
    snow.hide_render = args.no_snow
    print(f"{PROG}: {len(frames)} frame(s) of {out_dir}, {dimension}D, density scale "
          f"{density_scale:.4g} per m per kg/m^3, framing {np.round(lo, 3)}..{np.round(hi, 3)}")
    for frame in frames:
        scene.frame_set(frame)
        scene.render.filepath = os.path.join(images, f"frame.{frame:04d}.png")
        bpy.ops.render.render(write_still=True)
        print(f"{PROG}: wrote {scene.render.filepath}")


def argv_after_dashes():
    return sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []


if __name__ == "__main__":
    # Blender reports an exception escaping a --python script and then exits 0; the exit status
    # must say that nothing was rendered.
    try:
        main(argv_after_dashes())
    except InputError as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        sys.exit(1)
    except Exception:
        traceback.print_exc()
        sys.exit(1)
