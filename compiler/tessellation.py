"""Polygon meshes of the course's analytic shapes, for USD tools that bind materials to meshes only.

Blender's USD importer (5.0) converts UsdGeom implicit shapes to meshes but drops their material
binding, so the compiler writes a course sphere, box or cylinder as a `Mesh` (these polygons)
that also carries the exact shape (`rtc:implicit` and its sizes): rtc renders the exact shape,
other tools the mesh with its material.  Each function returns (points (n, 3), faceVertexCounts,
faceVertexIndices, vertex normals (n, 3)) in the shape's own frame, the frames of the UsdGeom
shape it stands for: a sphere and a cylinder (axis Y) centred on the origin, a cube of side 1.
Faces are counter-clockwise seen from outside.
"""
from __future__ import annotations

import numpy as np

SEGMENTS = 32          # around the axis
RINGS = 16             # pole to pole (sphere)


def sphere(radius: float):
    """Latitude-longitude sphere: quads between rings, triangles at the poles."""
    theta = np.linspace(0.0, np.pi, RINGS + 1)[1:-1]             # from the north pole (+Y)
    phi = np.linspace(0.0, 2 * np.pi, SEGMENTS, endpoint=False)
    ring = np.stack([np.sin(theta)[:, None] * np.sin(phi), np.repeat(np.cos(theta)[:, None], SEGMENTS, 1),
                     np.sin(theta)[:, None] * np.cos(phi)], axis=-1).reshape(-1, 3)
    unit = np.vstack([[0.0, 1.0, 0.0], ring, [0.0, -1.0, 0.0]])
    south, j = len(unit) - 1, np.arange(SEGMENTS)
    nxt = (j + 1) % SEGMENTS
    faces = [np.stack([np.zeros(SEGMENTS, int), 1 + j, 1 + nxt], 1)]          # north cap
    counts = [np.full(SEGMENTS, 3)]
    for r in range(RINGS - 2):
        a, b = 1 + r * SEGMENTS, 1 + (r + 1) * SEGMENTS
        faces.append(np.stack([a + j, b + j, b + nxt, a + nxt], 1))
        counts.append(np.full(SEGMENTS, 4))
    last = 1 + (RINGS - 2) * SEGMENTS
    faces.append(np.stack([last + j, np.full(SEGMENTS, south), last + nxt], 1))   # south cap
    counts.append(np.full(SEGMENTS, 3))
    indices = np.concatenate([f.ravel() for f in faces])
    return unit * radius, np.concatenate(counts), indices, unit


def cube():
    """The unit cube as 6 quads (8 shared corners); normals point away from the centre."""
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    quads = np.array([0, 1, 3, 2, 4, 6, 7, 5, 0, 4, 5, 1, 2, 3, 7, 6, 0, 2, 6, 4, 1, 5, 7, 3])
    return corners, np.full(6, 4), quads, corners / np.linalg.norm(corners, axis=1, keepdims=True)


def cylinder(radius: float, height: float):
    """Side quads and two polygonal caps of a Y-axis cylinder centred on the origin."""
    phi = np.linspace(0.0, 2 * np.pi, SEGMENTS, endpoint=False)
    x, z = np.sin(phi), np.cos(phi)
    h = height / 2
    bottom = np.stack([radius * x, np.full(SEGMENTS, -h), radius * z], 1)
    top = np.stack([radius * x, np.full(SEGMENTS, h), radius * z], 1)
    j = np.arange(SEGMENTS)
    nxt = (j + 1) % SEGMENTS
    side = np.stack([j, nxt, SEGMENTS + nxt, SEGMENTS + j], 1).ravel()
    caps = np.concatenate([j[::-1], SEGMENTS + j])              # bottom faces -Y, top faces +Y
    counts = np.concatenate([np.full(SEGMENTS, 4), [SEGMENTS, SEGMENTS]])
    normals = np.vstack([np.stack([x, np.zeros(SEGMENTS), z], 1)] * 2)
    return np.vstack([bottom, top]), counts, np.concatenate([side, caps]), normals
