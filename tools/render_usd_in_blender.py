#!/usr/bin/env python3
"""Renders a frame of a USD file with Blender's own USD importer and Cycles
(on the CPU, headless): the README's picture of a drape export opened in
another application.

    pip install bpy==5.0.1      # Blender 5.0.1 as a Python module (Python 3.11)
    drape export out/skirt_walk --format usd
    python3 tools/render_usd_in_blender.py out/skirt_walk/skirt_walk.usda 60 assets/renders/usd_in_blender.png

Blender imports the time-sampled meshes as Mesh Sequence Cache modifiers (a
time code per frame) and the UsdPreviewSurface materials as Principled BSDFs;
the camera frames every mesh but the ground.
"""

import math
import sys

import bpy
from mathutils import Vector


def main(path, frame, out):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.usd_import(filepath=path)
    scene = bpy.context.scene
    scene.render.fps = 30  # Blender does not take the frame rate from the file
    scene.frame_set(frame)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    meshes = [o for o in scene.objects if o.type == "MESH"]
    cached = [o for o in meshes if any(m.type == "MESH_SEQUENCE_CACHE" for m in o.modifiers)]
    print(f"{len(meshes)} meshes, {len(cached)} animated: {sorted(o.name for o in cached)}")
    corners = [o.evaluated_get(depsgraph).matrix_world @ Vector(c) for o in cached for c in o.evaluated_get(depsgraph).bound_box]
    low = Vector((min(c.x for c in corners), min(c.y for c in corners), min(c.z for c in corners)))
    high = Vector((max(c.x for c in corners), max(c.y for c in corners), max(c.z for c in corners)))
    centre, size = (low + high) / 2, (high - low).length
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    scene.collection.objects.link(camera)
    scene.camera = camera
    camera.location = centre + Vector((0.9, -2.2, 0.3)).normalized() * size * 1.9
    camera.rotation_euler = (centre - camera.location).to_track_quat("-Z", "Y").to_euler()
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    sun.data.energy = 3.5
    sun.rotation_euler = (math.radians(45), 0, math.radians(35))
    scene.collection.objects.link(sun)
    scene.world = scene.world or bpy.data.worlds.new("world")
    scene.world.color = (0.35, 0.37, 0.4)
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 32
    scene.render.resolution_x, scene.render.resolution_y = 960, 720
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = out
    bpy.ops.render.render(write_still=True)


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), sys.argv[3])
