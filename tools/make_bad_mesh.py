#!/usr/bin/env python3
"""Writes assets/garments/bad_mesh.obj: a 0.5 m square cloth (12 x 12 vertices)
with the four defects of the `bad_mesh` scene (SCENES.md):

- a duplicate vertex (a second `v` line at the position of vertex 14, used by one face),
- a zero-area triangle (three collinear vertices of the first row),
- a non-manifold edge (a fin triangle on an interior edge, so three faces share it),
- an isolated vertex (a `v` line no face uses).

drape must load it with a warning for each and simulate it without NaN.
Run from the repository root: python3 tools/make_bad_mesh.py
"""
from pathlib import Path

N, SIZE = 12, 0.5
h = SIZE / (N - 1)
lines = ["# bad_mesh: a deliberately broken garment for robustness tests (tools/make_bad_mesh.py)"]
for row in range(N):
    for col in range(N):
        lines.append(f"v {-SIZE / 2 + col * h:.6f} 0.000000 {-SIZE / 2 + row * h:.6f}")
vid = lambda row, col: row * N + col + 1  # OBJ indices are 1-based
duplicate = N * N + 1
lines.append(f"# duplicate of vertex {vid(1, 1)}, the fin's apex, and an isolated vertex")
lines.append(f"v {-SIZE / 2 + 1 * h:.6f} 0.000000 {-SIZE / 2 + 1 * h:.6f}")
fin_apex = N * N + 2
lines.append(f"v {-SIZE / 2 + 5.5 * h:.6f} {h:.6f} {-SIZE / 2 + 5 * h:.6f}")
lines.append("v 0.9 0.9 0.9")
faces = []
for row in range(N - 1):
    for col in range(N - 1):
        a, b, c, d = vid(row, col), vid(row + 1, col), vid(row + 1, col + 1), vid(row, col + 1)
        faces.append([a, b, c])
        faces.append([a, c, d])
# The duplicate replaces vertex (1,1) in one face: the cloth is one piece only once welded.
faces[2 * (1 * (N - 1) + 1)][0] = duplicate
faces.append([vid(0, 0), vid(0, 1), vid(0, 2)])           # zero area: collinear
faces.append([vid(5, 5), vid(5, 6), fin_apex])            # third face on edge (5,5)-(5,6)
lines += [f"f {' '.join(map(str, f))}" for f in faces]
Path("assets/garments/bad_mesh.obj").write_text("\n".join(lines) + "\n")
