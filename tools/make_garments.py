#!/usr/bin/env python3
"""Makes drape's demo garments fitted to the demo body: a single-layer skirt
and a three-tier skirt (outer tiers shorter), hanging from the waist, clear
of the body in its bind pose.

Each skirt is an open tube of quads (split into triangles by drape) whose
rings follow the body's cross-section at the waist and widen downwards (an
A-line), at least CLEARANCE_M from the body everywhere. The top ring is the
waistband: it lies in the OBJ group `waistband` and at the height recorded
in the file's header comment, so a scene pins it with a region (and glues it
to the body with `attach = "body"`).

Run from the repository root after tools/make_bodies.py (needs bpy 5.0.1):

    python3 tools/make_garments.py

Writes assets/garments/{skirt,skirt_tiered}.obj (Y up, metres, like drape).
"""

import argparse
import math
import pathlib

import bpy
from mathutils import Vector
from mathutils.bvhtree import BVHTree

AROUND = 72  # vertices around each ring
CLEARANCE_M = 0.012  # gap to the body in the bind pose (the cloth is ~1.5 mm thick)
WAIST_BELOW_TOP_OF_PELVIS_M = 0.0  # the waistband sits at the top of the pelvis bone
TORSO_BONES = ("pelvis", "spine_01", "spine_02", "thigh_l", "thigh_r", "calf_l", "calf_r")


def load_body(path):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.fbx(filepath=str(path))
    armature = next(o for o in bpy.context.scene.objects if o.type == "ARMATURE")
    body = next(o for o in bpy.context.scene.objects if o.type == "MESH")
    armature.data.pose_position = "REST"
    bpy.context.view_layer.update()
    return armature, body


def torso_tree(body):
    """A BVH of the faces that belong to the torso and legs (not the arms, which
    hang at the sides and must not shape the skirt)."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    mesh = body.evaluated_get(depsgraph).to_mesh()
    world = body.matrix_world
    wanted = {body.vertex_groups[name].index for name in TORSO_BONES if name in body.vertex_groups}
    torso_weight = []
    for v in body.data.vertices:
        torso_weight.append(sum(g.weight for g in v.groups if g.group in wanted))
    vertices = [world @ v.co for v in mesh.vertices]
    polygons = [list(p.vertices) for p in mesh.polygons if all(torso_weight[i] > 0.5 for i in p.vertices)]
    tree = BVHTree.FromPolygons(vertices, polygons)
    full = BVHTree.FromPolygons(vertices, [list(p.vertices) for p in mesh.polygons])
    return tree, full, vertices


def waist_height(armature):
    pelvis = armature.data.bones["pelvis"]
    return (armature.matrix_world @ pelvis.tail_local).z - WAIST_BELOW_TOP_OF_PELVIS_M


def body_radius(tree, centre, z, angle):
    """Distance from the vertical axis through `centre` to the body's outer
    surface at height z in direction `angle` (0 if the ray misses)."""
    direction = Vector((math.sin(angle), -math.cos(angle), 0.0))
    origin = Vector((centre.x, centre.y, z)) + direction * 1.0
    hit, _, _, _ = tree.ray_cast(origin, -direction, 1.0)
    return 0.0 if hit is None else (Vector((hit.x, hit.y)) - Vector((centre.x, centre.y))).length


def skirt_rings(tree, centre, top, length, rows, flare, extra_radius):
    """Ring radii per row and angle: the body's outline, kept no smaller than
    the rows above (the skirt hangs, it does not cling), widened by `flare`
    per metre below the waist."""
    rings = []
    previous = [0.0] * AROUND
    for row in range(rows + 1):
        z = top - length * row / rows
        radii = []
        for k in range(AROUND):
            angle = 2.0 * math.pi * k / AROUND
            outline = body_radius(tree, centre, z, angle)
            radius = max(outline + CLEARANCE_M + extra_radius, previous[k] + flare * length / rows)
            radii.append(radius)
        # Smooth around the ring (the legs' gap makes notches).
        radii = [max(radii[k], 0.5 * (radii[k - 1] + radii[(k + 1) % AROUND])) for k in range(AROUND)]
        rings.append((z, radii))
        previous = radii
    return rings


def clearance(full_tree, rings, centre):
    """Smallest distance from any skirt vertex to the body."""
    smallest = math.inf
    for z, radii in rings:
        for k, r in enumerate(radii):
            angle = 2.0 * math.pi * k / AROUND
            p = Vector((centre.x + r * math.sin(angle), centre.y - r * math.cos(angle), z))
            _, _, _, distance = full_tree.find_nearest(p)
            if distance is not None:
                smallest = min(smallest, distance)
    return smallest


def obj_text(name, tiers, centre, waist_z):
    """One OBJ with an object per tier; Blender (x, y, z) → drape (x, z, −y)."""
    lines = [
        f"# drape demo garment '{name}', made by tools/make_garments.py for assets/bodies/female_walk.fbx",
        f"# waistband: the top ring of each tier, at y = {waist_z:.4f} m (group 'waistband')",
    ]
    base = 0
    uv_base = 0
    for tier, rings in enumerate(tiers):
        lines.append(f"o {name}_tier{tier}" if len(tiers) > 1 else f"o {name}")
        for z, radii in rings:
            for k, r in enumerate(radii):
                angle = 2.0 * math.pi * k / AROUND
                x, y = centre.x + r * math.sin(angle), centre.y - r * math.cos(angle)
                lines.append(f"v {x:.5f} {z:.5f} {-y:.5f}")
        rows = len(rings) - 1
        for row in range(rows + 1):
            for k in range(AROUND + 1):
                lines.append(f"vt {k / AROUND:.5f} {1.0 - row / rows:.5f}")
        for row in range(rows):
            lines.append("g waistband" if row == 0 else f"g body{tier}")
            for k in range(AROUND):
                a = base + row * AROUND + k + 1
                b = base + row * AROUND + (k + 1) % AROUND + 1
                c, d = b + AROUND, a + AROUND
                ta = uv_base + row * (AROUND + 1) + k + 1
                tb, tc, td = ta + 1, ta + 1 + AROUND + 1, ta + AROUND + 1
                # Counter-clockwise seen from outside: normals point away from the body.
                lines.append(f"f {a}/{ta} {d}/{td} {c}/{tc} {b}/{tb}")
        base += len(rings) * AROUND
        uv_base += len(rings) * (AROUND + 1)
    return "\n".join(lines) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--body", default="assets/bodies/female_walk.fbx")
    parser.add_argument("--out", default="assets/garments")
    args = parser.parse_args()
    armature, body = load_body(pathlib.Path(args.body))
    tree, full, vertices = torso_tree(body)
    pelvis = armature.data.bones["pelvis"]
    centre = armature.matrix_world @ pelvis.head_local
    top = waist_height(armature)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    single = skirt_rings(tree, centre, top, length=0.52, rows=30, flare=0.35, extra_radius=0.0)
    tiers = [
        skirt_rings(tree, centre, top, length=0.56, rows=32, flare=0.30, extra_radius=0.0),
        skirt_rings(tree, centre, top - 0.004, length=0.42, rows=24, flare=0.38, extra_radius=0.012),
        skirt_rings(tree, centre, top - 0.008, length=0.28, rows=16, flare=0.46, extra_radius=0.024),
    ]
    for name, parts in (("skirt", [single]), ("skirt_tiered", tiers)):
        gap = min(clearance(full, rings, centre) for rings in parts)
        if gap < 0.005:
            raise SystemExit(f"{name}: only {gap * 1000:.1f} mm from the body; the skirt must clear it by 5 mm")
        path = out / f"{name}.obj"
        path.write_text(obj_text(name, parts, centre, top))
        count = sum(len(r) * AROUND for r in parts)
        print(f"wrote {path}: {count} vertices, {gap * 1000:.1f} mm from the body at the closest")


if __name__ == "__main__":
    main()
