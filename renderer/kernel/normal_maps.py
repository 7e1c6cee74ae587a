"""A UsdPreviewSurface's `normal` input read from a texture: the shading normal turned to the tangent-space
normal the texture gives at the hit (`usd/materials.py` records the UsdUVTexture, its scale and bias applied by
`textures.sample_texture`, so that a texel (0.5, 0.5, 1) of the usual scale 2 and bias -1 is (0, 0, 1)).

Tangent space is that of the texture coordinates, as Storm builds it from their screen-space derivatives
(`previewSurface.glslfx`) and pbrt from a triangle's: x along the direction in which s grows (dp/ds), y along
the one in which t grows (dp/dt), z the surface's shading normal.  Here the frame is the triangle's exact
derivatives: dp/ds and dp/dt solved from its edges and the differences of its corners' coordinates (a mesh
without texture coordinates: its barycentrics, as `shapes.triangle_st` reads them), placed in the world with
the placement's matrix; T is dp/ds made orthogonal to the shading normal N, B = N x T, turned to the side of
dp/dt (so a mirrored mapping mirrors the bumps, as it mirrors the image).  A sphere's frame is that of its
lat-long coordinates (`shapes.sphere_st`): T along the parallel, B towards +Y.  The normal is T x + B y + N z,
normalised; where the frame is undefined (coordinates that do not vary over a triangle, a sphere's poles,
curves) or the mapped normal is not finite or zero, the shading normal stays as it was.
"""
import math

import numba as nb

from .features import F_SPHERES
from .jit import SHADING_INLINE_JIT
from .tables import GP_CURVES, GP_HAS_UVS, GP_SPHERE
from .textures import sample_texture
from .vecmath import cross, dot, inverse_xform, normalize, xform_dir


@nb.njit(**SHADING_INLINE_JIT)
def _triangle_derivatives(S, g, prim_id):
    """(dp/ds, dp/dt) in object space of triangle prim_id of mesh gprim g, or two zero vectors where its
    coordinates do not span the plane."""
    tri = S.gp_off[g] + prim_id
    v = S.tri_v
    e1 = (float(v[tri, 1, 0]) - v[tri, 0, 0], float(v[tri, 1, 1]) - v[tri, 0, 1], float(v[tri, 1, 2]) - v[tri, 0, 2])
    e2 = (float(v[tri, 2, 0]) - v[tri, 0, 0], float(v[tri, 2, 1]) - v[tri, 0, 1], float(v[tri, 2, 2]) - v[tri, 0, 2])
    ds1, dt1, ds2, dt2 = 1.0, 0.0, 0.0, 1.0             # (barycentric coordinates: st = (bu, bv))
    if S.gp_flags[g] & GP_HAS_UVS:
        k = S.gp_uv_off[g] + prim_id
        uv = S.tri_uv
        ds1, dt1 = float(uv[k, 1, 0]) - uv[k, 0, 0], float(uv[k, 1, 1]) - uv[k, 0, 1]
        ds2, dt2 = float(uv[k, 2, 0]) - uv[k, 0, 0], float(uv[k, 2, 1]) - uv[k, 0, 1]
    det = ds1 * dt2 - ds2 * dt1
    if not abs(det) > 1e-9 * (abs(ds1 * dt2) + abs(ds2 * dt1)):     # (0, and NaN, fail)
        return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    inv = 1.0 / det
    dpds = ((dt2 * e1[0] - dt1 * e2[0]) * inv, (dt2 * e1[1] - dt1 * e2[1]) * inv, (dt2 * e1[2] - dt1 * e2[2]) * inv)
    dpdt = ((ds1 * e2[0] - ds2 * e1[0]) * inv, (ds1 * e2[1] - ds2 * e1[1]) * inv, (ds1 * e2[2] - ds2 * e1[2]) * inv)
    return dpds, dpdt


@nb.njit(**SHADING_INLINE_JIT)
def _sphere_derivatives(S, g, prim_id, m, p):
    """(directions of dp/ds, dp/dt) in object space at world point p of sphere prim_id of gprim g (placed by
    m): along the parallel, in the direction s = atan2(z, -x) / 2 pi grows, and along the meridian towards +Y."""
    k = S.gp_off[g] + prim_id
    po, _ = inverse_xform(m, p, (0.0, 0.0, 1.0))
    n = normalize((po[0] - S.sph[k, 0], po[1] - S.sph[k, 1], po[2] - S.sph[k, 2]))
    dpds = (n[2], 0.0, -n[0])                             # d/ds of (-cos, ., sin)(2 pi s): 0 at the poles
    return dpds, cross(n, dpds)                           # (n x dp/ds: towards +Y)


@nb.njit(**SHADING_INLINE_JIT)
def mapped_normal(S, m, hit, g, p, ns, st, tid):
    """The shading normal at `hit` (a `records.Hit` on gprim g, placed by m, at world point p; outward shading
    normal ns; texture coordinates st) turned to texture tid's tangent-space normal there."""
    kind = S.gp_kind[g]
    if kind == GP_CURVES:
        return ns
    if F_SPHERES and kind == GP_SPHERE:
        dpds, dpdt = _sphere_derivatives(S, g, hit.prim_id, m, p)
    else:
        dpds, dpdt = _triangle_derivatives(S, g, hit.prim_id)
    ws, wt = xform_dir(m, dpds), xform_dir(m, dpdt)
    along = dot(ws, ns)
    t = (ws[0] - along * ns[0], ws[1] - along * ns[1], ws[2] - along * ns[2])
    tt = dot(t, t)
    if not tt > 1e-30:
        return ns
    t = normalize(t)
    b = cross(ns, t)
    if dot(b, wt) < 0.0:
        b = (-b[0], -b[1], -b[2])
    x, y, z = sample_texture(S, tid, st[0], st[1])
    n = (x * t[0] + y * b[0] + z * ns[0], x * t[1] + y * b[1] + z * ns[1], x * t[2] + y * b[2] + z * ns[2])
    nn = dot(n, n)
    if not (nn > 1e-30 and math.isfinite(nn)):
        return ns
    return normalize(n)
