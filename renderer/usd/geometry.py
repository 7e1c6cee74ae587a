"""UsdGeom gprims -> `Mesh` / `Sphere` / `Curves` records in their container's space (UsdGeom.Points: a `Sphere`
record of many spheres; UsdGeom.BasisCurves: `curves.py`).

Every converter receives the gprim-to-container matrix (float64 4x4, column vectors) and bakes it: points are
transformed, normals use the inverse transpose, and triangles are re-wound so that they are counter-clockwise seen
from the outside after `orientation = "leftHanded"` and after a mirroring (negative-determinant) transform (the two
cancel). Spheres stay analytic and keep the matrix.

Shading normals: authored ``primvars:normals`` (preferred, as in UsdGeom) or ``normals`` with any interpolation,
indexed or not. Without authored normals a polygonal mesh (subdivisionScheme ``none`` or ``bilinear``) gets
``normals=None`` (the integrator uses the flat geometric normal); a subdivision surface (``catmullClark``, ``loop``,
the schema fallback) is not subdivided but gets smooth area-weighted vertex normals, which is what its limit surface
looks like from afar.

Quadrics (Cube, Cylinder, Cone, Capsule, Plane and their ``_1`` variants) are tessellated in gprim space with exact
per-corner normals (flat for cube faces and caps, smooth around the axis) and simple UVs, then go through the same
path as meshes.

A `materialBind` GeomSubset family splits a mesh into several `Mesh` records whose ``path`` is
the subset's path, so the reader resolves each part's binding on the subset prim.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from pxr import Usd, UsdGeom

from ..description import FLOAT32_MAX, Mesh, Sphere
from .corner_primvars import DISPLAY_COLOR, DISPLAY_OPACITY, corner_colour_name, corner_opacity_name
from .primvar_values import flattened, per_corner
from .texture_coordinates import uv_primvar

Warn = Callable[[str], None]
SEGMENTS = 48            # tessellation of quadrics around their axis
RINGS = 12               # latitude rings per capsule hemisphere
MATERIAL_BIND_FAMILY = 'materialBind'


class GeometryError(Exception):
    """One gprim cannot be converted (bad topology, non-finite values, degenerate size);
    the reader drops that gprim and records the message in `SceneDescription.skipped`."""


# --------------------------------------------------------------------------- public entry points
def converter_for(type_name: str):
    """The converter for a gprim type name, or None when the type is not renderable here."""
    return _CONVERTERS.get(type_name)


def convert_gprim(prim: Usd.Prim, to_container: np.ndarray, time: Usd.TimeCode, warn: Warn, posed=None) -> list:
    """Mesh/Sphere/Curves records for one gprim; `posed`: the points of a point-based gprim posed by its skeleton
    (`skinning.posed_points`), read in place of its own.  Raises GeometryError (also for coordinates past float32's
    range, where Embree traces), or KeyError for an unknown type (callers ask `converter_for` first)."""
    if not np.all(np.isfinite(to_container)):
        raise GeometryError(f'{prim.GetPath()}: non-finite transform')
    if abs(np.linalg.det(to_container[:3, :3])) < 1e-300:
        raise GeometryError(f'{prim.GetPath()}: singular transform')
    extra = (posed,) if posed is not None and implicit_type(prim) in _POSABLE else ()
    records = _CONVERTERS[implicit_type(prim)](prim, to_container, time, warn, *extra)
    if not (reach := max([r.reach() for r in records], default=0.0)) <= FLOAT32_MAX:
        raise GeometryError(f'{prim.GetPath()}: coordinates up to {reach:.3g} in its container, past float32\'s range')
    return records


def implicit_type(prim: Usd.Prim) -> str:
    """The gprim type to read: a `Mesh` with `rtc:implicit` (rtc's compiler writes course spheres,
    boxes and cylinders so, for tools that bind materials to meshes only) is read as that exact
    UsdGeom shape, its sizes in `rtc:<attribute>`; anything else as its own type."""
    kind = prim.GetTypeName()
    if kind == 'Mesh':
        attr = prim.GetAttribute('rtc:implicit')
        value = attr.Get() if attr else None
        if value in IMPLICIT_TYPES:
            return value
    return kind


# --------------------------------------------------------------------------- meshes
def points_box(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi): the axis-aligned box of (n, 3) points."""
    return points.min(axis=0), points.max(axis=0)


def _fan(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fan triangulation of polygons given their vertex counts, vectorised.

    Returns (face index per triangle (m,), corner indices into faceVertexIndices (m, 3)).
    Polygons with fewer than 3 vertices produce no triangles."""
    ntri = np.where(counts >= 3, counts - 2, 0)
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    face = np.repeat(np.arange(len(counts)), ntri)
    first = np.repeat(starts, ntri)
    j = np.arange(int(ntri.sum())) - np.repeat(np.cumsum(ntri) - ntri, ntri)
    return face, np.stack([first, first + j + 1, first + j + 2], axis=1)


def _authored_normals(mesh: UsdGeom.PointBased, time, warn: Warn):
    """(values, interpolation) of primvars:normals if authored, else of `normals`, else None;
    ((), None) when authored but unusable (already warned about)."""
    pv = UsdGeom.PrimvarsAPI(mesh).GetPrimvar('normals')
    if pv and pv.HasAuthoredValue():
        values = flattened(pv, time, warn, 'normals computed from the faces instead')
        return ((), None) if values is None else (values, pv.GetInterpolation())
    attr = mesh.GetNormalsAttr()
    if attr.HasAuthoredValue():
        values = attr.Get(time)
        if not hasattr(values, '__len__'):
            warn(f'{mesh.GetPath()}: normals has no readable array of values; normals computed from the '
                 'faces instead')
            return ((), None)
        return values, mesh.GetNormalsInterpolation()
    return None


def varying_display_color(prim: Usd.Prim, time, name: str = DISPLAY_COLOR):
    """(values (k, 3), interpolation) of a Mesh's, Points' or BasisCurves' own primvars:displayColor (or the colour
    primvar `name`: `corner_primvars`) where it varies over it (an interpolation other than constant, two or more
    distinct finite colours), else None.  Such a mesh keeps its colours per triangle corner (`Mesh.colors`), a cloud
    a colour a point (`Sphere.colors`), curves a colour at each segment end (`Curves.colors`), which a material
    fallback shades by (`materials.fallback`: its one test of the same prim, so that the two agree) or a material
    that reads that primvar (`materials.MaterialTable._primvar_value`)."""
    return _varying(prim, time, name, 3, VARYING_COLOUR_TYPES)


def varying_display_opacity(prim: Usd.Prim, time, name: str = DISPLAY_OPACITY):
    """(values (k,) clamped to [0, 1], interpolation) of the own primvars:displayOpacity (or the scalar primvar
    `name`: `corner_primvars`) of a gprim of VARYING_OPACITY_TYPES where it varies over it, else None.  A mesh keeps
    it per triangle corner, a cloud a value a point, curves one at each segment end (the fourth channel of
    `Mesh.colors`, `Sphere.colors`, `Curves.colors`), which the fallback material or a material that reads it for its
    opacity multiplies its opacity by."""
    v = _varying(prim, time, name, 1, VARYING_OPACITY_TYPES)
    return None if v is None else (np.clip(v[0][:, 0], 0.0, 1.0), v[1])


def _varying(prim: Usd.Prim, time, name: str, width: int, types: tuple):
    """(values (k, width), interpolation) of prim's own primvar `name` where prim is one of `types` and the primvar
    has an interpolation other than constant and two or more distinct finite values of `width` numbers, else None."""
    if implicit_type(prim) not in types:
        return None
    pv = UsdGeom.PrimvarsAPI(prim).GetPrimvar(name)
    if not pv or not pv.HasAuthoredValue() or pv.GetInterpolation() == UsdGeom.Tokens.constant:
        return None
    values = flattened(pv, time, lambda message: None, '')      # (unreadable: `fallback` warns)
    v = np.asarray([] if values is None else values, np.float64)
    v = v[:, None] if width == 1 and v.ndim == 1 else v
    if v.ndim != 2 or v.shape[1] != width or len(v) < 2 or not np.all(np.isfinite(v)) or np.all(v == v[0]):
        return None
    return v, pv.GetInterpolation()


def corner_values(prim: Usd.Prim, time, expand, shape: tuple, misfit, warn: Warn):
    """The colours, and the opacities, that `prim` keeps per corner (`corner_primvars`) where they vary over it,
    float32 (*shape, 3), or (*shape, 4) with the opacity (its colours white where only that varies); None where
    neither does.  `expand(values, interpolation)` gives a primvar's values per corner (`shape`), or None where their
    count does not fit its interpolation (then their mean is used, warned: `misfit(count, interpolation)` says how)."""
    parts = []
    for name, varying, width in ((corner_colour_name(prim), varying_display_color, 3),
                                 (corner_opacity_name(prim), varying_display_opacity, 1)):
        v = varying(prim, time, name)
        values = None if v is None else expand(v[0], v[1])
        if v is not None and values is None:
            warn(f'{prim.GetPath()}: primvars:{name}: {misfit(len(v[0]), v[1])}; '
                 f'their mean {"colour" if width == 3 else "opacity"} used')
            values = np.broadcast_to(v[0].mean(0), shape + (width,))
        parts.append(None if values is None else np.asarray(values, np.float64).reshape(shape + (width,)))
    colours, opacities = parts
    if opacities is not None:
        colours = np.concatenate([np.ones(shape + (3,)) if colours is None else colours, opacities], axis=-1)
    return None if colours is None else np.ascontiguousarray(colours, np.float32)


def _misfit(where: str):
    """The words of `corner_values`'s warning where a primvar's count does not fit its interpolation on a mesh."""
    return lambda n, how: f'{n} values do not match interpolation "{how}"{where}'


def _mesh(prim: Usd.Prim, m: np.ndarray, time, warn: Warn, posed=None) -> list[Mesh]:
    mesh = UsdGeom.Mesh(prim)
    counts = np.asarray(mesh.GetFaceVertexCountsAttr().Get(time) or [], np.int64)
    indices = np.asarray(mesh.GetFaceVertexIndicesAttr().Get(time) or [], np.int64)
    holes = np.asarray(mesh.GetHoleIndicesAttr().Get(time) or [], np.int64)
    subdivided = mesh.GetSubdivisionSchemeAttr().Get(time) not in (UsdGeom.Tokens.none, UsdGeom.Tokens.bilinear)
    return polygons(prim, m, time, warn, (counts, indices, holes), subdivided, posed)


def polygons(prim: Usd.Prim, m: np.ndarray, time, warn: Warn, topology: tuple, subdivided: bool,
             posed=None) -> list[Mesh]:
    """Mesh records of a point-based gprim's own `points` on a polygon topology (faceVertexCounts,
    faceVertexIndices, holeIndices), read as a Mesh is: its orientation, normals, texture coordinates,
    displayColor varying over it, materialBind subsets.  `subdivided`: a subdivision scheme's mesh (smooth
    normals where none are authored).  `posed`: its points posed by a skeleton, in place of its own; its authored
    normals are then not used (Storm computes a skinned mesh's normals from its posed points too)."""
    pb = UsdGeom.PointBased(prim)
    path = str(prim.GetPath())
    counts, indices, holes = topology
    points = np.asarray(pb.GetPointsAttr().Get(time) or [] if posed is None else posed, np.float64).reshape(-1, 3)
    if len(points) == 0 or len(counts) == 0:
        raise GeometryError(f'{path}: empty mesh')
    if counts.sum() != len(indices) or np.any(counts < 0):
        raise GeometryError(f'{path}: faceVertexCounts do not add up to faceVertexIndices')
    if len(indices) and (indices.min() < 0 or indices.max() >= len(points)):
        raise GeometryError(f'{path}: faceVertexIndices out of range')
    if not np.all(np.isfinite(points)):
        raise GeometryError(f'{path}: non-finite points')

    face, corner = _fan(counts)
    if len(holes):
        keep = ~np.isin(face, holes)
        face, corner = face[keep], corner[keep]
    if len(face) == 0:
        raise GeometryError(f'{path}: no faces with 3 or more vertices')
    left = pb.GetOrientationAttr().Get(time) == UsdGeom.Tokens.leftHanded
    if left:
        corner = corner[:, [0, 2, 1]]

    normals, dropped = None, False
    authored = None if posed is not None else _authored_normals(pb, time, warn)
    if authored is not None and authored[1] is not None:
        normals = per_corner(authored[0], authored[1], face, corner, indices, len(points), len(counts))
        if normals is None:
            warn(f'{path}: {len(authored[0])} normals do not match interpolation '
                 f'"{authored[1]}" ({len(points)} points, {len(counts)} faces, {len(indices)} face '
                 'corners); normals computed from the faces instead')
    dropped = authored is not None and normals is None
    uvs = None
    st = uv_primvar(prim)
    if st is not None:
        values = flattened(st, time, warn, 'texture coordinates ignored')
        if values is not None:
            uvs = per_corner(values, st.GetInterpolation(), face, corner, indices, len(points), len(counts))
            if uvs is None:
                warn(f'{path}: primvars:{st.GetPrimvarName()}: {len(values)} values do not match '
                     f'interpolation "{st.GetInterpolation()}"; texture coordinates ignored')
    colors = corner_values(prim, time, lambda v, how: per_corner(v, how, face, corner, indices, len(points),
                                                                 len(counts)), (len(face), 3), _misfit(''), warn)
    smooth = normals is None and (dropped or subdivided)
    whole = _finish(path, points, indices[corner], normals, uvs, m, smooth, _double_sided(prim), colors)

    # split by materialBind subsets: one record per subset (+ the faces in none of them)
    subsets = UsdGeom.Subset.GetGeomSubsets(pb, UsdGeom.Tokens.face, MATERIAL_BIND_FAMILY)
    if not subsets:
        return [whole]
    owner = np.full(len(face), -1)
    for k, subset in enumerate(subsets):
        owner[np.isin(face, np.asarray(subset.GetIndicesAttr().Get(time) or [], np.int64))] = k
    parts = []
    for k in range(-1, len(subsets)):
        sel = owner == k
        if sel.any():
            parts.append(Mesh(path if k < 0 else str(subsets[k].GetPath()), whole.points,
                              whole.triangles[sel],
                              None if whole.normals is None else whole.normals[sel],
                              None if whole.uvs is None else whole.uvs[sel],
                              double_sided=whole.double_sided,
                              colors=None if whole.colors is None else whole.colors[sel]))
    return parts


def _double_sided(prim: Usd.Prim) -> bool:
    """USD's `doubleSided` when authored; otherwise True, because Hydra does not cull back faces
    of single-sided gprims by default either and course scenes expect two-sided triangles."""
    attr = UsdGeom.Gprim(prim).GetDoubleSidedAttr()
    return bool(attr.Get()) if attr.HasAuthoredValue() else True


def _finish(path: str, points: np.ndarray, triangles: np.ndarray, normals, uvs,
            m: np.ndarray, smooth: bool, double_sided: bool, colors=None) -> Mesh:
    """Bake the gprim-to-container matrix into gprim-space geometry.

    `triangles` must be CCW in gprim space; a mirroring matrix reverses them.  `normals` are
    per-corner gprim-space directions (or None), `smooth` asks for area-weighted vertex normals
    computed after the transform."""
    lin = m[:3, :3]
    p = points @ lin.T + m[:3, 3]
    tris = np.ascontiguousarray(triangles, np.int32)
    if np.linalg.det(lin) < 0:
        tris = tris[:, [0, 2, 1]]
        normals = None if normals is None else normals[:, [0, 2, 1]]
        uvs = None if uvs is None else uvs[:, [0, 2, 1]]
        colors = None if colors is None else colors[:, [0, 2, 1]]
    face_n = np.cross(p[tris[:, 1]] - p[tris[:, 0]], p[tris[:, 2]] - p[tris[:, 0]])
    if normals is not None:
        n = normals @ np.linalg.inv(lin)          # row vectors: n' = n M^-1 = (M^-T n)^T
        normals = _unit(n, np.repeat(face_n[:, None, :], 3, axis=1))
    elif smooth:
        acc = np.zeros_like(p)
        for c in range(3):
            for a in range(3):
                acc[:, a] += np.bincount(tris[:, c], face_n[:, a], minlength=len(p))
        normals = _unit(acc[tris], np.repeat(face_n[:, None, :], 3, axis=1))
    return Mesh(path=path, points=p, triangles=tris,
                normals=None if normals is None else normals.astype(np.float32),
                uvs=None if uvs is None else np.ascontiguousarray(uvs[..., :2], np.float32),
                colors=None if colors is None else np.ascontiguousarray(colors, np.float32),
                double_sided=double_sided)


def _unit(v: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """Normalise vectors along the last axis; zero or non-finite ones take the (normalised)
    fallback direction, and if that is degenerate too, +Y."""
    out = np.array(v, np.float64)
    length = np.linalg.norm(out, axis=-1, keepdims=True)
    bad = ~(np.isfinite(length) & (length > 0))[..., 0]
    out[bad] = fallback[bad]
    length = np.linalg.norm(out, axis=-1, keepdims=True)
    bad = ~(np.isfinite(length) & (length > 0))[..., 0]
    out[bad] = (0.0, 1.0, 0.0)
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


# --------------------------------------------------------------------------- quadrics
def _axis_frame(axis: str) -> np.ndarray:
    """Rotation taking the Z-axis-aligned canonical shape to the authored `axis` (a cyclic
    permutation of the coordinates, det = +1, so winding is preserved)."""
    if axis == 'X':
        return np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0]], np.float64)
    if axis == 'Y':
        return np.array([[0, 1, 0], [0, 0, 1], [1, 0, 0]], np.float64)
    return np.eye(3)


def _shape(prim, name: str, time, default: float, positive=True) -> float:
    attr = prim.GetAttribute(name if prim.GetTypeName() != 'Mesh' else f'rtc:{name}')
    value = attr.Get(time) if attr else None
    value = default if value is None else float(value)
    if not np.isfinite(value) or (positive and value <= 0) or value < 0:
        raise GeometryError(f'{prim.GetPath()}: {name} = {value} is not a valid size')
    return value


def _axis(prim, time) -> str:
    attr = prim.GetAttribute('axis' if prim.GetTypeName() != 'Mesh' else 'rtc:axis')
    return (attr.Get(time) if attr else None) or 'Z'


def _revolve(profile: list[tuple[float, float, float, float, float]]):
    """Surface of revolution around +Z from a profile of (radius, z, normal_r, normal_z, v) rows
    ordered bottom to top.  Consecutive rows form a band; bands whose ends coincide are skipped
    and degenerate triangles at the poles are dropped.  Returns (points, tris, normals, uvs)
    per point (points duplicated along the seam for UVs)."""
    phi = np.linspace(0.0, 2 * np.pi, SEGMENTS + 1)
    c, s = np.cos(phi), np.sin(phi)
    u = phi / (2 * np.pi)
    pts, nrm, uv, tris = [], [], [], []
    for (r, z, nr, nz, v) in profile:
        pts.append(np.stack([r * c, r * s, np.full_like(c, z)], 1))
        nrm.append(np.stack([nr * c, nr * s, np.full_like(c, nz)], 1))
        uv.append(np.stack([u, np.full_like(u, v)], 1))
    w = SEGMENTS + 1
    i = np.arange(SEGMENTS)
    for k in range(len(profile) - 1):
        (r0, z0, *_), (r1, z1, *_) = profile[k], profile[k + 1]
        if r0 == r1 and z0 == z1:
            continue
        b, t = k * w + i, (k + 1) * w + i
        if r0 > 0:
            tris.append(np.stack([b, b + 1, t + 1], 1))
        if r1 > 0:
            tris.append(np.stack([b, t + 1, t], 1))
    return np.concatenate(pts), np.concatenate(tris), np.concatenate(nrm), np.concatenate(uv)


def _disk(radius: float, z: float, up: bool):
    """A flat cap (fan around its centre) facing +Z (`up`) or -Z."""
    phi = np.linspace(0.0, 2 * np.pi, SEGMENTS + 1)[:-1]
    ring = np.stack([radius * np.cos(phi), radius * np.sin(phi), np.full_like(phi, z)], 1)
    pts = np.vstack([[0.0, 0.0, z], ring])
    i = np.arange(SEGMENTS)
    a, b = 1 + i, 1 + (i + 1) % SEGMENTS
    tris = np.stack([np.zeros_like(i), a, b] if up else [np.zeros_like(i), b, a], 1)
    nrm = np.tile([0.0, 0.0, 1.0 if up else -1.0], (len(pts), 1))
    uv = 0.5 + 0.5 * pts[:, :2] / radius
    return pts, tris, nrm, uv


def _merge(*parts):
    pts, tris, nrm, uv, base = [], [], [], [], 0
    for p, t, n, u in parts:
        pts.append(p); tris.append(t + base); nrm.append(n); uv.append(u)
        base += len(p)
    return np.concatenate(pts), np.concatenate(tris), np.concatenate(nrm), np.concatenate(uv)


def _quadric(prim, m, parts, axis: str, double_sided: bool, colour=None) -> list[Mesh]:
    """One Mesh record of a quadric's parts; `colour(pts, tris)`, where given, returns its triangles again and their
    corners' colours."""
    pts, tris, nrm, uv = _merge(*parts)
    rot = _axis_frame(axis)
    pts, nrm = pts @ rot.T, nrm @ rot.T
    colors = None
    if colour is not None:
        tris, colors = colour(pts, tris)
    return [_finish(str(prim.GetPath()), pts, tris, nrm[tris], uv[tris], m, False, double_sided, colors)]


def _frustum(rb: float, rt: float, h: float):
    """Side and caps of a cylinder (rb = rt) or cone (rt = 0) of height h centred on the origin."""
    slope = np.array([h, rb - rt]) / np.hypot(h, rb - rt)
    parts = [_revolve([(rb, -h / 2, slope[0], slope[1], 0.0), (rt, h / 2, slope[0], slope[1], 1.0)])]
    if rb > 0:
        parts.append(_disk(rb, -h / 2, up=False))
    if rt > 0:
        parts.append(_disk(rt, h / 2, up=True))
    return parts


def _cylinder(prim, m, time, warn):
    h = _shape(prim, 'height', time, 2.0)
    if prim.GetTypeName() == 'Cylinder_1':
        rb = _shape(prim, 'radiusBottom', time, 1.0, positive=False)
        rt = _shape(prim, 'radiusTop', time, 1.0, positive=False)
    else:
        rb = rt = _shape(prim, 'radius', time, 1.0)
    if rb == 0 and rt == 0:
        raise GeometryError(f'{prim.GetPath()}: both radii are 0')
    return _quadric(prim, m, _frustum(rb, rt, h), _axis(prim, time),
                    _double_sided(prim))


def _cone(prim, m, time, warn):
    h, r = _shape(prim, 'height', time, 2.0), _shape(prim, 'radius', time, 1.0)
    return _quadric(prim, m, _frustum(r, 0.0, h), _axis(prim, time),
                    _double_sided(prim))


def _capsule(prim, m, time, warn):
    """Two hemispheres joined by a band.  For Capsule_1 with different radii the band joins the
    equators (not the exact tangent cone) -- a close approximation for moderate differences."""
    h = _shape(prim, 'height', time, 1.0, positive=False)
    if prim.GetTypeName() == 'Capsule_1':
        rb = _shape(prim, 'radiusBottom', time, 0.5)
        rt = _shape(prim, 'radiusTop', time, 0.5)
    else:
        rb = rt = _shape(prim, 'radius', time, 0.5)
    lat = np.linspace(-np.pi / 2, 0.0, RINGS + 1)
    total = np.pi * (rb + rt) / 2 + h
    profile = [(rb * np.cos(a), -h / 2 + rb * np.sin(a), np.cos(a), np.sin(a),
                (rb * (a + np.pi / 2)) / total) for a in lat]
    profile += [(rt * np.cos(a), h / 2 + rt * np.sin(a), np.cos(a), np.sin(a),
                 (rb * np.pi / 2 + h + rt * a) / total) for a in -lat[::-1]]
    return _quadric(prim, m, [_revolve(profile)], _axis(prim, time),
                    _double_sided(prim))


def _cube(prim, m, time, warn):
    half = _shape(prim, 'size', time, 2.0) / 2
    pts, nrm, uv, tris = [], [], [], []
    for a in range(3):
        for sign in (1.0, -1.0):
            n = np.zeros(3); n[a] = sign
            u = np.zeros(3); u[(a + 1) % 3] = 1.0
            v = np.cross(n, u)                               # u x v = n: CCW seen from outside
            base = len(pts)
            for (su, sv), t in zip(((-1, -1), (1, -1), (1, 1), (-1, 1)), ((0, 0), (1, 0), (1, 1), (0, 1))):
                pts.append(half * (n + su * u + sv * v)); nrm.append(n); uv.append(t)
            tris += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
    varying = varying_display_color(prim, time) is not None or varying_display_opacity(prim, time) is not None
    return _quadric(prim, m, [(np.array(pts), np.array(tris), np.array(nrm), np.array(uv, float))],
                    'Z', _double_sided(prim), (lambda p, t: _cube_colours(p, prim, time, warn)) if varying else None)


# Hydra's cube (GeomUtilCuboidMeshGenerator): its 8 corners' signs and its 6 quads, the order in which a Cube's
# uniform, vertex and faceVarying primvars are given
HYDRA_CUBE_CORNERS = np.array([(1, 1, 1), (-1, 1, 1), (-1, -1, 1), (1, -1, 1),
                               (-1, -1, -1), (-1, 1, -1), (1, 1, -1), (1, -1, -1)])
HYDRA_CUBE_QUADS = np.array([(0, 1, 2, 3), (4, 5, 6, 7), (0, 6, 5, 1), (4, 7, 3, 2), (0, 3, 7, 6), (4, 2, 1, 5)])


def _cube_colours(pts: np.ndarray, prim: Usd.Prim, time, warn: Warn):
    """A cube's triangles over its 24 points (4 a face, in faces' order) split as Storm splits Hydra's quads,
    (0, 1, 2) and (0, 2, 3), and the displayColor and displayOpacity at their corners (`corner_values`), read in the
    order of Hydra's cube."""
    corner = np.argmax(np.all(np.sign(pts)[:, None, :] == HYDRA_CUBE_CORNERS[None], axis=2), axis=1)
    centre = pts.reshape(6, 4, 3).mean(axis=1)            # (the points come 4 a face)
    tris, face, fv = [], [], []
    for f, quad in enumerate(HYDRA_CUBE_QUADS):
        axis = int(np.flatnonzero(np.all(HYDRA_CUBE_CORNERS[quad] == HYDRA_CUBE_CORNERS[quad[0]], axis=0))[0])
        on_face = np.flatnonzero(np.repeat(np.sign(centre[:, axis]) == HYDRA_CUBE_CORNERS[quad[0], axis], 4))
        ours = [int(on_face[np.flatnonzero(corner[on_face] == v)[0]]) for v in quad]
        tris += [(ours[0], ours[1], ours[2]), (ours[0], ours[2], ours[3])]
        face += [f, f]
        fv += [(4 * f, 4 * f + 1, 4 * f + 2), (4 * f, 4 * f + 2, 4 * f + 3)]
    tris, face, fv = np.array(tris), np.array(face), np.array(fv)
    colors = corner_values(prim, time, lambda v, how: per_corner(v, how, face, fv, HYDRA_CUBE_QUADS.reshape(-1), 8, 6),
                           (len(tris), 3), _misfit(' on a cube (6 faces, 8 points, 24 face corners)'), warn)
    return tris, colors


def _plane(prim, m, time, warn):
    """A two-triangle rectangle facing +axis; always double-sided (a plane has no inside)."""
    w, length = _shape(prim, 'width', time, 2.0), _shape(prim, 'length', time, 2.0)
    axis = _axis(prim, time)
    # (u, v, normal) axes with u x v = normal, and the extent along each in-plane axis
    frames = {'Z': ((0, 1, 2), (w, length)), 'X': ((1, 2, 0), (length, w)), 'Y': ((2, 0, 1), (length, w))}
    (iu, iv, inorm), (su, sv) = frames[axis] if axis in frames else frames['Z']
    pts = np.zeros((4, 3))
    corners = np.array([(-1, -1), (1, -1), (1, 1), (-1, 1)], float)
    pts[:, iu], pts[:, iv] = corners[:, 0] * su / 2, corners[:, 1] * sv / 2
    nrm = np.zeros((4, 3)); nrm[:, inorm] = 1.0
    tris = np.array([(0, 1, 2), (0, 2, 3)])
    uv = (corners + 1) / 2
    return [_finish(str(prim.GetPath()), pts, tris, nrm[tris], uv[tris], m, False, True)]


def _sphere(prim, m, time, warn):
    r = _shape(prim, 'radius', time, 1.0)
    return [Sphere(path=str(prim.GetPath()), radius=r, matrix=np.array(m, np.float64))]


def _points(prim, m, time, warn, posed=None):
    """UsdGeom.Points: a cloud of spheres, one a point, of diameter its width (`widths`, constant or one a
    point; unauthored: 1, as Hydra draws them), in gprim space; points that are not finite, or whose width is
    not positive, are left out (warned)."""
    pts = UsdGeom.Points(prim)
    path = str(prim.GetPath())
    p = pts.GetPointsAttr().Get(time) if posed is None else posed
    p = np.zeros((0, 3)) if p is None else np.asarray(p, np.float64).reshape(-1, 3)
    w = pts.GetWidthsAttr().Get(time)
    w = np.ones(1) if w is None or len(w) == 0 else np.asarray(w, np.float64).reshape(-1)
    if len(w) not in (1, len(p)):
        warn(f'{path}: {len(w)} widths for {len(p)} points (interpolation {pts.GetWidthsInterpolation()}); '
             f'using the first for every point')
    r = 0.5 * (np.full(len(p), w[0]) if len(w) != len(p) else w)
    ok = np.all(np.isfinite(p), axis=1) & np.isfinite(r) & (r > 0.0)
    if not ok.all():
        warn(f'{path}: {int((~ok).sum())} of {len(p)} points left out (not finite, or width not positive)')
    if not ok.any():
        raise GeometryError(f'{path}: no point to draw')
    g = m[:3, :3].T @ m[:3, :3]
    if not np.allclose(g, np.trace(g) / 3.0 * np.eye(3), rtol=1e-6, atol=1e-12 * abs(np.trace(g))):
        warn(f'{path}: a non-uniform scale; its points stay spheres, their widths scaled by its mean scale')
    colors = corner_values(prim, time, lambda v, how: v[:len(p)] if len(v) >= len(p) else None, (len(p),),
                           lambda n, how: f'{n} values for {len(p)} points', warn)   # (any interpolation but constant)
    colors = None if colors is None else np.ascontiguousarray(colors[ok])
    return [Sphere(path=path, radius=float(r[ok].max()), matrix=np.array(m, np.float64),
                   centers=np.ascontiguousarray(p[ok]), radii=np.ascontiguousarray(r[ok]), colors=colors)]


def _tet_mesh(prim, m, time, warn, posed=None):
    from .mesh_adapters import tet_mesh             # (TetMesh and NurbsPatch are read through `polygons`)
    return tet_mesh(prim, m, time, warn, polygons, GeometryError, posed)


def _nurbs_patch(prim, m, time, warn, posed=None):
    from .mesh_adapters import nurbs_patch
    return nurbs_patch(prim, m, time, warn, polygons, GeometryError, posed)


def _basis_curves(prim, m, time, warn, posed=None):
    from .curves import basis_curves                 # (curves.py is the BasisCurves reader; it reads no module here)
    return basis_curves(prim, m, time, warn, GeometryError, varying_display_color, posed, varying_display_opacity)


def _nurbs_curves(prim, m, time, warn, posed=None):
    from .curves import nurbs_curves
    return nurbs_curves(prim, m, time, warn, GeometryError, varying_display_color, posed, varying_display_opacity)


IMPLICIT_TYPES = ('Sphere', 'Cube', 'Cylinder')
_CONVERTERS = {
    'Mesh': _mesh, 'Sphere': _sphere, 'Cube': _cube, 'Cylinder': _cylinder,
    'Cylinder_1': _cylinder, 'Cone': _cone, 'Capsule': _capsule, 'Capsule_1': _capsule,
    'Plane': _plane, 'Points': _points, 'BasisCurves': _basis_curves, 'NurbsCurves': _nurbs_curves,
    'TetMesh': _tet_mesh, 'NurbsPatch': _nurbs_patch,
}
# point-based gprims whose converters read points posed by a skeleton in place of their own
_POSABLE = ('Mesh', 'Points', 'BasisCurves', 'NurbsCurves', 'TetMesh', 'NurbsPatch')
# gprims whose records keep a displayColor that varies over them (a course sphere written as a Mesh: a Sphere)
VARYING_COLOUR_TYPES = ('Mesh', 'Points', 'BasisCurves', 'NurbsCurves', 'TetMesh', 'NurbsPatch', 'Cube')
VARYING_OPACITY_TYPES = VARYING_COLOUR_TYPES
