"""A test scene (spheres, a box and an instanced mesh on a plane, one point light) that can be moved
far from the origin or scaled, and the image measures the stability tests use."""
from __future__ import annotations

import copy
import math

import numpy as np

from rtc.renderer import description as D

from tests.renderer.handmade import look_at, quad, scene

LAMBERT = D.Material('/lambert', model=D.LAMBERTIAN, diffuse=(0.6, 0.6, 0.6))
RED = D.Material('/red', model=D.BLINN_PHONG, diffuse=(0.7, 0.2, 0.1), specular=(0.3, 0.3, 0.3), exponent=30)


def box_mesh(lo, hi, material=0, path='/box'):
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    p = np.array([[(hi if i & 4 else lo)[0], (hi if i & 2 else lo)[1], (hi if i & 1 else lo)[2]] for i in range(8)])
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = np.array([t for f in faces for t in ((f[0], f[1], f[2]), (f[0], f[2], f[3]))], np.int32)
    return D.Mesh(path, points=p, triangles=tris, material=material)


def uv_sphere(segments=16, rings=8, radius=1.0, material=0, smooth=True, path='/uvsphere'):
    """A UV sphere mesh (poles + rings), optionally with per-corner smooth normals."""
    pts = [(0.0, radius, 0.0)]
    for i in range(1, rings):
        th = math.pi * i / rings
        for j in range(segments):
            ph = 2 * math.pi * j / segments
            pts.append((radius * math.sin(th) * math.cos(ph), radius * math.cos(th), -radius * math.sin(th) * math.sin(ph)))
    pts.append((0.0, -radius, 0.0))
    pts = np.array(pts)
    idx = lambda i, j: 1 + (i - 1) * segments + (j % segments)
    tris = []
    for j in range(segments):
        tris.append((0, idx(1, j), idx(1, j + 1)))
        tris.append((len(pts) - 1, idx(rings - 1, j + 1), idx(rings - 1, j)))
    for i in range(1, rings - 1):
        for j in range(segments):
            a, b, c, d = idx(i, j), idx(i, j + 1), idx(i + 1, j), idx(i + 1, j + 1)
            tris += [(a, c, d), (a, d, b)]
    tris = np.array(tris, np.int32)
    normals = None
    if smooth:
        vn = pts / np.linalg.norm(pts, axis=1)[:, None]
        normals = vn[tris].astype(np.float32)
    return D.Mesh(path, points=pts, triangles=tris, normals=normals, material=material)


def test_scene(width=64, height=48) -> D.SceneDescription:
    """Plane, analytic sphere resting on it, a box, and two placements of a mesh sphere (container 1)."""
    floor = quad(30.0, y=0.0, material=0, path='/floor')
    box = box_mesh((1.5, 0.0, -0.8), (3.0, 1.5, 0.7), material=1)
    root = D.Container('/', meshes=[floor, box],
                       spheres=[D.Sphere('/ball', 1.0, np.diag([1.0, 1.0, 1.0, 1.0]) @ _t(-1.0, 1.0, 0.0), material=1)])
    proto = D.Container('/proto', meshes=[uv_sphere(24, 12, 0.5, material=0)])
    mats = np.stack([np.eye(4), _t(-3.0, 0.5, 1.5), _t(0.5, 0.5, 2.2)])[:, None]
    inst = D.Instances(container=np.array([0, 1, 1], np.int32), matrices=mats, material_set=np.zeros(3, np.int32),
                       material_sets=[()])
    cam = D.Camera('/cam', matrix=look_at((0.5, 3.5, 8.0), (0.0, 0.6, 0.0)), focal_length=1.0,
                   horizontal_aperture=1.0, vertical_aperture=0.75)
    light = D.Light('/light', D.POINT, _t(3.0, 6.0, 4.0), (60.0, 60.0, 60.0))
    return scene([root, proto], [LAMBERT, RED], [light], cam, instances=inst, width=width, height=height)


def _t(x, y, z):
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def transformed(desc: D.SceneDescription, offset=(0.0, 0.0, 0.0), scale=1.0) -> D.SceneDescription:
    """The same scene under p -> scale * p + offset, applied to world-space data in float64: geometry of
    the root container (points, sphere matrices), placements of the others, lights and camera.  A point
    light's intensity is multiplied by scale^2 so that the image is unchanged."""
    d = copy.deepcopy(desc)
    g = np.diag([scale, scale, scale, 1.0])
    g[:3, 3] = offset
    for ci, c in enumerate(d.containers):
        rows = np.nonzero(d.instances.container == ci)[0]
        if ci == 0:                                        # world-space geometry: move the numbers themselves
            for m in c.meshes:
                m.points = m.points * scale + np.asarray(offset, float)
            for s in c.spheres:
                s.matrix = g @ s.matrix
        else:
            d.instances.matrices[rows] = g @ d.instances.matrices[rows]
    for l in d.lights:
        l.matrix = g @ l.matrix
        if l.type == D.POINT:
            l.radiance = tuple(v * scale * scale for v in l.radiance)
    cm = d.camera.matrix.copy()
    cm[:3, 3] = cm[:3, 3] * scale + np.asarray(offset, float)
    d.camera.matrix = cm
    d.camera.focal_length *= 1.0          # camera frame is only translated; film is in angular units
    d.camera.clip_near = desc.camera.clip_near * scale
    return d


def compare(img, ref, threshold=0.05):
    """(mean |diff|, fraction of pixels whose max channel differs by more than threshold)."""
    diff = np.abs(np.asarray(img, np.float64) - np.asarray(ref, np.float64)).max(axis=2)
    return float(diff.mean()), float((diff > threshold).mean())


def speckles(img, factor=0.5):
    """Fraction of pixels darker than `factor` x the darkest of their 4 neighbours (isolated dark
    dots: shadow acne, holes).  Shadow edges always have a dark neighbour, so they do not count."""
    y = np.asarray(img, np.float64).mean(axis=2)
    c = y[1:-1, 1:-1]
    nb = np.minimum.reduce([y[:-2, 1:-1], y[2:, 1:-1], y[1:-1, :-2], y[1:-1, 2:]])
    return float(((c < factor * nb) & (nb > 0.02)).mean())
