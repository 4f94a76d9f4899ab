#!/usr/bin/env python3
"""Blender's cloth on drape's benchmark scenes: the peer that `drape bench` compares against.

`drape bench` runs this script as a subprocess, then measures the frames it writes with
drape's own independent intersection checker and strain measure, so both simulators are
judged by the same code. Needs Blender 5.0.1 as a Python module (Python 3.11):

    pip install bpy==5.0.1
    python3 benches/peers/blender_cloth.py --scene drape_sphere --out DIR [--frames N] [--quality Q]

The scene is read from assets/scenes/<scene>.toml and its fabric from the preset it names,
so Blender gets the same cloth (the grid of `mesh::generate::grid`: same vertex order, same
quad diagonals), height, colliders, mass, frame rate and duration as drape. Writes
DIR/frame_0000.obj (the initial state) to DIR/frame_<N>.obj, Y-up metres like drape's
frames, and DIR/blender.json: the timings and every Blender setting used. Only the frame
stepping is timed, not the setup or the OBJ writing.

Units. Blender's cloth solver has its own time unit, 1/sqrt(1000) s: gravity enters as
0.001·g per unit², and one frame is one unit whatever the scene's fps. Its force unit is
therefore kg·m per unit² = 1000 N. The script sets the speed multiplier (`time_scale`) so
that a frame lasts 1/fps s, and converts drape's SI fabric into these units for Blender's
springs (see `cloth_settings`). Blender's Cotton preset is tuned for 0.3 kg per vertex: with
the real mass (33 mg per vertex here) its springs would act 10⁴ times stiffer than meant and
its air damping would let the cloth fall at 1 mm/s. drape's strain limit has no Blender
counterpart.

Contact. Blender resolves contacts from the positions at the end of each step, so at
drape's 2.5 mm thickness its default 5 steps per frame let the tablecloth, landing at 3 m/s,
pass through the 5 cm table top (measured: through at 6 steps, held from 7); pass
--quality 10 for drape_table.

Exit codes: 0 done, 1 error, 4 bpy not installed (the harness reports the peer as skipped).
"""

import argparse
import json
import math
import os
import statistics
import sys
import tempfile
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

try:
    import bpy
    import bmesh  # importable once bpy is
    import numpy as np  # a dependency of the bpy package
except ImportError:
    bpy = None

SKIPPED = 4
REPO = Path(__file__).resolve().parents[2]
SCENES = ("drape_sphere", "drape_table")

# Blender cloth's time unit in seconds, and its force unit in newtons (kg·m per time unit²).
TIME_UNIT_S = 1.0 / math.sqrt(1000.0)
FORCE_UNIT_N = 1000.0
# One Blender damping unit (force unit per m per time unit) in N·s/m.
DAMPING_UNIT_N_S_PER_M = FORCE_UNIT_N * TIME_UNIT_S

FIRST_FRAME = 1  # Blender frame holding drape's frame 0; the cloth cache starts here.
SPHERE_SEGMENTS, SPHERE_RINGS = 64, 32
GROUND_SIZE_M = 20.0


class PeerError(Exception):
    """A problem worth a one-line message rather than a traceback."""


@dataclass
class Collider:
    """A drape collider: `kind` is plane, sphere or box; positions and sizes in drape's frame."""

    name: str
    kind: str
    position_m: tuple
    friction: float
    radius_m: float = 0.0
    size_m: tuple = (0.0, 0.0, 0.0)


@dataclass
class Scene:
    """What this script needs from a drape scene file, in drape's frame (Y up, metres)."""

    name: str
    fps: float
    frames: int
    size_m: float
    resolution: int
    translation_m: tuple
    self_collision: bool
    fabric: dict
    colliders: list


def load_scene(name):
    """Reads assets/scenes/<name>.toml and its fabric preset; refuses what it cannot reproduce."""
    path = REPO / "assets" / "scenes" / f"{name}.toml"
    spec = tomllib.loads(path.read_text())
    garments = spec.get("garment", [])
    if len(garments) != 1 or "grid" not in garments[0]["mesh"]:
        raise PeerError(f"{path}: expected one garment with a grid mesh")
    garment = garments[0]
    unsupported = [k for k in ("rotation_deg", "scale", "pin") if k in garment]
    if unsupported:
        raise PeerError(f"{path}: garment keys not reproduced in Blender: {', '.join(unsupported)}")
    preset = garment["preset"]
    preset_path = path.parent / preset if preset.endswith(".toml") else REPO / "presets" / f"{preset}.toml"
    fabric = tomllib.loads(preset_path.read_text())["fabric"] | garment.get("fabric", {})
    grid_spec = garment["mesh"]["grid"]
    time_spec = spec["time"]
    return Scene(
        name=name,
        fps=time_spec["fps"],
        frames=round(time_spec["duration_s"] * time_spec["fps"]),
        size_m=grid_spec["size_m"],
        resolution=grid_spec["resolution"],
        translation_m=tuple(garment.get("translation_m", (0.0, 0.0, 0.0))),
        self_collision=garment.get("self_collision", True),
        fabric=fabric,
        colliders=[load_collider(c, fabric, path) for c in spec.get("collider", [])],
    )


def load_collider(spec, fabric, path):
    """One `[[collider]]` table: an unrotated, unmoving plane, sphere or box."""
    if "rotation_deg" in spec or "motion" in spec:
        raise PeerError(f"{path}: collider {spec['name']}: rotation and motion are not reproduced in Blender")
    collider = Collider(
        name=spec["name"],
        kind="plane",
        position_m=tuple(spec.get("position_m", (0.0, 0.0, 0.0))),
        friction=spec.get("friction", fabric["friction"]),
    )
    shape = spec["shape"]
    if shape == "plane":
        return collider
    if isinstance(shape, dict) and "sphere" in shape:
        collider.kind, collider.radius_m = "sphere", shape["sphere"]["radius_m"]
        return collider
    if isinstance(shape, dict) and "box" in shape:
        collider.kind, collider.size_m = "box", tuple(shape["box"]["size_m"])
        return collider
    raise PeerError(f"{path}: collider {spec['name']}: shape {shape} is not reproduced in Blender")


def grid(size_m, resolution, translation_m):
    """drape's `mesh::generate::grid`, translated: positions (drape's frame), quads, triangles.

    Vertex `row * n + col` sits at x = -size/2 + col·h, z = -size/2 + row·h. Quads run
    counter-clockwise seen from +Y and are rotated by one corner on odd cells (a checkerboard
    of diagonals); each quad (a, b, c, d) splits into (a, b, c) and (a, c, d).
    """
    n = resolution
    h = size_m / (n - 1)
    tx, ty, tz = translation_m
    positions = [
        (-0.5 * size_m + col * h + tx, ty, -0.5 * size_m + row * h + tz) for row in range(n) for col in range(n)
    ]
    quads = []
    for row in range(n - 1):
        for col in range(n - 1):
            corners = [row * n + col, (row + 1) * n + col, (row + 1) * n + col + 1, row * n + col + 1]
            quads.append(corners if (row + col) % 2 == 0 else corners[1:] + corners[:1])
    triangles = [tri for a, b, c, d in quads for tri in ((a, b, c), (a, c, d))]
    return positions, quads, triangles


def to_blender(p):
    """drape (x, y, z), Y up, to Blender (x, -z, y), Z up: a rotation, so windings are kept."""
    x, y, z = p
    return (x, -z, y)


def from_blender(co):
    """Blender coordinates, an (n, 3) array, back to drape's frame."""
    return np.column_stack((co[:, 0], co[:, 2], -co[:, 1]))


def cloth_settings(scene, quality):
    """Blender `ClothSettings` for drape's fabric on this grid, in Blender's units.

    With spacing h, force unit F = 1000 N and time unit τ = 1/sqrt(1000) s:
    - mass: area density × area / vertex count, per vertex (Blender's masses are uniform).
    - tension: an edge spring is tension / (mean edge length h) F per metre and carries a strip
      h wide, so a membrane stretch stiffness E (N/m) is tension = E·h / F; compression with
      drape's compression ratio (Blender's angular model buckles under compression).
    - shear: the two quad diagonals only resist tension, so one of them carries a shear of
      stiffness G (N/m): shear = 2·G·h / F.
    - bending: the angular spring is a force 0.1·bending·h·Δθ on each face, applied at the
      face centre h/2 from the hinge; matching drape's moment G_b·Δθ/h (G_b in N·m) gives
      bending = 20·G_b / (F·h²).
    - damping: a spring's damping force is damping × the relative speed along it (F·τ/m);
      drape's membrane damping c (N·s/m) is the same per spring, so damping = c / (F·τ),
      doubled for the tension-only diagonals; the hinge's damping moment gives
      bending_damping = 4·c_b / (F·τ·h²).
    - air: Blender's drag is 0.01·air_damping F·τ/m per vertex; drape's is air × mass per
      vertex, so air_damping = 100 · air · mass / (F·τ).
    - time_scale makes one frame last 1/fps s (τ·time_scale = 1/fps).
    """
    f = scene.fabric
    n = scene.resolution
    h = scene.size_m / (n - 1)
    mass = f["area_density_kg_per_m2"] * scene.size_m**2 / n**2
    tension = f["stretch_stiffness_n_per_m"] * h / FORCE_UNIT_N
    return {
        "quality": quality,
        "time_scale": 1.0 / (scene.fps * TIME_UNIT_S),
        "mass": mass,
        "bending_model": "ANGULAR",
        "tension_stiffness": tension,
        "compression_stiffness": f["compression_ratio"] * tension,
        "shear_stiffness": 2.0 * f["shear_stiffness_n_per_m"] * h / FORCE_UNIT_N,
        "bending_stiffness": 20.0 * f["bend_stiffness_n_m"] / (FORCE_UNIT_N * h * h),
        "tension_damping": f["stretch_damping_n_s_per_m"] / DAMPING_UNIT_N_S_PER_M,
        "compression_damping": f["stretch_damping_n_s_per_m"] / DAMPING_UNIT_N_S_PER_M,
        "shear_damping": 2.0 * f["shear_damping_n_s_per_m"] / DAMPING_UNIT_N_S_PER_M,
        "bending_damping": 4.0 * f["bend_damping_n_m_s"] / (DAMPING_UNIT_N_S_PER_M * h * h),
        "air_damping": 100.0 * f["air_damping_per_s"] * mass / DAMPING_UNIT_N_S_PER_M,
    }


def cloth_collision_settings(scene):
    """Blender `ClothCollisionSettings`: drape's thickness as the contact distances, drape's
    friction for self-contact (Blender's friction is 100 × the Coulomb coefficient; against
    colliders it is the collider's own), Blender's default collision quality."""
    f = scene.fabric
    return {
        "use_collision": True,
        "distance_min": f["thickness_m"],
        "collision_quality": 2,
        "use_self_collision": scene.self_collision,
        "self_distance_min": f["thickness_m"],
        "self_friction": 100.0 * f["friction"],
    }


def collider_settings(scene, collider):
    """Blender `CollisionSettings` of a collider: drape's thickness and friction."""
    return {"thickness_outer": scene.fabric["thickness_m"], "cloth_friction": 100.0 * collider.friction}


def apply(target, settings):
    """Sets `settings` on a Blender struct and returns them as Blender stored them."""
    for key, value in settings.items():
        setattr(target, key, value)
    return {key: getattr(target, key) for key in settings}


def collider_mesh(collider):
    """The collider as a Blender mesh, centred on the object origin (Blender's frame)."""
    bm = bmesh.new()
    if collider.kind == "sphere":
        bmesh.ops.create_uvsphere(bm, u_segments=SPHERE_SEGMENTS, v_segments=SPHERE_RINGS, radius=collider.radius_m)
    elif collider.kind == "box":
        bmesh.ops.create_cube(bm, size=1.0)
        sx, sy, sz = collider.size_m
        bmesh.ops.scale(bm, vec=(sx, sz, sy), verts=bm.verts)
    else:
        bmesh.ops.create_grid(bm, x_segments=1, y_segments=1, size=0.5 * GROUND_SIZE_M)
    mesh = bpy.data.meshes.new(collider.name)
    bm.to_mesh(mesh)
    bm.free()
    return mesh


def add_object(name, mesh):
    """Links a new object holding `mesh` to the scene, at the origin."""
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def check_triangulation(mesh, triangles):
    """Blender's own split of the quads (its collision triangles) must be drape's."""
    mesh.calc_loop_triangles()
    blender = [tuple(t.vertices) for t in mesh.loop_triangles]
    if blender != [tuple(t) for t in triangles]:
        raise PeerError("Blender triangulates the grid's quads differently from drape")


def setup_scene(scene, frames):
    """An empty Blender scene at drape's frame rate and gravity; returns the settings used."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    blender_scene = bpy.context.scene
    settings = apply(blender_scene.render, {"fps": round(scene.fps), "fps_base": round(scene.fps) / scene.fps})
    settings |= apply(
        blender_scene,
        {
            "gravity": to_blender(scene.fabric["gravity_m_per_s2"]),
            "use_gravity": True,
            "frame_start": FIRST_FRAME,
            "frame_end": FIRST_FRAME + frames,
        },
    )
    settings["gravity"] = tuple(settings["gravity"])
    return settings


def add_cloth(scene, quality, frames):
    """The grid with a Cloth modifier; returns the object, its triangles and the settings used."""
    positions, quads, triangles = grid(scene.size_m, scene.resolution, scene.translation_m)
    mesh = bpy.data.meshes.new("cloth")
    mesh.from_pydata([to_blender(p) for p in positions], [], quads)
    mesh.update()
    check_triangulation(mesh, triangles)
    cloth = add_object("cloth", mesh)
    modifier = cloth.modifiers.new("Cloth", "CLOTH")
    settings = {
        "cloth.settings": apply(modifier.settings, cloth_settings(scene, quality)),
        "cloth.collision_settings": apply(modifier.collision_settings, cloth_collision_settings(scene)),
        "cloth.point_cache": apply(
            modifier.point_cache, {"frame_start": FIRST_FRAME, "frame_end": FIRST_FRAME + frames}
        ),
    }
    return cloth, triangles, settings


def add_collider(scene, collider):
    """A collider object with a Collision modifier; returns the settings used."""
    obj = add_object(collider.name, collider_mesh(collider))
    obj.location = to_blender(collider.position_m)
    obj.modifiers.new("Collision", "COLLISION")
    mesh_settings = {"sphere": {"segments": SPHERE_SEGMENTS, "rings": SPHERE_RINGS}, "plane": {"size_m": GROUND_SIZE_M}}
    return {
        "shape": collider.kind,
        **mesh_settings.get(collider.kind, {}),
        **apply(obj.collision, collider_settings(scene, collider)),
    }


def build(scene, quality, frames):
    """A fresh Blender scene with the cloth and the colliders.

    Returns the cloth object, the triangles to export and every setting used.
    """
    settings = {"scene": setup_scene(scene, frames)}
    cloth, triangles, cloth_settings_used = add_cloth(scene, quality, frames)
    settings |= cloth_settings_used
    for collider in scene.colliders:
        settings[f"collider.{collider.name}"] = add_collider(scene, collider)
    return cloth, triangles, settings


def cloth_positions(cloth, depsgraph, vertices):
    """The cloth's evaluated vertices at the current frame, in drape's frame."""
    evaluated = cloth.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        if len(mesh.vertices) != vertices:
            raise PeerError(f"Blender's cloth has {len(mesh.vertices)} vertices, expected {vertices}")
        co = np.empty(3 * vertices, dtype=np.float32)
        mesh.vertices.foreach_get("co", co)
    finally:
        evaluated.to_mesh_clear()
    return from_blender(co.reshape(-1, 3).astype(np.float64))


def write_obj(path, positions, faces):
    """One frame: `v x y z` lines, then the prepared `f a b c` block."""
    vertices = "".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in positions.tolist())
    path.write_text(vertices + faces)


def write_json(path, data):
    """Writes `data` next to `path` and renames it into place."""
    fd, temporary = tempfile.mkstemp(dir=path.parent, prefix=".blender-", suffix=".json")
    with os.fdopen(fd, "w") as out:
        json.dump(data, out, indent=2)
        out.write("\n")
    os.replace(temporary, path)


def simulate(cloth, triangles, vertices, frames, out):
    """Steps the cloth frame by frame, writing each; returns (setup ms, step ms list, CPU s)."""
    blender_scene = bpy.context.scene
    depsgraph = bpy.context.evaluated_depsgraph_get()
    faces = "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in triangles)

    start = time.perf_counter()
    blender_scene.frame_set(FIRST_FRAME)
    setup_ms = 1e3 * (time.perf_counter() - start)
    write_obj(out / "frame_0000.obj", cloth_positions(cloth, depsgraph, vertices), faces)

    step_ms, cpu_s = [], 0.0
    for frame in range(1, frames + 1):
        cpu, start = time.process_time(), time.perf_counter()
        blender_scene.frame_set(FIRST_FRAME + frame)
        step_ms.append(1e3 * (time.perf_counter() - start))
        cpu_s += time.process_time() - cpu
        write_obj(out / f"frame_{frame:04d}.obj", cloth_positions(cloth, depsgraph, vertices), faces)
    return setup_ms, step_ms, cpu_s


def run(args):
    """Builds the scene, simulates it and writes the frames and blender.json."""
    scene = load_scene(args.scene)
    frames = scene.frames if args.frames is None else args.frames
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for stale in out.glob("frame_*.obj"):
        stale.unlink()

    cloth, triangles, settings = build(scene, args.quality, frames)
    vertices = scene.resolution**2
    setup_ms, step_ms, cpu_s = simulate(cloth, triangles, vertices, frames, out)
    sim_s = sum(step_ms) / 1e3
    write_json(
        out / "blender.json",
        {
            "scene": scene.name,
            "scene_file": str(REPO / "assets" / "scenes" / f"{scene.name}.toml"),
            "blender_version": bpy.app.version_string,
            "vertices": vertices,
            "triangles": len(triangles),
            "frames": frames,
            "fps": scene.fps,
            "sim_seconds_total": sim_s,
            "ms_per_frame_mean": statistics.fmean(step_ms),
            "ms_per_frame_median": statistics.median(step_ms),
            "per_frame_ms": step_ms,
            "setup_ms": setup_ms,
            "threads": bpy.context.scene.render.threads,
            "cpu_seconds_total": cpu_s,
            "settings": settings,
        },
    )
    print(
        f"{scene.name}: {frames} frames of {vertices} vertices in {sim_s:.2f} s "
        f"(median {statistics.median(step_ms):.0f} ms per frame), written to {out}"
    )


def parse_args():
    """The command line."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", required=True, choices=SCENES, help="drape benchmark scene")
    parser.add_argument("--out", required=True, help="output folder for frame_NNNN.obj and blender.json")
    parser.add_argument("--frames", type=int, help="frames to simulate after frame 0 (default: the scene's duration)")
    parser.add_argument("--quality", type=int, default=5, help="Blender's steps per frame (default 5, Blender's own)")
    args = parser.parse_args()
    if args.frames is not None and args.frames < 1:
        parser.error("--frames must be at least 1")
    if args.quality < 1:
        parser.error("--quality must be at least 1")
    return args


def main():
    args = parse_args()
    if bpy is None:
        print("bpy not installed: pip install bpy==5.0.1 (Python 3.11)", file=sys.stderr)
        return SKIPPED
    try:
        run(args)
    except KeyError as error:
        print(f"blender_cloth: {args.scene}: missing entry {error} in the scene or its preset", file=sys.stderr)
        return 1
    except (PeerError, OSError, tomllib.TOMLDecodeError) as error:
        print(f"blender_cloth: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
