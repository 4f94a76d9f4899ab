#!/usr/bin/env python3
"""Reads drape's exports back with independent readers and compares them
with the bake they came from: prints one JSON object, which
tests/exports.rs asserts on.

    check_export.py usd  BAKE_DIR FILE.usda GARMENT
    check_export.py gltf BAKE_DIR FILE.glb GARMENT
    check_export.py mdd  BAKE_DIR FILE.mdd GARMENT

The bake's own files are the reference: GARMENT.pc2 (every frame's
positions) and frame_0000.obj (the garment's faces and UVs). USD is read
with Pixar's usd-core and validated with its UsdValidation framework; glTF
with pygltflib (the Khronos validator runs separately); MDD with struct.
"""

import json
import struct
import sys
from pathlib import Path

import numpy as np


def read_pc2(path):
    data = Path(path).read_bytes()
    _version, points, _start, _rate, samples = struct.unpack_from("<iiffi", data, 12)
    return np.frombuffer(data, "<f4", offset=32).reshape(samples, points, 3)


def read_obj(path, garment):
    """The garment object's faces (v, vt per corner, 0-based within the object) and UV count."""
    faces, uv_count, inside = [], 0, False
    v_base = vt_base = 0
    v_seen = vt_seen = 0
    for line in Path(path).read_text().splitlines():
        tag, _, rest = line.partition(" ")
        if tag == "o":
            if inside:
                break
            inside = rest.strip() == garment
            v_base, vt_base = v_seen, vt_seen
        elif tag == "v":
            v_seen += 1
        elif tag == "vt":
            vt_seen += 1
            uv_count += inside
        elif tag == "f" and inside:
            corners = []
            for corner in rest.split():
                fields = corner.split("/")
                vt = int(fields[1]) - 1 - vt_base if len(fields) > 1 and fields[1] else -1
                corners.append((int(fields[0]) - 1 - v_base, vt))
            faces.append(corners)
    return faces, uv_count


def check_usd(bake, file, garment):
    from pxr import Usd, UsdGeom, UsdValidation

    stage = Usd.Stage.Open(str(file))
    validators = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
    issues = [e for e in UsdValidation.ValidationContext(validators).Validate(stage) if not e.HasNoError()]
    errors = [f"{e.GetIdentifier()}: {e.GetMessage()}" for e in issues]
    meshes = {p.GetName(): UsdGeom.Mesh(p) for p in stage.Traverse() if p.IsA(UsdGeom.Mesh)}
    mesh = meshes[garment]
    cache = read_pc2(Path(bake) / f"{garment}.pc2")
    faces, uv_count = read_obj(Path(bake) / "frame_0000.obj", garment)
    points = mesh.GetPointsAttr()
    times = points.GetTimeSamples()
    worst = 0.0
    extent_off = 0.0
    for t in times:
        ours = np.array(points.Get(t), dtype=np.float32)
        worst = max(worst, float(np.abs(ours - cache[int(t)]).max()))
        computed = UsdGeom.Boundable.ComputeExtentFromPlugins(mesh, t)
        authored = np.array(mesh.GetExtentAttr().Get(t), dtype=np.float64)
        extent_off = max(extent_off, float(np.abs(np.array(computed, dtype=np.float64) - authored).max()))
    st = UsdGeom.PrimvarsAPI(mesh).GetPrimvar("st")
    counts = list(mesh.GetFaceVertexCountsAttr().Get())
    indices = list(mesh.GetFaceVertexIndicesAttr().Get())
    obj_indices = [v for f in faces for v, _ in f]
    body = {n: m for n, m in meshes.items() if m.GetPrim().GetParent().GetName() == "body"}
    body_moves = 0.0
    for m in body.values():
        samples = m.GetPointsAttr().GetTimeSamples()
        a = np.array(m.GetPointsAttr().Get(samples[0]))
        b = np.array(m.GetPointsAttr().Get(samples[-1]))
        body_moves = max(body_moves, float(np.linalg.norm(a - b, axis=1).max()))
    return {
        "errors": errors,
        "up_axis": UsdGeom.GetStageUpAxis(stage),
        "meters_per_unit": UsdGeom.GetStageMetersPerUnit(stage),
        "time_codes_per_second": stage.GetTimeCodesPerSecond(),
        "start": stage.GetStartTimeCode(),
        "end": stage.GetEndTimeCode(),
        "time_samples": len(times),
        "frames": int(cache.shape[0]),
        "largest_difference_m": worst,
        "extent_difference_m": extent_off,
        "faces": len(counts),
        "obj_faces": len(faces),
        "same_corners": indices == obj_indices,
        "uvs": len(st.Get()) if st else 0,
        "uv_indices_match": st.IsIndexed() and list(st.GetIndices()) == [vt for f in faces for _, vt in f],
        "obj_uvs": uv_count,
        "interpolation": st.GetInterpolation() if st else "",
        "body_meshes": sorted(body),
        "body_moves_m": body_moves,
        "meshes": sorted(meshes),
    }


def read_accessor(gltf, blob, index):
    import pygltflib  # noqa: F401 (the caller imported it)

    dtype = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
    ncomp = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}
    acc = gltf.accessors[index]
    dt = np.dtype(dtype[acc.componentType]).newbyteorder("<")
    n = ncomp[acc.type]
    if acc.sparse is not None:
        out = np.zeros((acc.count, n), dtype=np.float64)
        s = acc.sparse
        iv, vv = gltf.bufferViews[s.indices.bufferView], gltf.bufferViews[s.values.bufferView]
        idx = np.frombuffer(blob, np.dtype(dtype[s.indices.componentType]).newbyteorder("<"), s.count, (iv.byteOffset or 0) + (s.indices.byteOffset or 0))
        val = np.frombuffer(blob, dt, s.count * n, (vv.byteOffset or 0) + (s.values.byteOffset or 0)).reshape(s.count, n)
        out[idx] = val
        return out
    bv = gltf.bufferViews[acc.bufferView]
    elem = dt.itemsize * n
    stride = bv.byteStride or elem
    start = (bv.byteOffset or 0) + (acc.byteOffset or 0)
    rows = [np.frombuffer(blob, dt, n, start + i * stride) for i in range(acc.count)]
    out = np.stack(rows).astype(np.float64)
    if acc.normalized:
        out = np.maximum(out / np.iinfo(dt).max, -1.0)
    return out


def check_gltf(bake, file, garment):
    import pygltflib

    gltf = pygltflib.GLTF2().load(str(file))
    blob = gltf.binary_blob()
    node = next(n for n in gltf.nodes if n.name == garment)
    mesh = gltf.meshes[node.mesh]
    prim = mesh.primitives[0]
    scale = np.array(node.scale or [1, 1, 1], dtype=np.float64)
    offset = np.array(node.translation or [0, 0, 0], dtype=np.float64)
    base = read_accessor(gltf, blob, prim.attributes.POSITION) * scale + offset
    cache = read_pc2(Path(bake) / f"{garment}.pc2")
    faces, _ = read_obj(Path(bake) / "frame_0000.obj", garment)
    # drape splits vertices at UV seams in the order the faces first use them.
    order, seen = [], set()
    for face in faces:
        for corner in face:
            if corner not in seen:
                seen.add(corner)
                order.append(corner[0])
    welded = read_accessor(gltf, blob, getattr(prim.attributes, "_DRAPE_VERTEX"))[:, 0].astype(np.int64)
    names = (mesh.extras or {}).get("targetNames", [])
    frames = [0] + [int(n.split("_")[1]) for n in names]
    worst = float(np.abs(base - cache[frames[0]][order]).max())
    for target, frame in zip(prim.targets or [], frames[1:]):
        shape = base + read_accessor(gltf, blob, target["POSITION"]) * scale
        worst = max(worst, float(np.abs(shape - cache[frame][order]).max()))
    animation = gltf.animations[0] if gltf.animations else None
    sampler = next(
        (animation.samplers[c.sampler] for c in animation.channels if c.target.node == gltf.nodes.index(node)), None
    ) if animation else None
    weights_ok = False
    if sampler is not None:
        times = read_accessor(gltf, blob, sampler.input)[:, 0]
        weights = read_accessor(gltf, blob, sampler.output).reshape(len(times), -1)
        fps = 1.0 / times[1] if len(times) > 1 else 0
        expected = np.zeros_like(weights)
        for k in range(1, len(times)):
            expected[k, k - 1] = 1.0
        weights_ok = bool(np.array_equal(weights, expected)) and sampler.interpolation == "LINEAR"
    material = gltf.materials[prim.material]
    return {
        "vertices": int(base.shape[0]),
        "targets": len(prim.targets or []),
        "frames": frames,
        "largest_difference_m": worst,
        "weights_one_hot": weights_ok,
        "vertex_map_matches_the_obj": bool(np.array_equal(welded, np.array(order))),
        "sheen": "KHR_materials_sheen" in (material.extensions or {}),
        "nodes": [n.name for n in gltf.nodes],
        "extensions_required": gltf.extensionsRequired or [],
    }


def check_mdd(bake, file, garment):
    data = Path(file).read_bytes()
    frames, points = struct.unpack_from(">2i", data, 0)
    times = struct.unpack_from(f">{frames}f", data, 8)
    positions = np.frombuffer(data, ">f4", offset=8 + 4 * frames).reshape(frames, points, 3)
    cache = read_pc2(Path(bake) / f"{garment}.pc2")
    return {
        "frames": frames,
        "points": points,
        "size_bytes": len(data),
        "first_times": list(times[:3]),
        "equal_to_pc2": bool(np.array_equal(positions, cache)),
    }


if __name__ == "__main__":
    kind, bake, file, garment = sys.argv[1:5]
    check = {"usd": check_usd, "gltf": check_gltf, "mdd": check_mdd}[kind]
    print(json.dumps(check(bake, file, garment)))
