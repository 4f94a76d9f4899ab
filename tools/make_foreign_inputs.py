#!/usr/bin/env python3
"""Writes tests/fixtures/foreign/: small garments and bodies that imitate the
habits of other programs' exporters (issue 9, "Inputs from other programs"),
with the numbers a loader must find in them (expected.toml, README.md).

OBJ garments are written as text here; FBX bodies are built and exported by
Blender used as a Python module, and one of them is rewritten here as FBX 7.5
(64-bit node headers), which Blender does not write.

Set up once, then run from the repository root:

    pip install bpy==5.0.1              # Blender 5.0.1 as a Python module (Python 3.11)
    python3 tools/make_foreign_inputs.py

Every number written to expected.toml is measured: the OBJ numbers by reading
the written files back with an independent reader here (BOM and comments
stripped, relative indices resolved, identical positions welded, polygons
fanned), the FBX numbers by parsing the written binary FBX here and, for the
bounding boxes, from Blender's own evaluation of the body.
"""

import argparse
import math
import os
import pathlib
import struct
import sys
import tempfile
import zlib

OUT = pathlib.Path("tests/fixtures/foreign")
FPS = 30
FRAME_START, FRAME_END = 1, 10  # ten frames
SPINE_TURN_DEG = 30.0  # Spine turns about its X axis from frame 1 to frame 10

# ---------------------------------------------------------------------------
# OBJ garments
# ---------------------------------------------------------------------------


def grid(cols, rows, corner, step_u, step_v):
    """Positions of a (cols+1) x (rows+1) grid, row by row: corner + i*step_u + j*step_v."""
    return [
        tuple(corner[k] + i * step_u[k] + j * step_v[k] for k in range(3))
        for j in range(rows + 1)
        for i in range(cols + 1)
    ]


def grid_quads(cols, rows, first=1, flip=False):
    """Quads (1-based, from `first`) of a grid, counter-clockwise seen from the
    side step_u x step_v points to (clockwise when `flip`), row by row."""
    at = lambda i, j: first + j * (cols + 1) + i
    quads = []
    for j in range(rows):
        for i in range(cols):
            q = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]
            quads.append(q[::-1] if flip else q)
    return quads


def fmt(values, digits=6, sep=" "):
    return sep.join(f"{v:.{digits}f}" for v in values)


def maya_quads_crlf():
    """Maya (Windows): CRLF, `g default` before the vertices, one group per
    face set, quads with v/vt/vn, an MTL with a shading-group material whose
    texture lives in sourceimages/ (not shipped)."""
    pos = grid(4, 4, (-0.2, 1.0, 0.0), (0.1, 0.0, 0.0), (0.0, 0.1, 0.0))
    uvs = [(i / 4, j / 4) for j in range(5) for i in range(5)]
    quads = grid_quads(4, 4)
    lines = [
        "# This file uses meters as units for non-parametric coordinates.",
        "",
        "mtllib maya_quads_crlf.mtl",
        "g default",
    ]
    lines += [f"v {fmt(p)}" for p in pos]
    lines += [f"vt {fmt(t)}" for t in uvs]
    lines += ["vn 0.000000 0.000000 1.000000"] * len(pos)
    lines.append("s off")
    for name, rows in (("front_top", range(8, 16)), ("front_bottom", range(0, 8))):
        lines += [f"g {name}", "usemtl cotton_redSG"]
        lines += ["f " + " ".join(f"{v}/{v}/{v}" for v in quads[q]) for q in rows]
    obj = "\r\n".join(lines) + "\r\n"
    mtl = "\r\n".join([
        "newmtl cotton_redSG",
        "illum 4",
        "Kd 0.80 0.10 0.10",
        "Ka 0.00 0.00 0.00",
        "Tf 1.00 1.00 1.00",
        "map_Kd sourceimages/cotton_red.png",
        "Ni 1.00",
    ]) + "\r\n"
    return obj.encode(), {"maya_quads_crlf.mtl": mtl.encode()}, {
        "imitates": "Maya on Windows: CRLF line ends, `g default` then one `g` group per face set, "
                    "quads with v/vt/vn, MTL shading group with a map_Kd texture that is not shipped",
        "units": "m",
        "design": (25, 32, [-0.2, 1.0, 0.0], [0.2, 1.4, 0.0]),  # welded vertices, triangles, bbox
        "parts": ["front_top", "front_bottom"],
        "materials": ["cotton_redSG"],
        "material_diffuse": [[0.8, 0.1, 0.1]],
        "material_texture": ["sourceimages/cotton_red.png"],
    }


def max_multi_object():
    """3ds Max (guruware exporter): header comment, per-object comment blocks
    and counts, double space after `v`, three-component `vt`, smoothing groups,
    absolute indices running across objects, centimetres."""
    front = grid(4, 4, (-20.0, 100.0, 5.0), (10.0, 0.0, 0.0), (0.0, 10.0, 0.0))
    back = grid(4, 4, (-20.0, 100.0, -5.0), (10.0, 0.0, 0.0), (0.0, 10.0, 0.0))
    uvs = [(i / 4, j / 4) for j in range(5) for i in range(5)]
    lines = [
        "# 3ds Max Wavefront OBJ Exporter v0.97b - (c)2007 guruware",
        "# File Created: 14.03.2024 09:12:44",
        "",
    ]
    first = 1
    for name, pos, normal, smoothing, flip in (
        ("front_panel", front, (0.0, 0.0, 1.0), 1, False),
        ("back_panel", back, (0.0, 0.0, -1.0), 2, True),
    ):
        lines += ["#", f"# object {name}", "#", "", f"o {name}"]
        lines += [f"v  {fmt(p, 4)}" for p in pos]
        lines += [f"# {len(pos)} vertices", ""]
        lines += [f"vn {fmt(normal, 4)}"] * len(pos)
        lines += [f"# {len(pos)} vertex normals", ""]
        lines += [f"vt {fmt((u, v, 0.0), 4)}" for u, v in uvs]
        lines += [f"# {len(uvs)} texture coords", "", f"s {smoothing}"]
        quads = grid_quads(4, 4, first, flip)
        lines += ["f " + " ".join(f"{v}/{v}/{v}" for v in q) + " " for q in quads]
        lines += [f"# {len(quads)} polygons", ""]
        first += len(pos)
    return ("\n".join(lines) + "\n").encode(), {}, {
        "imitates": "3ds Max (guruware OBJ exporter): two `o` objects (front and back panel), `s` smoothing "
                    "groups, `v` with two spaces, 3-component `vt`, count comments, centimetres "
                    "(a scene needs scale = 0.01)",
        "units": "cm",
        "design": (50, 64, [-20.0, 100.0, -5.0], [20.0, 140.0, 5.0]),  # welded vertices, triangles, bbox
        "parts": ["front_panel", "back_panel"],
        "materials": [],
    }


def md_ngons_negative():
    """Marvelous Designer: n-gons, relative (negative) indices, one group per
    pattern piece, the pieces' own copies of the vertices on the seam between
    them (same position, other `vt`: a UV seam)."""
    r, h = 0.1, 0.15
    w = math.sqrt(3.0) * r
    x0, y0 = -w, 1.3
    hexes, yoke = [], []  # yoke: positions of the hexagon row

    def yoke_vertex(p):
        key = (round(p[0], 9), round(p[1], 9))
        for k, q in enumerate(yoke):
            if (round(q[0], 9), round(q[1], 9)) == key:
                return k
        yoke.append(p)
        return len(yoke) - 1

    for i in range(3):
        cx = x0 + i * w
        corners = [(cx + r * math.cos(math.radians(30 + 60 * k)), y0 + r * math.sin(math.radians(30 + 60 * k)))
                   for k in range(6)]
        hexes.append([yoke_vertex(c) for c in corners])
    # The hem: below each hexagon a pentagon [B, BL, LL, LR, BR] (fanned from
    # B, the notch, so every fan triangle has area); B, BL, BR are the hem's own
    # copies of the hexagons' lower corners.
    hem, pentagons = [], []

    def hem_vertex(p):
        key = (round(p[0], 9), round(p[1], 9))
        for k, q in enumerate(hem):
            if (round(q[0], 9), round(q[1], 9)) == key:
                return k
        hem.append(p)
        return len(hem) - 1

    for i in range(3):
        cx = x0 + i * w
        b, bl, br = (cx, y0 - r), (cx - w / 2, y0 - r / 2), (cx + w / 2, y0 - r / 2)
        ll, lr = (cx - w / 2, y0 - r / 2 - h), (cx + w / 2, y0 - r / 2 - h)
        pentagons.append([hem_vertex(p) for p in (b, bl, ll, lr, br)])
    xmin = min(p[0] for p in yoke + hem)
    ymin_yoke = min(p[1] for p in yoke)
    ymin_hem = min(p[1] for p in hem)
    lines = [
        "# Created by Marvelous Designer",
        "# Object: Dress_Sample  (2 patterns)",
    ]
    lines.append("g Yoke")
    lines += [f"v {x:.6f} {y:.6f} 0.000000" for x, y in yoke]
    lines += [f"vt {x - xmin + 0.05:.6f} {y - ymin_yoke + 0.55:.6f}" for x, y in yoke]
    n = len(yoke)
    lines += ["f " + " ".join(f"{k - n}/{k - n}" for k in poly) for poly in hexes]
    lines.append("g Hem")
    lines += [f"v {x:.6f} {y:.6f} 0.000000" for x, y in hem]
    lines += [f"vt {x - xmin + 0.05:.6f} {y - ymin_hem + 0.05:.6f}" for x, y in hem]
    n = len(hem)
    lines += ["f " + " ".join(f"{k - n}/{k - n}" for k in poly) for poly in pentagons]
    # printf's habit: a coordinate a hair below zero is written -0.000000; its
    # copy in the other piece is 0.000000, and the two must weld.
    assert "v -0.000000 1.200000 0.000000" in lines and "v 0.000000 1.200000 0.000000" in lines
    return ("\n".join(lines) + "\n").encode(), {}, {
        "imitates": "Marvelous Designer: hexagons and pentagons, relative (negative) v/vt indices, one `g` per "
                    "pattern piece, each piece with its own copies of the seam vertices (identical positions, "
                    "other UVs; one written -0.000000 in one piece and 0.000000 in the other) that must be welded",
        "units": "m",
        "design": (18, 3 * 4 + 3 * 3, [-0.259808, 1.1, 0.0], [0.259808, 1.4, 0.0]),  # welded vertices, triangles, bbox
        "parts": ["Yoke", "Hem"],
        "materials": [],
    }


def no_normals_no_uvs():
    """Bare geometry: `v` and `f a b c` only (a horizontal square, triangles with alternating diagonals)."""
    pos = grid(4, 4, (-0.2, 0.8, -0.2), (0.1, 0.0, 0.0), (0.0, 0.0, 0.1))
    tris = []
    for q, (a, b, c, d) in enumerate(grid_quads(4, 4, flip=True)):
        tris += [(a, b, c), (a, c, d)] if q % 2 == 0 else [(b, c, d), (b, d, a)]
    lines = ["# Blender 4.2.0", "# www.blender.org", "o Cloth"]
    lines += [f"v {fmt(p)}" for p in pos]
    lines += [f"f {a} {b} {c}" for a, b, c in tris]
    return ("\n".join(lines) + "\n").encode(), {}, {
        "imitates": "a bare export (normals and UVs switched off): `v` and triangle `f a b c` only",
        "units": "m",
        "design": (25, 32, [-0.2, 0.8, -0.2], [0.2, 0.8, 0.2]),  # welded vertices, triangles, bbox
        "parts": ["Cloth"],
        "materials": [],
    }


def unicode_names():
    """Non-ASCII object, group and material names; a UTF-8 BOM (Windows
    Notepad) directly before the first statement, `mtllib`."""
    pos = grid(4, 4, (0.0, 0.9, 0.05), (0.1, 0.0, 0.0), (0.0, 0.1, 0.0))
    uvs = [(i / 4, j / 4) for j in range(5) for i in range(5)]
    quads = grid_quads(4, 4)
    lines = ["mtllib unicode_names.mtl", "o Röck_袖"]
    lines += [f"v {fmt(p)}" for p in pos]
    lines += [f"vt {fmt(t)}" for t in uvs]
    for name, material, cols in (("Ärmel_links", "Seide_絹", (0, 1)), ("袖_右", "Baumwolle_綿", (2, 3))):
        lines += [f"g {name}", f"usemtl {material}"]
        lines += ["f " + " ".join(f"{v}/{v}" for v in q) for k, q in enumerate(quads) if k % 4 in cols]
    obj = "\ufeff" + "\n".join(lines) + "\n"
    mtl = ("# Seide = silk, Baumwolle = cotton\n"
           "newmtl Seide_絹\nKd 0.90 0.85 0.70\n\nnewmtl Baumwolle_綿\nKd 0.20 0.30 0.60\n")
    return obj.encode("utf-8"), {"unicode_names.mtl": mtl.encode("utf-8")}, {
        "imitates": "a file saved by Windows Notepad: UTF-8 BOM right before the first line (`mtllib`), "
                    "non-ASCII object, group and material names",
        "units": "m",
        "design": (25, 32, [0.0, 0.9, 0.05], [0.4, 1.3, 0.05]),  # welded vertices, triangles, bbox
        "parts": ["Ärmel_links", "袖_右"],
        "materials": ["Seide_絹", "Baumwolle_綿"],
        "material_diffuse": [[0.9, 0.85, 0.7], [0.2, 0.3, 0.6]],
    }


def tabs_and_comments():
    """Hand-edited text: tabs between tokens, indented lines, trailing
    whitespace, whitespace-only lines, comments after `v`/`vt` data. (No `\\`
    line continuation: tobj 4 reads every line on its own. No comment after an
    `f` line and no tab after `usemtl`: tobj rejects both, see README.md.)"""
    pos = grid(3, 3, (-0.15, 1.0, 0.0), (0.1, 0.0, 0.0), (0.0, 0.1, 0.0))
    uvs = [(i / 3, j / 3) for j in range(4) for i in range(4)]
    lines = ["# tabs_and_comments: a hand-edited panel", "\t# an indented comment", "o\tTabbed_Panel\t "]
    for k, p in enumerate(pos):
        sep = "\t" if k % 2 == 0 else " \t "
        tail = "\t# corner" if k in (0, 3, 12, 15) else ("  \t" if k % 3 == 0 else "")
        lead = "\t" if k % 4 == 1 else ""
        lines.append(f"{lead}v{sep}{fmt(p, sep=sep)}{tail}")
    lines.append("   \t  ")
    for k, t in enumerate(uvs):
        lines.append(f"vt\t{fmt(t, sep=chr(9))}" + ("\t# uv" if k == 0 else ""))
    lines.append("")
    for q in grid_quads(3, 3):
        lines.append("f\t" + "\t".join(f"{v}/{v}" for v in q) + "\t ")
    return ("\n".join(lines) + "\n").encode(), {}, {
        "imitates": "a hand-edited file: tabs between tokens, indented lines, trailing whitespace, "
                    "whitespace-only lines, comments after `v` and `vt` data",
        "units": "m",
        "design": (16, 18, [-0.15, 1.0, 0.0], [0.15, 1.3, 0.0]),  # welded vertices, triangles, bbox
        "parts": ["Tabbed_Panel"],
        "materials": [],
    }


OBJ_MAKERS = (maya_quads_crlf, max_multi_object, md_ngons_negative, no_normals_no_uvs, unicode_names,
              tabs_and_comments)


def read_obj_reference(data):
    """What a loader should make of an OBJ: BOM dropped, CRLF and comments
    handled, relative indices resolved, identical positions welded, polygons
    fanned from their first corner. Returns the measured numbers."""
    text = data.decode("utf-8")
    bom = text.startswith("\ufeff")
    text = text.removeprefix("\ufeff")
    positions, uv_count, faces, parts = [], 0, [], []
    current = None
    for raw in text.splitlines():
        tokens = raw.split("#", 1)[0].split()
        if not tokens:
            continue
        tag, args = tokens[0], tokens[1:]
        if tag == "v":
            positions.append(tuple(float(a) for a in args[:3]))
        elif tag == "vt":
            uv_count += 1
        elif tag in ("o", "g"):
            current = " ".join(args)
        elif tag == "f":
            corners = []
            for a in args:
                i = int(a.split("/")[0])
                corners.append(i - 1 if i > 0 else len(positions) + i)
            faces.append(corners)
            if not parts or parts[-1] != current:
                parts.append(current)
    weld = {}
    index = [weld.setdefault(p, len(weld)) for p in positions]
    used = {index[c] for f in faces for c in f}
    assert len(used) == len(weld), "a vertex no face uses"
    triangles = []
    for f in faces:
        triangles += [(index[f[0]], index[f[k]], index[f[k + 1]]) for k in range(1, len(f) - 1)]
    welded = list(weld)
    for a, b, c in triangles:  # every fan triangle has area: nothing is dropped as degenerate
        u = [welded[b][k] - welded[a][k] for k in range(3)]
        v = [welded[c][k] - welded[a][k] for k in range(3)]
        n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
        assert math.sqrt(sum(x * x for x in n)) > 1e-9 * max(sum(x * x for x in u), 1e-30), "degenerate triangle"
    points = [welded[i] for i in sorted(used)]
    return {
        "bom": bom,
        "crlf": b"\r\n" in data,
        "v_lines": len(positions),
        "vertices": len(used),
        "duplicate_positions": len(positions) - len(weld),
        "uvs": uv_count,
        "polygons": len(faces),
        "quads": sum(len(f) == 4 for f in faces),
        "largest_polygon": max(len(f) for f in faces),
        "triangles": len(triangles),
        "parts_read": parts,
        "bbox_min": [min(p[k] for p in points) for k in range(3)],
        "bbox_max": [max(p[k] for p in points) for k in range(3)],
    }


def write_objs(out):
    records = {}
    for make in OBJ_MAKERS:
        data, extras, meta = make()
        name = make.__name__
        (out / f"{name}.obj").write_bytes(data)
        for extra, content in extras.items():
            (out / extra).write_bytes(content)
        measured = read_obj_reference(data)
        assert measured["parts_read"] == meta["parts"], (name, measured["parts_read"])
        del measured["parts_read"]
        vertices, triangles, low, high = meta.pop("design")
        assert (measured["vertices"], measured["triangles"]) == (vertices, triangles), (name, measured)
        assert measured["bbox_min"] == low and measured["bbox_max"] == high, (name, measured)
        records[name] = {"file": f"{name}.obj", "kind": "garment", **meta, **measured}
        for extra in extras:
            records[name]["mtl"] = extra
    return records


# ---------------------------------------------------------------------------
# Binary FBX: reading, and rewriting 7.4 as 7.5
# ---------------------------------------------------------------------------

FBX_MAGIC = b"Kaydara FBX Binary  \x00\x1a\x00"
# The last 16 bytes of every binary FBX file.
FBX_FOOTER_MAGIC = bytes.fromhex("f85a8c6adef5d97eece90ce3758f290b")


class Node:
    __slots__ = ("name", "prop_count", "props", "children", "null_record")

    def __init__(self, name, prop_count, props, children, null_record):
        self.name, self.prop_count, self.props = name, prop_count, props
        self.children, self.null_record = children, null_record

    def child(self, name):
        return next((c for c in self.children if c.name == name), None)


def header_layout(version):
    """(struct format, size) of a node record header: 32-bit fields before 7.5, 64-bit from 7.5."""
    return ("<3Q", 24) if version >= 7500 else ("<3I", 12)


def read_node(data, pos, version):
    layout, size = header_layout(version)
    end, prop_count, props_len = struct.unpack_from(layout, data, pos)
    name_len = data[pos + size]
    pos += size + 1
    if end == 0 and prop_count == 0 and props_len == 0 and name_len == 0:
        return None, pos  # a null record: the end of a nested list
    name = data[pos:pos + name_len].decode()
    pos += name_len
    props = data[pos:pos + props_len]
    pos += props_len
    children, null_record = [], False
    if pos < end:  # a nested list, closed by a null record
        while True:
            child, pos = read_node(data, pos, version)
            if child is None:
                null_record = True
                break
            children.append(child)
    if pos != end:
        raise ValueError(f"node {name}: ends at {pos}, its header says {end}")
    return Node(name, prop_count, props, children, null_record), pos


def read_fbx(data):
    """(version, top-level nodes, offset of the footer) of a binary FBX file."""
    if data[:23] != FBX_MAGIC:
        raise ValueError("not a binary FBX file")
    version = struct.unpack_from("<I", data, 23)[0]
    pos, nodes = 27, []
    while True:
        node, pos = read_node(data, pos, version)
        if node is None:
            return version, nodes, pos
        nodes.append(node)


def node_bytes(node, start, version):
    layout, size = header_layout(version)
    body = bytearray()
    offset = start + size + 1 + len(node.name) + len(node.props)
    for child in node.children:
        b = node_bytes(child, offset, version)
        body += b
        offset += len(b)
    if node.null_record or node.children:
        body += bytes(size + 1)
    end = start + size + 1 + len(node.name) + len(node.props) + len(body)
    return struct.pack(layout, end, node.prop_count, len(node.props)) + bytes((len(node.name),)) \
        + node.name.encode() + node.props + body


def footer_bytes(position, footer_id, version):
    """The footer as fbxcel reads and writes it (fbxcel 0.9 src/low/v7400/fbx_footer.rs):
    a 16-byte id, zeros up to a multiple of 16 from the file start, 4 zero
    bytes, the version (same as the header's), 120 zeros, the fixed magic."""
    padding = (-(position + 16)) & 0x0F
    return footer_id + bytes(padding) + bytes(4) + struct.pack("<I", version) + bytes(120) + FBX_FOOTER_MAGIC


def fbx_without_footer(version, nodes):
    out = bytearray(FBX_MAGIC + struct.pack("<I", version))
    for node in nodes:
        out += node_bytes(node, len(out), version)
    out += bytes(header_layout(version)[1] + 1)  # the top-level null record
    return bytes(out)


def write_fbx(version, nodes, footer_id):
    out = fbx_without_footer(version, nodes)
    return out + footer_bytes(len(out), footer_id, version)


# Blender writes the export time in FBXHeaderExtension/CreationTimeStamp; a
# fixed one keeps the committed files the same from run to run.
FIXED_TIMESTAMP = {"Year": 2024, "Month": 1, "Day": 1, "Hour": 0, "Minute": 0, "Second": 0, "Millisecond": 0}


def fix_timestamp(data):
    version, nodes, footer_at = read_fbx(data)
    stamp = next(n for n in nodes if n.name == "FBXHeaderExtension").child("CreationTimeStamp")
    for field in stamp.children:
        if field.name in FIXED_TIMESTAMP:
            assert field.props[:1] == b"I"
            field.props = b"I" + struct.pack("<i", FIXED_TIMESTAMP[field.name])
    body = fbx_without_footer(version, nodes)
    assert len(body) == footer_at and body[:27] == data[:27]
    return body + data[footer_at:]


def check_footer_as_fbxcel(data, position, version):
    """fbxcel's footer checks, as errors (a footer fbxcel-dom would only warn about is rejected here too)."""
    id_nibbles = bytes.fromhex("f0b0a000d0c0d060b070f08010f02070")
    footer_id = data[position:position + 16]
    assert all(b & 0xF0 == e for b, e in zip(footer_id, id_nibbles)), "footer id"
    buf = data[position + 16:position + 16 + 144]
    first = next(k for k in range(128, 144) if buf[k] != 0)
    padding = first & 0x0F
    assert padding == (-(position + 16)) & 0x0F, "footer padding"
    assert buf[:padding + 4] == bytes(padding + 4), "footer zeros"
    assert struct.unpack_from("<I", buf, padding + 4)[0] == version, "footer version"
    assert buf[padding + 8:padding + 128] == bytes(120), "footer 120 zeros"
    assert data[position + 16 + padding + 128:] == FBX_FOOTER_MAGIC, "footer magic"


def convert_7400_to_7500(data):
    """Rewrites a binary FBX 7.4 file as 7.5: 64-bit node record headers,
    25-byte null records, the version 7500 in the header, in
    FBXHeaderExtension/FBXVersion and in the footer. Property bytes are kept
    as they are (compressed arrays stay compressed)."""
    version, nodes, footer_at = read_fbx(data)
    assert version == 7400, version
    header_ext = next(n for n in nodes if n.name == "FBXHeaderExtension")
    fbx_version = header_ext.child("FBXVersion")
    assert fbx_version.props == b"I" + struct.pack("<i", 7400)
    fbx_version.props = b"I" + struct.pack("<i", 7500)
    converted = write_fbx(7500, nodes, data[footer_at:footer_at + 16])
    # Read back: the same tree, footer as fbxcel wants it.
    version2, nodes2, footer2 = read_fbx(converted)
    assert version2 == 7500 and same_tree(nodes, nodes2)
    check_footer_as_fbxcel(converted, footer2, 7500)
    return converted


def same_tree(a, b):
    return len(a) == len(b) and all(
        x.name == y.name and x.props == y.props and x.prop_count == y.prop_count
        and x.null_record == y.null_record and same_tree(x.children, y.children)
        for x, y in zip(a, b))


ARRAY_TYPES = {"f": "f", "d": "d", "l": "q", "i": "i", "b": "b"}
SCALAR_TYPES = {"Y": "<h", "C": "<?", "I": "<i", "F": "<f", "D": "<d", "L": "<q"}


def decode_props(node, stats=None):
    """Property values of a node (arrays decompressed); counts array encodings in `stats`."""
    values, pos, p = [], 0, node.props
    while pos < len(p):
        kind = chr(p[pos])
        pos += 1
        if kind in SCALAR_TYPES:
            fmt_ = SCALAR_TYPES[kind]
            values.append(struct.unpack_from(fmt_, p, pos)[0])
            pos += struct.calcsize(fmt_)
        elif kind in ARRAY_TYPES:
            count, encoding, length = struct.unpack_from("<3I", p, pos)
            pos += 12
            raw = p[pos:pos + length]
            pos += length
            if stats is not None:
                stats[encoding] = stats.get(encoding, 0) + 1
            raw = zlib.decompress(raw) if encoding == 1 else raw
            values.append(list(struct.unpack(f"<{count}{ARRAY_TYPES[kind]}", raw)))
        elif kind in "SR":
            (length,) = struct.unpack_from("<I", p, pos)
            pos += 4
            chunk = p[pos:pos + length]
            pos += length
            values.append(chunk.decode("utf-8", "replace") if kind == "S" else chunk)
        else:
            raise ValueError(f"unknown property type {kind!r} in {node.name}")
    return values


def walk(nodes):
    for n in nodes:
        yield n
        yield from walk(n.children)


def properties70(node):
    table = {}
    block = node.child("Properties70")
    for p in block.children if block else []:
        values = decode_props(p)
        table[values[0]] = values[4:]
    return table


def describe_fbx(data):
    """What a reader must find in a binary FBX body (file units and axes)."""
    version, nodes, footer_at = read_fbx(data)
    encodings = {}
    for n in walk(nodes):
        decode_props(n, encodings)
    top = {n.name: n for n in nodes}
    settings = properties70(top["GlobalSettings"])
    objects = {}
    for n in top["Objects"].children:
        v = decode_props(n)
        objects[v[0]] = (n, v[1].split("\x00\x01")[0], v[2] if len(v) > 2 else "")
    links = [decode_props(c) for c in top["Connections"].children]
    models = {i: name for i, (n, name, sub) in objects.items() if n.name == "Model"}
    parent_of = {c[1]: c[2] for c in links if c[0] == "OO" and c[1] in models and c[2] in models}
    geometry = next(n for n, _, sub in objects.values() if n.name == "Geometry" and sub == "Mesh")
    vertices = decode_props(geometry.child("Vertices"))[0]
    corners = decode_props(geometry.child("PolygonVertexIndex"))[0]
    polygon_sizes, size = [], 0
    for c in corners:
        size += 1
        if c < 0:
            polygon_sizes.append(size)
            size = 0
    limbs = {i: name for i, (n, name, sub) in objects.items() if n.name == "Model" and sub == "LimbNode"}
    bone_parents = {name: models.get(parent_of.get(i), "") for i, name in limbs.items()}
    for name, parent in list(bone_parents.items()):  # the Null above the root bone is in the chain too
        if parent and parent not in bone_parents:
            bone_parents[parent] = ""
    nulls = [n for n, _, sub in objects.values() if n.name == "Model" and sub == "Null"]
    assert len(nulls) == 1
    null_props = properties70(nulls[0])
    animated, keys = {}, set()
    for c in links:
        if c[0] == "OP" and c[1] in objects and objects[c[1]][0].name == "AnimationCurveNode" and c[2] in models:
            animated.setdefault(models[c[2]], []).append(c[3])
    channels = {}
    for c in links:
        if c[0] == "OP" and c[1] in objects and objects[c[1]][0].name == "AnimationCurve":
            curve = objects[c[1]][0]
            keys.add(len(decode_props(curve.child("KeyTime"))[0]))
            target = next(d for d in links if d[0] == "OP" and d[1] == c[2] and d[2] in models)
            channels[f"{models[target[2]]} {target[3]} {c[3].removeprefix('d|')}"] = [
                round(v, 6) for v in decode_props(curve.child("KeyValueFloat"))[0]]
    assert len(channels) == 1, channels  # only the Spine turns: static channels are not written
    stack = next(n for n, _, _ in objects.values() if n.name == "AnimationStack")
    ticks = 46_186_158_000
    stack_props = properties70(stack)
    return {
        "fbx_version": version,
        "up_axis": settings["UpAxis"][0],
        "up_axis_sign": settings["UpAxisSign"][0],
        "front_axis": settings["FrontAxis"][0],
        "front_axis_sign": settings["FrontAxisSign"][0],
        "coord_axis": settings["CoordAxis"][0],
        "coord_axis_sign": settings["CoordAxisSign"][0],
        "unit_scale_factor": settings["UnitScaleFactor"][0],
        "vertices": len(vertices) // 3,
        "polygons": len(polygon_sizes),
        "triangles": sum(s - 2 for s in polygon_sizes),
        "file_coordinate_max_abs": max(abs(x) for x in vertices),
        "bones": sorted(limbs.values()),
        "bone_parents": bone_parents,
        "armature_lcl_rotation": null_props.get("Lcl Rotation", [0.0, 0.0, 0.0]),
        "armature_lcl_scaling": null_props.get("Lcl Scaling", [1.0, 1.0, 1.0]),
        "animated_models": sorted(animated),
        "frames": max(keys),
        "animated_channel": next(iter(channels)),
        "channel_keys": next(iter(channels.values())),
        "start_s": stack_props["LocalStart"][0] / ticks,
        "end_s": stack_props["LocalStop"][0] / ticks,
        "arrays_zlib": encodings.get(1, 0),
        "arrays_raw": encodings.get(0, 0),
        "footer_bytes": len(data) - footer_at,
    }


# ---------------------------------------------------------------------------
# FBX bodies built in Blender
# ---------------------------------------------------------------------------

BODY_SIZE = (0.36, 0.22, 1.70)  # x (width), y (depth), z (height), m
BONES = (("Hips", None, 0.85, 1.05), ("Spine", "Hips", 1.05, 1.45), ("Head", "Spine", 1.45, 1.70))


def bone_weights(z):
    """Weights of (Hips, Spine, Head) at height z: blends over 0.95-1.15 m and 1.40-1.50 m."""
    s = min(max((z - 0.95) / 0.20, 0.0), 1.0)
    t = min(max((z - 1.40) / 0.10, 0.0), 1.0)
    return 1.0 - s, s * (1.0 - t), t


def build_body(prefix):
    import bmesh
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = FPS, 1.0
    scene.frame_start, scene.frame_end = FRAME_START, FRAME_END
    scene.unit_settings.system, scene.unit_settings.scale_length = "METRIC", 1.0

    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=1.0)
    bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=5, use_grid_fill=True)
    for v in bm.verts:
        v.co.x, v.co.y, v.co.z = v.co.x * BODY_SIZE[0], v.co.y * BODY_SIZE[1], (v.co.z + 0.5) * BODY_SIZE[2]
    mesh = bpy.data.meshes.new("Body")
    bm.to_mesh(mesh)
    bm.free()
    material = bpy.data.materials.new("Skin")
    material.diffuse_color = (0.6, 0.46, 0.38, 1.0)
    mesh.materials.append(material)
    body = bpy.data.objects.new("Body", mesh)
    scene.collection.objects.link(body)

    data = bpy.data.armatures.new("Armature")
    armature = bpy.data.objects.new("Armature", data)
    scene.collection.objects.link(armature)
    bpy.context.view_layer.objects.active = armature
    bpy.ops.object.mode_set(mode="EDIT")
    for name, parent, z0, z1 in BONES:
        bone = data.edit_bones.new(prefix + name)
        bone.head, bone.tail = (0.0, 0.0, z0), (0.0, 0.0, z1)
        if parent:
            bone.parent = data.edit_bones[prefix + parent]
            bone.use_connect = True
    bpy.ops.object.mode_set(mode="OBJECT")

    groups = [body.vertex_groups.new(name=prefix + name) for name, *_ in BONES]
    for v in mesh.vertices:
        for group, weight in zip(groups, bone_weights(v.co.z)):
            if weight > 0.0:
                group.add([v.index], weight, "REPLACE")
    body.parent = armature
    body.modifiers.new("Armature", "ARMATURE").object = armature

    spine = armature.pose.bones[prefix + "Spine"]
    spine.rotation_mode = "XYZ"
    spine.rotation_euler = (0.0, 0.0, 0.0)
    spine.keyframe_insert("rotation_euler", frame=FRAME_START)
    spine.rotation_euler = (math.radians(SPINE_TURN_DEG), 0.0, 0.0)
    spine.keyframe_insert("rotation_euler", frame=FRAME_END)
    for fcurve in all_fcurves(armature):
        for key in fcurve.keyframe_points:
            key.interpolation = "LINEAR"
    return body, armature


def all_fcurves(obj):
    """F-curves of an object's action (Blender 5 keeps them in layered channelbags)."""
    action = obj.animation_data.action
    if hasattr(action, "fcurves"):
        return list(action.fcurves)
    slot = obj.animation_data.action_slot
    return [fc for layer in action.layers for strip in layer.strips for fc in strip.channelbag(slot).fcurves]


def y_up(p):
    """Blender (Z up, -Y forward) to drape's world (Y up): (x, z, -y)."""
    return (p[0], p[2], -p[1])


def bbox(points):
    low = [round(min(p[k] for p in points), 6) for k in range(3)]
    high = [round(max(p[k] for p in points), 6) for k in range(3)]
    return low, high


def measure_body(body, frame):
    import bpy

    bpy.context.scene.frame_set(frame)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = body.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    points = [y_up(body.matrix_world @ v.co) for v in mesh.vertices]
    evaluated.to_mesh_clear()
    return bbox(points)


def export_fbx(path, body, armature, up, forward, scale_options):
    import bpy

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
        bake_anim_simplify_factor=0.01,  # static channels dropped; a key on every frame where one moves
        bake_anim_use_all_bones=False,  # curves only where something moves: keeps the files small
        bake_anim_force_startend_keying=False,
        mesh_smooth_type="FACE",
        axis_up=up,
        axis_forward=forward,
        apply_unit_scale=True,
        apply_scale_options=scale_options,
    )


def blender_7500(path, body, armature):
    """The same Y-up export written by Blender's own encoder at version 7500
    (its FBX writer supports it, the operator does not offer it): a check of
    the converter."""
    import importlib

    encode_bin = importlib.import_module("io_scene_fbx.encode_bin")
    original = encode_bin.write
    encode_bin.write = lambda fn, root, version: original(fn, root, 7500)
    try:
        export_fbx(path, body, armature, "Y", "-Z", "FBX_SCALE_UNITS")
    finally:
        encode_bin.write = original


BODY_VARIANTS = (
    # name, bone prefix, axis_up, axis_forward, apply_scale_options, what it imitates
    ("zup_cm", "", "Z", "Y", "FBX_SCALE_NONE",
     "3ds Max style: Z-up, centimetres (UnitScaleFactor 1); Blender writes the vertices in metres and the "
     "x100 as the armature node's Lcl Scaling"),
    ("yup_m", "", "Y", "-Z", "FBX_SCALE_UNITS",
     "Maya / game engines: Y-up, metres (UnitScaleFactor 100); Blender puts the -90 deg X turn on the "
     "armature node"),
    ("mixamo_names", "mixamorig:", "Y", "-Z", "FBX_SCALE_UNITS",
     "Mixamo rigs: bone names in the `mixamorig:` namespace, otherwise as yup_m"),
)


def check_by_importing(path, record):
    """Blender's own FBX importer (which reads 7.4 and 7.5) finds the same
    mesh, bones and bind-pose box: an independent check of each file."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.fbx(filepath=str(path))
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    armatures = [o for o in bpy.context.scene.objects if o.type == "ARMATURE"]
    assert len(meshes) == 1 and len(armatures) == 1, (path, meshes, armatures)
    mesh = meshes[0]
    assert len(mesh.data.vertices) == record["vertices"], path
    assert sorted(b.name for b in armatures[0].data.bones) == record["bones"], path
    low, high = bbox([y_up(mesh.matrix_world @ v.co) for v in mesh.data.vertices])
    for got, want in ((low, record["bind_bbox_min_m"]), (high, record["bind_bbox_max_m"])):
        assert all(abs(a - b) < 1e-4 for a, b in zip(got, want)), (path, got, want)


def write_fbxs(out):
    import bpy

    records = {}
    for name, prefix, up, forward, scale_options, imitates in BODY_VARIANTS:
        body, armature = build_body(prefix)
        bind_min, bind_max = measure_body(body, FRAME_START - 1)  # before the first key: the rest pose
        rest = [y_up(body.matrix_world @ v.co) for v in body.data.vertices]
        assert bbox(rest) == (bind_min, bind_max)
        last_min, last_max = measure_body(body, FRAME_END)
        bpy.context.scene.frame_set(FRAME_START)
        path = out / f"{name}.fbx"
        export_fbx(path, body, armature, up, forward, scale_options)
        path.write_bytes(fix_timestamp(path.read_bytes()))
        facts = describe_fbx(path.read_bytes())
        want = {"Z": (2, 1.0), "Y": (1, 100.0)}[up]  # UpAxis, UnitScaleFactor (cm per unit)
        assert (facts["up_axis"], facts["unit_scale_factor"]) == want, (name, facts)
        records[name] = {
            "file": path.name, "kind": "body", "imitates": imitates,
            "units": "cm" if facts["unit_scale_factor"] == 1.0 else "m",
            **facts,
            "fps": FPS,
            "bind_bbox_min_m": bind_min, "bind_bbox_max_m": bind_max,
            "last_frame_bbox_min_m": last_min, "last_frame_bbox_max_m": last_max,
        }
        if name == "yup_m":
            converted = convert_7400_to_7500(path.read_bytes())
            (out / "fbx75_64bit.fbx").write_bytes(converted)
            with tempfile.TemporaryDirectory() as folder:
                reference = pathlib.Path(folder) / "blender_7500.fbx"
                blender_7500(reference, body, armature)
                ours, theirs = read_fbx(converted), read_fbx(fix_timestamp(reference.read_bytes()))
            for node in theirs[1]:  # Blender's encoder keeps 7400 in FBXHeaderExtension
                if node.name == "FBXHeaderExtension":
                    node.child("FBXVersion").props = b"I" + struct.pack("<i", 7500)
            assert same_tree(ours[1], theirs[1]), "the converter and Blender's 7500 encoder disagree"
            ours_nodes = converted[:ours[2]]
            theirs_nodes = write_fbx(7500, theirs[1], b"")[:ours[2]]
            assert ours_nodes == theirs_nodes, "node bytes differ from Blender's 7500 encoding"
            facts75 = describe_fbx(converted)
            records["fbx75_64bit"] = {
                **records[name], **facts75, "file": "fbx75_64bit.fbx",
                "imitates": "FBX 2016+ SDK exporters (Maya, 3ds Max, MotionBuilder): FBX 7.5, 64-bit node "
                            "record headers and 25-byte null records; the yup_m body rewritten, arrays kept "
                            "zlib-compressed",
            }
    for record in records.values():
        check_by_importing(out / record["file"], record)
    return records


# ---------------------------------------------------------------------------
# expected.toml and README.md
# ---------------------------------------------------------------------------


def toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(round(v, 9))
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{toml_key(k)} = {toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(type(v))


def toml_key(k):
    return k if k.replace("_", "").isalnum() and k.isascii() else toml_value(k)


FIELD_NOTES = """\
# Expected contents of the files in this folder, written by tools/make_foreign_inputs.py
# (measured on the written files; do not edit by hand).
#
# Garments (kind = "garment"), in the file's units:
#   vertices            distinct positions used by faces: identical positions welded (across
#                       groups, objects and UV seams), as drape's reader must give
#   v_lines             `v` statements in the file; duplicate_positions = v_lines - vertices
#   triangles           polygons fanned from their first corner (a k-gon gives k - 2), none degenerate
#   quads, polygons     4-corner faces, all faces; largest_polygon = most corners of one face
#   uvs                 `vt` statements
#   parts               the named parts in order (tobj: the last `o`/`g` name before the faces)
#   materials           material names (from the MTL), material_diffuse their Kd
#   bbox_min, bbox_max  of the used positions, file units (units: "m" or "cm")
#   bom, crlf           the file starts with a UTF-8 BOM / has CRLF line ends
# Bodies (kind = "body"):
#   up_axis ... unit_scale_factor   GlobalSettings as Blender wrote them
#   vertices, polygons, triangles   of the skinned mesh; triangles = polygons fanned
#   bones               LimbNode names; bone_parents also holds the armature's Null ("Armature"),
#                       which drape's skeleton includes as the root ("" = no parent)
#   animated_models     Models with animation curves; frames = keys per curve, at fps,
#                       from start_s to end_s (AnimationStack LocalStart / LocalStop)
#   animated_channel    the one animated channel ("bone property axis"); channel_keys its values
#                       (degrees), one per frame, linear keys
#   armature_lcl_*      Lcl Rotation / Lcl Scaling of the armature's Null (where Blender puts the
#                       axis and unit conversion; the vertices are in metres in every file)
#   bind_bbox_*_m       the body at its bind pose in drape's world: metres, Y up (x, z, -y of Blender)
#   last_frame_bbox_*_m the body at the last frame (Spine turned {turn} deg), same frame
#   arrays_zlib/raw     array properties stored zlib-compressed (encoding 1) / raw
"""


def write_expected(out, records):
    lines = [FIELD_NOTES.format(turn=SPINE_TURN_DEG)]
    for name, record in records.items():
        lines.append(f"[{name}]")
        lines += [f"{toml_key(k)} = {toml_value(v)}" for k, v in record.items()]
        lines.append("")
    (out / "expected.toml").write_text("\n".join(lines), encoding="utf-8")


def readme_line(name, r):
    if r["kind"] == "garment":
        extra = f", {r['duplicate_positions']} duplicate positions to weld" if r["duplicate_positions"] else ""
        mats = f", materials {', '.join(r['materials'])}" if r["materials"] else ""
        return (f"- `{r['file']}`: {r['imitates']}. Loads as {r['vertices']} vertices, {r['triangles']} triangles "
                f"({r['quads']} quads){extra}, parts {', '.join(r['parts'])}{mats}; "
                f"bbox {r['bbox_min']} .. {r['bbox_max']} {r['units']}.")
    return (f"- `{r['file']}`: {r['imitates']}. FBX {r['fbx_version']}, UpAxis {r['up_axis']}, UnitScaleFactor "
            f"{r['unit_scale_factor']}; {r['vertices']} vertices, {r['triangles']} triangles, bones "
            f"{', '.join(r['bones'])} (under `Armature`), {r['frames']} frames at {r['fps']} fps "
            f"({r['start_s']:.4f} s to {r['end_s']:.4f} s); bind bbox {r['bind_bbox_min_m']} .. "
            f"{r['bind_bbox_max_m']} m, Y up; {r['arrays_zlib']} zlib-compressed arrays.")


README_HEAD = """\
# Inputs from other programs

Small garments and bodies that imitate what other programs' exporters write
(issue 9). Made by `tools/make_foreign_inputs.py` (Blender {blender} as a Python
module for the FBX files); the numbers each loader must give are in
`expected.toml`, one table per file. Coordinates of the garments are in the
file's units (a scene scales them, e.g. `scale = 0.01` for centimetres); the
bodies' bounding boxes are in drape's world: metres, Y up.

"""

README_TAIL = """
What the loaders must do beyond the numbers: drop a UTF-8 BOM before
reading the first line (`unicode_names.obj` starts with U+FEFF then `mtllib`:
if the BOM is kept, that line is lost and the materials with it, silently); keep bone names as
written (`mixamorig:Hips`), but match them for motion reuse without the
namespace (a motion read from `mixamo_names.fbx` drives the skeleton of
`yup_m.fbx`: Hips, Spine, Head); read FBX 7.5 (64-bit node headers) as 7.4.
The bodies' skeletons also hold the armature's Null, `Armature`, as their root
(`bone_parents`); only Spine is animated (its `Lcl Rotation` X, one key per
frame).

Also here: `maya_quads_crlf.mtl` (CRLF; its texture `sourceimages/cotton_red.png`
is deliberately absent: loading must go on, at most with a warning) and
`unicode_names.mtl` (UTF-8 names).

Not covered, because tobj 4 (drape's OBJ parser) rejects them outright:
`\\` line continuations (read as a bad face index), a comment after an `f`
line (`#` read as a face index), and a tab after `usemtl` or `mtllib` (tobj
splits those at the first space only). A file with them must fail with a
message naming the file and line, not load wrongly.
"""


def write_readme(out, records, blender):
    lines = [README_HEAD.format(blender=blender).rstrip("\n") + "\n"]
    lines += [readme_line(n, r) for n, r in records.items()]
    (out / "README.md").write_text("\n".join(lines) + "\n" + README_TAIL, encoding="utf-8")


def main():
    # Blender numbers FBX objects by hash() of their names: a fixed hash seed
    # gives the same files on every run.
    if os.environ.get("PYTHONHASHSEED") != "0":
        os.execve(sys.executable, [sys.executable, *sys.argv], {**os.environ, "PYTHONHASHSEED": "0"})
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(OUT))
    args = parser.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    records = write_objs(out)
    try:
        import bpy
    except ImportError:
        raise SystemExit("bpy is not installed: pip install bpy==5.0.1 (Python 3.11), then run again")
    records.update(write_fbxs(out))
    write_expected(out, records)
    write_readme(out, records, bpy.app.version_string)
    for path in sorted(out.iterdir()):
        size = path.stat().st_size
        assert size <= 60_000, f"{path} is {size} bytes"
        print(f"{path} {size} bytes")


if __name__ == "__main__":
    main()
