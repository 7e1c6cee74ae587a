"""From an Embree hit to a shading point: which placement, gprim and material was hit, and the
world-space position, normals and texture coordinates there.

Instancing: Embree reports the top-level instance-array geometry (instID) and the row within it
(instPrimID); `grp_base[instID] + instPrimID` is our placement row, whose float64 matrix (lerped at the
ray's time exactly as Embree lerps its time steps) maps the prototype's object space to the world.
Normals transform with the cofactor matrix, i.e. `L^-T` up to a positive factor, which is correct for
non-uniform scale and keeps the outside of mirrored (negative-determinant) placements outside.

Precision: the hit position is rebuilt from Embree's barycentrics on the float32 object-space
triangle (spheres: projected onto the exact sphere) and transformed in float64, so its error does not
grow with the length of the ray; the geometric normal used to offset new rays comes from the
triangle's vertices, not from Embree's Ng.
"""
import math

import numba as nb

from .curves import surface_point
from .features import F_COLORS, F_CURVES, F_NORMALS, F_SPHERES, F_TEXTURES, F_UVS, F_XF_MOTION
from .jit import SHADING_INLINE_JIT
from .tables import (GP_CURVES, GP_HAS_COLORS, GP_HAS_NORMALS, GP_HAS_UVS, GP_SPHERE, MI_DIFFUSE_TEX, MI_EMISSION_TEX,
                     MI_NORMAL_TEX, MI_SCALAR_CH, MI_SCALAR_TEX, MI_SPECULAR_TEX, MI_VERTEX_COLOR, VC_OPACITY)
from .trace import instance_transform
from .vecmath import cofactor_dir, cross, inverse_xform, lerp_xf, normalize, xform_point


@nb.njit(**SHADING_INLINE_JIT)
def sphere_st(nobj):
    """Spherical (lat-long) texture coordinates of the unit object-space direction nobj from a sphere's
    centre: +Y up, seam at -X."""
    return (0.5 + math.atan2(nobj[2], -nobj[0]) / (2.0 * math.pi),
            0.5 + math.asin(max(-1.0, min(1.0, nobj[1]))) / math.pi)


@nb.njit(**SHADING_INLINE_JIT)
def triangle_st(S, g, prim_id, bu, bv):
    """Texture coordinates of triangle prim_id of mesh gprim g at barycentrics (bu, bv): its st primvar
    interpolated, or (bu, bv) where it has none."""
    if F_UVS and S.gp_flags[g] & GP_HAS_UVS:
        k = S.gp_uv_off[g] + prim_id
        uv = S.tri_uv
        w0 = 1.0 - bu - bv
        return (w0 * uv[k, 0, 0] + bu * uv[k, 1, 0] + bv * uv[k, 2, 0],
                w0 * uv[k, 0, 1] + bu * uv[k, 1, 1] + bv * uv[k, 2, 1])
    return bu, bv


@nb.njit(**SHADING_INLINE_JIT)
def corner_color(S, g, hit):
    """The displayColor of mesh gprim g at `hit` (a `records.Hit`): its triangle's corner colours (`Mesh.colors`)
    interpolated at the hit's barycentrics, as `triangle_st` interpolates texture coordinates; a point cloud's
    point's own colour (`Sphere.colors`); a curve segment's end colours, interpolated at Embree's u (`Curves.colors`);
    white where the gprim has none."""
    if S.gp_flags[g] & GP_HAS_COLORS:
        k = S.gp_c_off[g] + hit.prim_id
        c = S.tri_c
        if S.gp_kind[g] == GP_SPHERE:
            return c[k, 0, 0], c[k, 0, 1], c[k, 0, 2]
        if F_CURVES and S.gp_kind[g] == GP_CURVES:
            u = min(1.0, max(0.0, hit.u))
            return ((1.0 - u) * c[k, 0, 0] + u * c[k, 1, 0], (1.0 - u) * c[k, 0, 1] + u * c[k, 1, 1],
                    (1.0 - u) * c[k, 0, 2] + u * c[k, 1, 2])
        w0 = 1.0 - hit.u - hit.v
        return (w0 * c[k, 0, 0] + hit.u * c[k, 1, 0] + hit.v * c[k, 2, 0],
                w0 * c[k, 0, 1] + hit.u * c[k, 1, 1] + hit.v * c[k, 2, 1],
                w0 * c[k, 0, 2] + hit.u * c[k, 1, 2] + hit.v * c[k, 2, 2])
    return 1.0, 1.0, 1.0


@nb.njit(**SHADING_INLINE_JIT)
def corner_opacity(S, mat, g, prim_id, u, v):
    """The per-corner opacity material mat multiplies its opacity by (`materials.opacity`) at the point (u, v) of
    primitive prim_id of gprim g (Embree's barycentrics, or a curve's u): the A of the gprim's `tri_c` rows there,
    interpolated as `corner_color` interpolates their RGB, where mat reads it (bit VC_OPACITY of MI_VERTEX_COLOR:
    the fallback material of a mesh or cloud whose displayOpacity varies, or a reader of it); else 1."""
    if not (F_COLORS and S.mat_i[mat, MI_VERTEX_COLOR] & VC_OPACITY and S.gp_flags[g] & GP_HAS_COLORS):
        return 1.0
    k = S.gp_c_off[g] + prim_id
    c = S.tri_c
    if S.gp_kind[g] == GP_SPHERE:
        return float(c[k, 0, 3])
    if F_CURVES and S.gp_kind[g] == GP_CURVES:
        t = min(1.0, max(0.0, u))
        return (1.0 - t) * c[k, 0, 3] + t * c[k, 1, 3]
    return (1.0 - u - v) * c[k, 0, 3] + u * c[k, 1, 3] + v * c[k, 2, 3]


@nb.njit(**SHADING_INLINE_JIT)
def textured(S, mat):
    """Whether material mat reads an image texture (its hits need texture coordinates)."""
    return F_TEXTURES and (S.mat_i[mat, MI_DIFFUSE_TEX] >= 0 or S.mat_i[mat, MI_SPECULAR_TEX] >= 0
                           or S.mat_i[mat, MI_EMISSION_TEX] >= 0 or _scalar_textured(S, mat)
                           or S.mat_i[mat, MI_NORMAL_TEX] >= 0)


@nb.njit(**SHADING_INLINE_JIT)
def _scalar_textured(S, mat):
    """Whether a texture drives one of material mat's scalar inputs (roughness, ..., `tables.S_ROUGH`)."""
    for k in range(MI_SCALAR_CH - MI_SCALAR_TEX):
        if S.mat_i[mat, MI_SCALAR_TEX + k] >= 0:
            return True
    return False


@nb.njit(**SHADING_INLINE_JIT)
def hit_gprim(S, hit):
    """(placement row, gprim, material) of `hit` (a `records.Hit`): the placement's material set
    overrides the gprim's own binding."""
    row = S.grp_base[hit.inst_id] + hit.inst_prim
    proto = S.in_proto[row]
    g = S.pr_geom_gp[S.pr_geom_off[proto] + hit.geom_id]
    mat = -1
    base = S.in_matset[row]
    if base >= 0:
        mat = S.matset[base + g - S.pr_gp_start[proto]]
    if mat < 0:
        mat = S.gp_material[g]
    return row, g, mat


@nb.njit(**SHADING_INLINE_JIT)
def surface(S, scene, hit, o, d, time, m, m32):
    """The surface at `hit` (a `records.Hit`) of the ray (o, d): (p, ng, ns, st, gprim, material).  `m` (3, 4) float64 and `m32` (12,) float32 are scratch.
    Moving placements take their matrix from Embree (interpolated exactly as it was traced: lerped
    or, for rotations, slerped); static ones use our float64 matrix.
    ng: unit geometric normal (outward), ns: unit shading normal, st: texture coordinates."""
    inst_id, inst_prim, geom_id, prim_id, bu, bv, t = hit
    row, g, mat = hit_gprim(S, hit)
    if F_XF_MOTION and S.in_xf.shape[1] > 1:
        instance_transform(scene, inst_id, inst_prim, time, m32)
        for i in range(3):
            for j in range(4):
                m[i, j] = m32[4 * i + j]
    else:
        lerp_xf(S.in_xf, row, time, m)
    flags = S.gp_flags[g]
    if F_SPHERES and S.gp_kind[g] == GP_SPHERE:
        k = S.gp_off[g] + prim_id                      # (a point cloud's sphere prim_id; a lone sphere's 0)
        c = (S.sph[k, 0], S.sph[k, 1], S.sph[k, 2])
        r = S.sph[k, 3]
        ph = (o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2])
        po, _ = inverse_xform(m, ph, d)
        nobj = normalize((po[0] - c[0], po[1] - c[1], po[2] - c[2]))
        pobj = (c[0] + r * nobj[0], c[1] + r * nobj[1], c[2] + r * nobj[2])
        p = xform_point(m, pobj)
        ng = normalize(cofactor_dir(m, nobj))
        # spherical (lat-long) texture coordinates, +Y up, seam at -X; only for textured materials
        # (an atan2 and an asin per hit otherwise wasted)
        st = sphere_st(nobj) if textured(S, mat) else (0.0, 0.0)
        return p, ng, ng, st, g, mat
    if F_CURVES and S.gp_kind[g] == GP_CURVES:         # the tube's point and normal (`curves.surface_point`)
        ph = (o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2])
        po, vo = inverse_xform(m, ph, d)
        pobj, nobj = surface_point(S, g, S.gp_off[g] + prim_id, bu, po, vo)
        ng = normalize(cofactor_dir(m, nobj))
        return xform_point(m, pobj), ng, ng, (bu, bv), g, mat
    tri = S.gp_off[g] + prim_id
    v = S.tri_v
    w0 = 1.0 - bu - bv
    pobj = (w0 * v[tri, 0, 0] + bu * v[tri, 1, 0] + bv * v[tri, 2, 0],
            w0 * v[tri, 0, 1] + bu * v[tri, 1, 1] + bv * v[tri, 2, 1],
            w0 * v[tri, 0, 2] + bu * v[tri, 1, 2] + bv * v[tri, 2, 2])
    e1 = (float(v[tri, 1, 0]) - v[tri, 0, 0], float(v[tri, 1, 1]) - v[tri, 0, 1], float(v[tri, 1, 2]) - v[tri, 0, 2])
    e2 = (float(v[tri, 2, 0]) - v[tri, 0, 0], float(v[tri, 2, 1]) - v[tri, 0, 1], float(v[tri, 2, 2]) - v[tri, 0, 2])
    p = xform_point(m, pobj)
    ng = normalize(cofactor_dir(m, cross(e1, e2)))
    ns = ng
    if F_NORMALS and flags & GP_HAS_NORMALS:
        k = S.gp_n_off[g] + prim_id
        nn = S.tri_n
        nsum = (w0 * nn[k, 0, 0] + bu * nn[k, 1, 0] + bv * nn[k, 2, 0],
                w0 * nn[k, 0, 1] + bu * nn[k, 1, 1] + bv * nn[k, 2, 1],
                w0 * nn[k, 0, 2] + bu * nn[k, 1, 2] + bv * nn[k, 2, 2])
        if nsum[0] * nsum[0] + nsum[1] * nsum[1] + nsum[2] * nsum[2] > 0.0:
            ns = normalize(cofactor_dir(m, nsum))
    return p, ng, ns, triangle_st(S, g, prim_id, bu, bv), g, mat
