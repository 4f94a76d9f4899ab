#!/usr/bin/env python3
"""Writes the mesh colliders of the hard cases into assets/colliders/:

funnel.obj  a funnel, axis Y, open at both ends: rim radius 0.35 m at
            y = 0.35, a straight cone down to a neck of radius 0.07 m at
            y = 0, then a spout of that radius down to y = -0.15; 96
            segments around, quads split into triangles, normals outward.

Usage: python3 tools/make_colliders.py [OUT_DIR]
"""
import math
import sys
from pathlib import Path

SEGMENTS = 96
# (radius, height) of each ring, top to bottom, m.
PROFILE = [(0.35, 0.35), (0.28, 0.28), (0.21, 0.21), (0.14, 0.14), (0.07, 0.0),
           (0.07, -0.05), (0.07, -0.10), (0.07, -0.15)]


def funnel():
    vertices, faces = [], []
    for radius, y in PROFILE:
        for k in range(SEGMENTS):
            a = 2 * math.pi * k / SEGMENTS
            vertices.append((radius * math.cos(a), y, radius * math.sin(a)))
    for ring in range(len(PROFILE) - 1):
        for k in range(SEGMENTS):
            a, b = ring * SEGMENTS + k, ring * SEGMENTS + (k + 1) % SEGMENTS
            c, d = a + SEGMENTS, b + SEGMENTS
            # Counter-clockwise seen from outside (normals away from the axis).
            faces += [(a, b, c), (b, d, c)]
    return vertices, faces


def write_obj(path, vertices, faces, comment):
    lines = [f"# {comment}"]
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")


def main():
    out = Path(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).resolve().parent.parent / "assets" / "colliders")
    out.mkdir(parents=True, exist_ok=True)
    write_obj(out / "funnel.obj", *funnel(), "funnel: rim r 0.35 m at y 0.35, neck r 0.07 m at y 0, spout to y -0.15 (tools/make_colliders.py)")


main()
