"""The lights as the path integrator samples them: one light per shading point, chosen from the
light tree (`light_tree.py`: by power, distance and orientation, in O(log n)), so the cost of a sample
grows only with the logarithm of the number of lights and far or turned-away lights are rarely
chosen (at a path's first vertex, in a scene of many lights, from its image tile's table, which weighs every
light with the tree's importance of its leaf: `kernel/tile_lights.py`, the `leaf_*` fields); the geometry of
the light shapes that BSDF rays can meet (in the path integrator's top level, found in O(log n) per ray by the
same query as the surfaces: `build.path_top`; the cook integrator never builds it); the dome's sampling tables.

The tree's phi of a light (only ratios matter, and any positive choice keeps the estimator unbiased) is
its largest radiant *intensity*, so that a leaf's importance, phi cos / d^2, is the irradiance the light
delivers (exactly for a small light): point I, rect and disk A L (seen face on), sphere pi r^2 L, cylinder
2 r l L (seen across its axis), emissive surface A L (a flat one seen face on; no mesh of that area shows
more: `surface_lights.py`).  Total powers (4 pi I, pi A L, 4 pi^2 r^2 L, as pbrt-v4's light bounds) would
weigh a point light 4 times too much against an area light of the same irradiance, and the tree would
spend light samples on minor point lights beside a dominant area light (`benchmarks/bench_many_lights.py`).
Distant and dome lights (outside the tree, chosen uniformly beside it) need only phi > 0: pi R^2 E and
4 pi^2 R^2 L (texture mean), R the radius of the scene's bounds.  A rect light's image scales its phi by the
image's mean luminance.  Luminances of the RGB values' magnitudes: a light of negative radiance (a
subtractive light, as the course integrator reads it) is chosen by how much it changes the image, so that
light samples find it as BSDF samples do (an integrand of either sign is sampled in proportion to its
magnitude).  An IES profile multiplies a light's phi by its largest weight (`kernel/ies_profiles.py`).

Lights are numbered as the scene's (`desc.lights`, the light table), then its emissive surfaces
(`surface_first` on: `surface_lights.py`).
"""
from __future__ import annotations

import warnings
from collections import namedtuple

import numpy as np

from .. import description as D
from ..kernel.tables import LF_AREA, LF_H, LF_LENGTH, LF_M, LF_RADIUS, LF_W
from ..kernel.trace import MASK_FACING, MASK_LIGHT_SHAPES
from ..kernel.tile_lights import TILE_LIGHTS_MAX, TILE_LIGHTS_MIN
from .light_images import image_tables
from .features import see_through
from .light_tree import light_tree
from .surface_lights import surface_lights, surface_lights_none

PathLights = namedtuple('PathLights', ['tree_f', 'tree_i', 'trail', 'depth', 'unbounded', 'n_bounded', 'shapes',
                                       'infinite', 'has_dome', 'image_i', 'image_cdf', 'light_group', 'geom_off',
                                       'prim_light', 'facing', 'surface_first', 'n_surface', 'sl_f', 'sl_i', 'sl_tri',
                                       'sl_cdf', 'sl_row', 'sl_idx', 'direct_base', 'direct', 'see_through',
                                       'shadow_packets', 'leaf_f', 'leaf_k', 'leaf_col'])
_LUM = np.array([0.2126, 0.7152, 0.0722])


def light_phi(desc: D.SceneDescription, li_f: np.ndarray, radius: float, image_mean: dict) -> np.ndarray:
    out = np.zeros(max(len(desc.lights), 1))
    for k, l in enumerate(desc.lights):
        y = float(np.dot(_LUM, np.abs(l.radiance)))
        if l.type == D.POINT:
            out[k] = y
        elif l.type in (D.RECT, D.DISK):
            out[k] = li_f[k, LF_AREA] * y * image_mean.get(k, 1.0)
        elif l.type == D.CYLINDER:
            out[k] = 2 * li_f[k, LF_RADIUS] * li_f[k, LF_LENGTH] * y
        elif l.type == D.SPHERE:
            out[k] = np.pi * li_f[k, LF_RADIUS] ** 2 * y
        elif l.type == D.DISTANT:
            out[k] = np.pi * radius ** 2 * y
        elif l.type == D.DOME:
            out[k] = 4 * np.pi ** 2 * radius ** 2 * y * image_mean.get(k, 1.0)
        if l.ies is not None:                        # (its profile's peak: the largest intensity still)
            out[k] *= l.ies_gain * float(l.ies.candela.max())
    return np.where(np.isfinite(out) & (out > 0), out, 0.0)


# one-sided light shapes (rects, disks) facing within FACING_ANGLE of each other share a ray-mask bit, up
# to FACING_GROUPS bits (`facing_groups`); the others are in the group every ray meets
FACING_GROUPS, FACING_ANGLE = 8, np.radians(30.0)
FACING_EPS = 1e-7


def _back_normal(li_f: np.ndarray, k: int) -> np.ndarray:
    """The unit normal of planar light k on the side it does not emit from, as `kernel/light_sampling._plane`
    computes it: a ray along d can meet its emitting side only where d . n > 0."""
    m = li_f[k, LF_M:LF_M + 12].reshape(3, 4)
    n = np.cross(m[:, 0], m[:, 1])
    n = n / max(float(np.linalg.norm(n)), 1e-300)
    return -n if float(np.dot(n, m[:, 2])) < 0.0 else n


def facing_groups(normals: list, groups: int = FACING_GROUPS, angle: float = FACING_ANGLE):
    """(group of each normal, -1: none; facing float64 (g, 4)) of one-sided planar lights whose back
    normals are `normals` (unit): each joins the first group whose axis (its first member's normal) is
    within `angle` of it, or starts a group while there are fewer than `groups`.  Row g of `facing`: the
    axis a and -sin(theta) - FACING_EPS, theta the largest angle between a and a member: a ray along d
    can meet the emitting side of a member (d . n > 0) only if d . a > -sin(theta) (the angle between d and
    a is below 90 degrees + theta), so a ray whose d . a is at most row[3] meets none of them, and the
    kernel leaves the group's bit out of its ray mask (`light_sampling.shape_mask`): camera rays that look
    down on ceiling lights do not traverse them."""
    axes, spread, of = [], [], []
    cos_a = np.cos(angle)
    for n in normals:
        g = next((j for j, a in enumerate(axes) if float(np.dot(a, n)) >= cos_a), -1)
        if g < 0 and len(axes) < groups:
            g = len(axes)
            axes.append(np.asarray(n, np.float64))
            spread.append(0.0)
        if g >= 0:
            spread[g] = max(spread[g], float(np.arccos(np.clip(np.dot(axes[g], n), -1.0, 1.0))))
        of.append(g)
    facing = np.array([[*a, -np.sin(t) - FACING_EPS] for a, t in zip(axes, spread)], np.float64).reshape(-1, 4)
    return np.array(of, np.int64), facing


def shape_geometry(desc: D.SceneDescription, li_f: np.ndarray, shapes: list[int], groups: int = FACING_GROUPS):
    """((meshes, spheres, curves) as `embree.Device.prototype_scene` takes them, or None; geom_off,
    prim_light; masks: the ray mask of each of those geometries, in that order; facing: the planar groups'
    rows, `facing_groups`) of the light shapes, for BSDF rays to find them in O(log n) (`build.path_top`
    puts them in the path integrator's top level): rects and disks as two triangles each (a disk's
    circumscribed square; the kernel's exact test `light_sampling.hit_shape` rejects the corners), one mesh
    per facing group (mask MASK_FACING << g) and one of the rest (MASK_LIGHT_SHAPES), spheres as float64
    rows, cylinders as one segment each (its two ends and the radius, float64), both MASK_LIGHT_SHAPES and
    both tested exactly by the path top level's user geometry (`user_geometry.py`: the open cylinder); light
    of a hit = prim_light[geom_off[geomID] + primID]."""
    planar = [k for k in shapes if desc.lights[k].type in (D.RECT, D.DISK)]
    round_ = [k for k in shapes if desc.lights[k].type == D.SPHERE]
    tubes = [k for k in shapes if desc.lights[k].type == D.CYLINDER]
    no_facing = np.zeros((0, 4), np.float64)
    if not shapes:
        return None, np.zeros(1, np.int64), np.zeros(1, np.int64), [], no_facing
    meshes, spheres, geom_off, prim_light, masks = [], [], [], [], []
    of, facing = facing_groups([_back_normal(li_f, k) for k in planar], groups) if planar else ([], no_facing)
    for g in [*range(len(facing)), -1]:
        members = [k for k, j in zip(planar, of) if j == g]
        if not members:
            continue
        verts = []
        for k in members:
            m = li_f[k, LF_M:LF_M + 12].reshape(3, 4)
            half = (0.5 * li_f[k, LF_W], 0.5 * li_f[k, LF_H]) if desc.lights[k].type == D.RECT else \
                (li_f[k, LF_RADIUS],) * 2
            ex, ey = m[:, 0] * half[0], m[:, 1] * half[1]
            verts += [m[:, 3] - ex - ey, m[:, 3] + ex - ey, m[:, 3] + ex + ey, m[:, 3] - ex + ey]
        base = 4 * np.arange(len(members))[:, None]
        tris = np.concatenate([base + [0, 1, 2], base + [0, 2, 3]], 1).reshape(-1, 3)
        meshes.append((np.array(verts, np.float32), tris.astype(np.uint32)))
        geom_off.append(len(prim_light))
        prim_light += [k for k in members for _ in range(2)]
        masks.append(MASK_FACING << g if g >= 0 else MASK_LIGHT_SHAPES)
    if round_:
        spheres.append(np.array([[*li_f[k, LF_M:LF_M + 12].reshape(3, 4)[:, 3], li_f[k, LF_RADIUS]]
                                 for k in round_], np.float64))
        geom_off.append(len(prim_light))
        prim_light += round_
        masks.append(MASK_LIGHT_SHAPES)
    curves = []
    if tubes:
        segments = []
        for k in tubes:
            m = li_f[k, LF_M:LF_M + 12].reshape(3, 4)
            half = 0.5 * li_f[k, LF_LENGTH] * m[:, 0] / np.linalg.norm(m[:, 0])
            segments.append([[*(m[:, 3] - half), li_f[k, LF_RADIUS]], [*(m[:, 3] + half), li_f[k, LF_RADIUS]]])
        curves.append(np.array(segments, np.float64))
        geom_off.append(len(prim_light))
        prim_light += tubes
        masks.append(MASK_LIGHT_SHAPES)
    return (meshes, spheres, curves), np.array(geom_off, np.int64), np.array(prim_light, np.int64), masks, facing


def path_lights(desc: D.SceneDescription, li_f: np.ndarray, bounds: np.ndarray, light_group: int,
                data=None, shadow_packets: bool = True) -> tuple:
    """(PathLights record, (the light shapes' geometry, their ray masks) or None: `shape_geometry`) of a built
    scene (li_f: the light table; bounds (2, 3) of the scene; light_group: the instance id that hits on light shapes
    report in the path integrator's top level, `build.path_top`;
    data: its `build.SceneData`, whose emissive surfaces become lights; None: none do).  `see_through`:
    whether a surface lets rays through (`features.see_through`; without `data`, whether a material
    could), i.e. whether shadow rays must be traced one by one (`kernel/path._defer_shadow`);
    `shadow_packets`: whether the other scenes' shadow rays are queued and traced in packets (where
    Embree's own 16- or 8-wide kernels run them, `embree.Device.native_packets`) or traced one by one."""
    lo, hi = np.asarray(bounds, np.float64)
    ext = hi - lo
    radius = 0.5 * float(np.linalg.norm(ext)) if np.all(np.isfinite(ext)) and np.all(ext >= 0) else 1.0
    image_i, image_cdf, image_mean = image_tables(desc)
    surf = surface_lights(data, len(desc.lights), _warner(desc)) if data is not None else None
    tree_f, tree_i, trail, depth, unbounded, n_bounded, leaves = light_tree(
        desc, li_f, light_phi(desc, li_f, max(radius, 1e-30), image_mean), surf.bounds if surf else ())
    types = [l.type for l in desc.lights]
    shapes = [k for k, t in enumerate(types) if t in (D.RECT, D.DISK, D.SPHERE, D.CYLINDER)]
    infinite = [k for k, l in enumerate(desc.lights)
                if l.type == D.DOME or (l.type == D.DISTANT and l.angle > 0)]
    geometry, geom_off, prim_light, masks, facing = shape_geometry(desc, li_f, shapes, FACING_GROUPS)
    return PathLights(tree_f=tree_f, tree_i=tree_i, trail=trail, depth=depth, unbounded=unbounded, n_bounded=n_bounded,
                      shapes=np.array(shapes, np.int64),
                      infinite=np.array(infinite, np.int64), has_dome=int(D.DOME in types),
                      image_i=image_i, image_cdf=image_cdf, light_group=light_group if geometry else -1,
                      geom_off=geom_off, prim_light=prim_light, facing=facing, **_surface_fields(desc, surf),
                      direct_base=-1, direct=np.zeros((0, 3), np.int64),
                      see_through=see_through(data) if data is not None else any(
                          m.model == D.PREVIEW_SURFACE and m.opacity < 1.0 for m in desc.materials),
                      shadow_packets=bool(shadow_packets), **_leaf_fields(leaves, len(depth))), \
        (geometry, masks) if geometry else None


def _leaf_fields(leaves, n_lights: int) -> dict:
    """The PathLights fields of `tile_lights.py` (leaf_f: every light's bounds as one block row of the tree,
    leaf_k: the light of each column, leaf_col: the column of each light or -1) where the scene has
    TILE_LIGHTS_MIN to TILE_LIGHTS_MAX lights with a position; empty tables elsewhere (the tree alone)."""
    leaf_f, leaf_k = leaves
    col = np.full(n_lights, -1, np.int64)
    if not TILE_LIGHTS_MIN <= len(leaf_k) <= TILE_LIGHTS_MAX:
        return {'leaf_f': np.zeros((1, 0), np.float32), 'leaf_k': np.zeros(0, np.int64), 'leaf_col': col}
    col[leaf_k] = np.arange(len(leaf_k))
    return {'leaf_f': np.ascontiguousarray(leaf_f.reshape(1, -1)), 'leaf_k': leaf_k, 'leaf_col': col}


def _warner(desc: D.SceneDescription):
    """warn(message): a warning about the scene found at render time (the scene's warnings were printed
    when it was read: also a RuntimeWarning)."""
    def warn(message: str) -> None:
        desc.warnings.append(message)
        warnings.warn(message, RuntimeWarning, stacklevel=2)
    return warn


def _surface_fields(desc: D.SceneDescription, surf) -> dict:
    """The PathLights fields of the emissive surfaces (`surface_lights.py`; placeholders when none)."""
    if surf is None:
        surf = surface_lights_none()
    n = len(surf.bounds)
    return {'surface_first': len(desc.lights), 'n_surface': n, 'sl_f': surf.sl_f, 'sl_i': surf.sl_i,
            'sl_tri': surf.sl_tri, 'sl_cdf': surf.sl_cdf, 'sl_row': surf.sl_row, 'sl_idx': surf.sl_idx}
