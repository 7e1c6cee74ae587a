"""Scene-level geometry facts the writer needs: transform sanity and the world bounding box.

Both are computed batched over all shapes and placements (composition through
`transforms.compose_many`), so scenes with 10^5 placements stay fast.
"""
from __future__ import annotations

from typing import NamedTuple, Optional

import numpy as np

from .diagnostics import Diagnostics
from .obj import ObjMesh
from .scene import FLOAT_MAX, Box, Cylinder, Geometry, Scene, Sphere, Triangle
from .transforms import compose_many, singular_mask


def check_transforms(scene: Scene, diags: Diagnostics) -> None:
    """Error (naming the <transform> line) for every transform that is singular, not finite, or has an
    entry beyond the 32-bit float range (a placement the renderer could not hold: ~1e39 away)."""
    transforms = [t for obj in (*scene.shapes, *scene.placements) for t in obj.motion.samples]
    transforms += [p.transform for p in scene.used_prototypes() if p.transform is not None]
    if not transforms:
        return
    with np.errstate(over="ignore", invalid="ignore"):
        matrices = compose_many([t.ops for t in transforms])
    finite = np.isfinite(matrices).all(axis=(1, 2))
    within = finite & (np.abs(np.where(np.isfinite(matrices), matrices, 0.0)) <= FLOAT_MAX).all(axis=(1, 2))
    singular = np.zeros(len(transforms), bool)
    singular[within] = singular_mask(matrices[within])
    for i in np.flatnonzero(~within | singular):
        if not finite[i]:
            diags.error("the transform is not finite (its product overflows)", transforms[i].line,
                        "transform")
        elif not within[i]:
            diags.error(f"the transform is beyond the 32-bit float range (an entry of magnitude above "
                        f"{FLOAT_MAX:.7g}) in which the renderer places instances", transforms[i].line,
                        "transform")
        else:
            diags.error("the transform is singular (a zero scale or collapsed axes): it has no inverse",
                        transforms[i].line, "transform")


def local_box(geometry: Geometry, meshes: dict) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned box of the geometry in its own space."""
    if isinstance(geometry, Sphere):
        c, r = np.array(geometry.center), geometry.radius
        return c - r, c + r
    if isinstance(geometry, Box):
        return np.array(geometry.min), np.array(geometry.max)
    if isinstance(geometry, Triangle):
        v = np.array([geometry.v0, geometry.v1, geometry.v2])
        return v.min(axis=0), v.max(axis=0)
    if isinstance(geometry, Cylinder):
        c = np.array(geometry.center)
        half = np.array([geometry.radius, geometry.height / 2, geometry.radius])
        return c - half, c + half
    mesh: ObjMesh = meshes[geometry.path]
    return mesh.bounds()


class Extent(NamedTuple):
    """World-space extent of everything rendered (first motion sample)."""
    lo: np.ndarray            # (3,) box corners
    hi: np.ndarray
    centers: np.ndarray       # (n, 3) centre of each rendered shape's / placement's world box


def world_bounds(scene: Scene, meshes: dict) -> Optional[Extent]:
    """The scene's Extent, or None if nothing is rendered."""
    groups: dict[int, tuple[np.ndarray, list]] = {}
    for shape in scene.shapes:
        groups.setdefault(id(shape), (_corners(shape.geometry, meshes), []))[1].append(
            (shape.motion.samples[0].ops if shape.motion.samples else ()))
    for placement in scene.placements:
        proto = placement.prototype
        if id(proto) not in groups:
            corners = _corners(proto.geometry, meshes)
            if proto.transform is not None:
                corners = corners @ proto.transform.matrix().T
            groups[id(proto)] = (corners, [])
        groups[id(proto)][1].append(placement.motion.samples[0].ops if placement.motion.samples else ())
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    centers = []
    for corners, op_lists in groups.values():
        world = np.einsum("nij,kj->nki", compose_many(op_lists), corners)[..., :3]
        wlo, whi = world.min(axis=1), world.max(axis=1)
        lo = np.minimum(lo, wlo.min(axis=0))
        hi = np.maximum(hi, whi.max(axis=0))
        centers.append((wlo + whi) / 2)
    return Extent(lo, hi, np.concatenate(centers)) if np.all(lo <= hi) else None


def _corners(geometry: Geometry, meshes: dict) -> np.ndarray:
    lo, hi = local_box(geometry, meshes)
    pick = np.array([[i >> 2 & 1, i >> 1 & 1, i & 1] for i in range(8)], dtype=bool)
    return np.hstack([np.where(pick, hi, lo), np.ones((8, 1))])


MAX_INSIDE_WARNINGS = 3


def warn_camera_inside(scene: Scene, diags: Diagnostics) -> None:
    """Warn when the eye sits inside a closed analytic shape (sphere, box, cylinder; plain or
    placed, first motion sample): every camera ray then meets its inner side first, which usually
    hides the rest of the scene (a course `skysphere` is meant to be seen so)."""
    eye = np.array([*scene.camera.position, 1.0])
    groups: dict[int, tuple] = {}
    for shape in scene.shapes:
        groups.setdefault(id(shape), (shape.geometry, None, []))[2].append((shape.motion, shape.line))
    for placement in scene.placements:
        proto = placement.prototype
        inner = proto.transform.matrix() if proto.transform is not None else None
        groups.setdefault(id(proto), (proto.geometry, inner, []))[2].append((placement.motion, placement.line))
    found = []
    for geometry, inner, uses in groups.values():
        if not isinstance(geometry, (Sphere, Box, Cylinder)):
            continue
        with np.errstate(over="ignore", invalid="ignore"):
            world = compose_many([m.samples[0].ops if m.samples else () for m, _ in uses])
            if inner is not None:
                world = world @ inner
            local = np.linalg.solve(world, np.broadcast_to(eye, (len(world), 4))[..., None])[..., 0, None]
        inside = _inside(geometry, local[:, :3, 0])
        found += [(line, type(geometry).__name__.lower()) for (_, line), hit in zip(uses, inside) if hit]
    for line, kind in sorted(found)[:MAX_INSIDE_WARNINGS]:
        diags.warning(f"the camera is inside the closed {kind} of line {line}: camera rays meet its inner "
                      "side first, which hides what lies outside it", scene.camera.line, "camera")
    if len(found) > MAX_INSIDE_WARNINGS:
        diags.warning(f"the camera is inside {len(found) - MAX_INSIDE_WARNINGS} more closed shapes",
                      scene.camera.line, "camera")


def _inside(geometry: Geometry, p: np.ndarray) -> np.ndarray:
    """Which object-space points lie strictly inside the shape."""
    if isinstance(geometry, Sphere):
        return np.linalg.norm(p - np.array(geometry.center), axis=1) < geometry.radius
    if isinstance(geometry, Box):
        lo, hi = np.array(geometry.min), np.array(geometry.max)
        return np.all((p > lo) & (p < hi), axis=1)
    c = np.array(geometry.center)
    radial = np.hypot(p[:, 0] - c[0], p[:, 2] - c[2])
    return (radial < geometry.radius) & (np.abs(p[:, 1] - c[1]) < geometry.height / 2)
