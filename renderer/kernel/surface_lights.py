"""Emissive surfaces as lights of the path integrator (tables: `host/surface_lights.py`): a light sample on
one, and the MIS weight of its emission where a BSDF-sampled ray hits it.

A light sample picks a triangle of the light by area (its cumulative-area table) and a point uniformly on
it, or a point uniformly on a sphere: pdf d^2 / (|cos_l| A) per unit solid angle, A the light's total
area (a sphere's far side, drawn as often, is hidden by its near side: the shadow ray finds it).  An
ellipsoid (centre + A n, n on the unit sphere) is sampled uniformly in n: its density per unit area at
the point of n is 1 / (4 pi |det A| |A^-T n|), the inverse of the map's area element, so A above is
replaced by that point's 4 pi |det A| |A^-T n| (`_ellipsoid_area`), for a light sample and for a hit
alike.  Both sides emit (|cos_l|; the host's module docstring gives the rule).  A ray that hits an
emissive surface finds its light from the hit's placement row and gprim slot (`sl_row`, `sl_idx`; a point
cloud's ball: plus its primitive); a surface that is no light (-1: emission without luminance) keeps
weight 1.  A see-through surface (opacity a) is a light of a times its emission, found by rays with
probability a: its emission where one finds it is MIS-weighted like any other (`host/surface_lights.py`).
A moving placement keeps its object-space triangles or sphere and is placed at the ray's time by the
matrix Embree traced it with (`_placement`): an object area element dA is |cof(M) n| dA in the world, so
A above becomes the object area times that scale (`_moving_point`, `_moving_area`).

A curve segment (CURVE) is sampled in u by CURVE_BINS bins weighted by what each sends the shading point (its
circle's circumference times the curve's speed over the squared distance, at the bin's middle), uniformly within
the bin, and uniformly in angle around its circle (`curves.tube_point`): its density per unit area at the point is
f(u) / (2 pi J), J the tube's area element there, which a hit finds again from its point, Embree's u and the vertex
it came from (`_curve_area_at`): 2 pi J / f(u) takes A's place above.  A linear segment (CURVE_LINEAR) is stored as
the straight Bezier whose tube of circles is its cone's side: a hit finds u from its place along that axis
(`_side_u`).  A round end or joint (CURVE_CAP, `host/curve_caps.py`) is a sphere's part past up to CAP_PLANES planes:
drawn in the cone of directions from the shading point that meet the sphere (uniform in solid angle, the sphere's near
point along it; from inside the sphere, uniformly by area on the cap of its first plane), a point not past every
plane not drawn (`_cap_point`, `_cap_area`: A such that the pdf above is the draw's).
A hit off a segment's side finds the end or joint it lies on among the two its segment names (`_cap_of_hit`); one
that is no light keeps its emission with weight 1 in every strategy.

`L` is the `PathLights` record (`host/light_selection.py`); light k of the tree is surface light
k - L.surface_first.
"""
import math

import numba as nb

from .curves import evaluate, tube_area_element, tube_point
from .features import F_CURVES, F_SPHERES, F_TEXTURES, F_XF_MOTION
from .jit import SHADING_INLINE_JIT as _JIT
from .materials import opacity
from .shapes import corner_opacity, sphere_st, triangle_st
from .tables import (CAP_PLANES, CURVE_CAP, CURVE_LINEAR, GP_CLOUD, GP_CURVES, SLF_AREA, SLF_AXES, SLF_CENTER,
                     SLF_CTRL, SLF_INV, SLF_RAD, SLF_RADIUS, SLI_CAP0, SLI_COUNT, SLI_CURVE, SLI_ELLIPSOID,
                     SLI_EMISSION_TEX, SLI_FIRST, SLI_GPRIM, SLI_INST, SLI_INST_PRIM, SLI_MOVING, SLI_OPACITY_MAT)
from .textures import sample_texture
from .tile_lights import vertex_pmf
from .trace import GEOM_ID, INST_ID, INST_PRIM_ID, PRIM_ID, instance_transform
from .vecmath import (cofactor_dir, cofactors, cross, dot, normalize, offset_origin, onb, sub, to_world, toward, turn,
                      xform_point)

ZERO = (0.0, 0.0, 0.0)
NONE = ((0.0, 0.0, 1.0), 0.0, ZERO, 0.0, False)
ONE_MINUS = 0.99999994


@nb.njit(**_JIT)
def _triangle(cdf, first, n, u):
    """(i, u rescaled to [0, 1)): the triangle i of [0, n) with cdf[first + i - 1] <= u < cdf[first + i]
    (cdf[first - 1] read as 0)."""
    a = 0
    b = n - 1
    while a < b:
        m = (a + b) // 2
        if u < cdf[first + m]:
            b = m
        else:
            a = m + 1
    lo = cdf[first + a - 1] if a > 0 else 0.0
    w = cdf[first + a] - lo
    return a, (min((u - lo) / w, ONE_MINUS) if w > 0.0 else 0.0)


@nb.njit(**_JIT)
def _triangle_point(L, j, u1, u2):
    """(point, unit normal, (triangle, barycentrics b1, b2): where it is, `_st_at`) uniformly by area
    on the triangles of surface light j."""
    first = L.sl_i[j, SLI_FIRST]
    i, u = _triangle(L.sl_cdf, first, L.sl_i[j, SLI_COUNT], u1)
    tri = L.sl_tri[first + i]
    su = math.sqrt(u)
    b1 = u2 * su
    b2 = 1.0 - su
    b0 = 1.0 - b1 - b2
    q = (b0 * tri[0, 0] + b1 * tri[1, 0] + b2 * tri[2, 0], b0 * tri[0, 1] + b1 * tri[1, 1] + b2 * tri[2, 1],
         b0 * tri[0, 2] + b1 * tri[1, 2] + b2 * tri[2, 2])
    e1 = (tri[1, 0] - tri[0, 0], tri[1, 1] - tri[0, 1], tri[1, 2] - tri[0, 2])
    e2 = (tri[2, 0] - tri[0, 0], tri[2, 1] - tri[0, 1], tri[2, 2] - tri[0, 2])
    return q, normalize(cross(e1, e2)), (float(i), b1, b2)


@nb.njit(**_JIT)
def _unit_sphere(u1, u2):
    z = 1.0 - 2.0 * u1
    rr = math.sqrt(max(0.0, 1.0 - z * z))
    cp, sp = turn(u2)
    return rr * cp, rr * sp, z


@nb.njit(**_JIT)
def _sphere_point(L, j, u1, u2):
    """(point, unit normal) uniformly by area on the sphere of surface light j."""
    n = _unit_sphere(u1, u2)
    r = L.sl_f[j, SLF_RADIUS]
    return (L.sl_f[j, SLF_CENTER] + r * n[0], L.sl_f[j, SLF_CENTER + 1] + r * n[1],
            L.sl_f[j, SLF_CENTER + 2] + r * n[2]), n


@nb.njit(**_JIT)
def _ellipsoid_area(L, j, n):
    """(4 pi |det A| |A^-T n|: the inverse of the density per unit area of the ellipsoid of surface light j
    at its point centre + A n (n a unit vector), A^-T n: the direction of its normal there)."""
    f = L.sl_f[j]
    m = (f[SLF_INV] * n[0] + f[SLF_INV + 3] * n[1] + f[SLF_INV + 6] * n[2],     # (A^-1)^T n
         f[SLF_INV + 1] * n[0] + f[SLF_INV + 4] * n[1] + f[SLF_INV + 7] * n[2],
         f[SLF_INV + 2] * n[0] + f[SLF_INV + 5] * n[1] + f[SLF_INV + 8] * n[2])
    return f[SLF_AREA] * math.sqrt(dot(m, m)), m


@nb.njit(**_JIT)
def _ellipsoid_point(L, j, u1, u2):
    """(point, unit normal, 1 / density per unit area there) of the ellipsoid of surface light j, uniform
    in the unit vector n of its point centre + A n."""
    n = _unit_sphere(u1, u2)
    f = L.sl_f[j]
    q = (f[SLF_CENTER] + f[SLF_AXES] * n[0] + f[SLF_AXES + 1] * n[1] + f[SLF_AXES + 2] * n[2],
         f[SLF_CENTER + 1] + f[SLF_AXES + 3] * n[0] + f[SLF_AXES + 4] * n[1] + f[SLF_AXES + 5] * n[2],
         f[SLF_CENTER + 2] + f[SLF_AXES + 6] * n[0] + f[SLF_AXES + 7] * n[1] + f[SLF_AXES + 8] * n[2])
    area, m = _ellipsoid_area(L, j, n)
    return q, normalize(m), area


@nb.njit(**_JIT)
def _control(L, j):
    """The world Bezier control points (x, y, z, radius) of curve light j."""
    f = L.sl_f[j]
    return ((f[SLF_CTRL], f[SLF_CTRL + 1], f[SLF_CTRL + 2], f[SLF_CTRL + 3]),
            (f[SLF_CTRL + 4], f[SLF_CTRL + 5], f[SLF_CTRL + 6], f[SLF_CTRL + 7]),
            (f[SLF_CTRL + 8], f[SLF_CTRL + 9], f[SLF_CTRL + 10], f[SLF_CTRL + 11]),
            (f[SLF_CTRL + 12], f[SLF_CTRL + 13], f[SLF_CTRL + 14], f[SLF_CTRL + 15]))


CURVE_BINS = 8


@nb.njit(**_JIT)
def _bin_weight(q0, q1, q2, q3, k, p):
    """The weight of bin k of a segment seen from p: its circle's circumference times its speed at the bin's middle,
    over its squared distance from p (not below its radius squared): the light the bin sends p, up to the angles."""
    e, d, _ = evaluate(q0, q1, q2, q3, (k + 0.5) / CURVE_BINS)
    x = (p[0] - e[0], p[1] - e[1], p[2] - e[2])
    speed = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    return (abs(e[3]) * speed + 1e-30) / max(x[0] * x[0] + x[1] * x[1] + x[2] * x[2], e[3] * e[3], 1e-30)


@nb.njit(**_JIT)
def _bin_weights(q0, q1, q2, q3, p):
    """The CURVE_BINS weights of a segment's bins seen from p (`_bin_weight`), each evaluated once."""
    return (_bin_weight(q0, q1, q2, q3, 0, p), _bin_weight(q0, q1, q2, q3, 1, p),
            _bin_weight(q0, q1, q2, q3, 2, p), _bin_weight(q0, q1, q2, q3, 3, p),
            _bin_weight(q0, q1, q2, q3, 4, p), _bin_weight(q0, q1, q2, q3, 5, p),
            _bin_weight(q0, q1, q2, q3, 6, p), _bin_weight(q0, q1, q2, q3, 7, p))


@nb.njit(**_JIT)
def _bin_density(q0, q1, q2, q3, p, u):
    """The density in u at u of `_curve_point`'s draw seen from p (piecewise constant over CURVE_BINS bins)."""
    total = 0.0
    mine = 0.0
    k_u = min(CURVE_BINS - 1, max(0, int(u * CURVE_BINS)))
    for k in range(CURVE_BINS):
        w = _bin_weight(q0, q1, q2, q3, k, p)
        total += w
        if k == k_u:
            mine = w
    return CURVE_BINS * mine / total


@nb.njit(**_JIT)
def _curve_point(L, j, p, u1, u2):
    """(point, unit normal, 2 pi J / f(u)) of curve light j seen from p: u drawn with density f among CURVE_BINS
    bins of the segment by their weight from p (`_bin_weight`), uniform within its bin, and the angle uniform around
    the circle; the density per unit area at the point is f(u) / (2 pi J), J the area element there
    (`curves.tube_point`)."""
    q0, q1, q2, q3 = _control(L, j)
    ws = _bin_weights(q0, q1, q2, q3, p)
    total = 0.0
    for k in range(CURVE_BINS):
        total += ws[k]
    target = u1 * total
    acc = 0.0
    k = CURVE_BINS - 1
    w = 0.0
    for i in range(CURVE_BINS):
        w = ws[i]
        if target < acc + w or i == CURVE_BINS - 1:
            k = i
            break
        acc += w
    t = min(max((target - acc) / w, 0.0), ONE_MINUS) if w > 0.0 else 0.5
    u = (k + t) / CURVE_BINS
    q, n, jac = tube_point(q0, q1, q2, q3, u, turn(u2))
    return q, n, 2.0 * math.pi * jac / (CURVE_BINS * w / total)


@nb.njit(**_JIT)
def _curve_area_at(L, j, p0, p, u):
    """2 pi J / f(u) at the point p of curve light j that a ray from p0 hit at Embree's u (`_curve_point`)."""
    q0, q1, q2, q3 = _control(L, j)
    return 2.0 * math.pi * tube_area_element(q0, q1, q2, q3, u, p) / _bin_density(q0, q1, q2, q3, p0, u)


@nb.njit(**_JIT)
def _cap_past(f, n):
    """Whether the unit direction n from the centre of the sphere of cap light row f is past each of its planes
    (n . a >= z): a point of the curve's surface (`host/curve_caps.py`)."""
    for k in range(CAP_PLANES):
        o = SLF_CTRL + 4 * k
        if n[0] * f[o] + n[1] * f[o + 1] + n[2] * f[o + 2] < f[o + 3]:
            return False
    return True


@nb.njit(**_JIT)
def _cap_cone(L, j, p):
    """(axis: the unit direction from p to the centre of the sphere of cap light j, sin^2 and 1 - cos of the
    half-angle of the cone of directions from p that meet it), or 1 - cos = 0 where p is not outside it."""
    f = L.sl_f[j]
    w = (f[SLF_CENTER] - p[0], f[SLF_CENTER + 1] - p[1], f[SLF_CENTER + 2] - p[2])
    d2 = dot(w, w)
    r2 = f[SLF_RADIUS] * f[SLF_RADIUS]
    sin2 = r2 / d2 if d2 > r2 else 0.0
    if not sin2 > 0.0:
        return w, 0.0, 0.0
    dc = math.sqrt(d2)
    return (w[0] / dc, w[1] / dc, w[2] / dc), sin2, sin2 / (1.0 + math.sqrt(1.0 - sin2))


@nb.njit(**_JIT)
def _cap_point(L, j, p, u1, u2):
    """(point, unit normal, 1 / density per unit area there) of cap light j (a linear curve's round end or joint) seen
    from p: a direction uniform in the cone of directions from p that meet its sphere, the sphere's near point along
    it (density 1 / (2 pi (1 - cos)) per unit solid angle); from p inside the sphere, uniform by area on the cap of its
    first plane, n . a >= z.  A point not past its planes is not drawn (1 / density 0: it lies inside a cone)."""
    f = L.sl_f[j]
    r = f[SLF_RADIUS]
    axis, sin2_max, one_minus = _cap_cone(L, j, p)
    if one_minus > 0.0:
        # the direction at angle t from the axis meets the sphere where its normal makes angle alpha with -axis
        v = u1 * one_minus                                   # 1 - cos t
        sin2 = v * (2.0 - v)
        cos_t = 1.0 - v
        cos_a = sin2 / math.sqrt(sin2_max) + cos_t * math.sqrt(max(0.0, 1.0 - sin2 / sin2_max))
        sin_a = math.sqrt(max(0.0, 1.0 - cos_a * cos_a))
        c, s = turn(u2)
        t, b = onb(axis)
        w = to_world((sin_a * c, sin_a * s, cos_a), t, b, axis)
        n = (-w[0], -w[1], -w[2])
    else:
        a = (f[SLF_CTRL], f[SLF_CTRL + 1], f[SLF_CTRL + 2])
        z = 1.0 - u1 * (1.0 - f[SLF_CTRL + 3])
        ring = math.sqrt(max(0.0, 1.0 - z * z))
        c, s = turn(u2)
        t, b = onb(a)
        n = to_world((ring * c, ring * s, z), t, b, a)
    q = (f[SLF_CENTER] + r * n[0], f[SLF_CENTER + 1] + r * n[1], f[SLF_CENTER + 2] + r * n[2])
    if not _cap_past(f, n):
        return q, n, 0.0
    return q, n, _cap_area(L, j, p, q, n, one_minus)


@nb.njit(**_JIT)
def _cap_area(L, j, p, q, n, one_minus):
    """A of `sample_surface`'s pdf d^2 / (|cos_l| A) for the point q (unit normal n) of cap light j seen from p: the
    drawn cap's area from inside its sphere, else d^2 2 pi (1 - cos) / |cos_l| (a density 1 / (2 pi (1 - cos)) per
    unit solid angle)."""
    if not one_minus > 0.0:
        return L.sl_f[j, SLF_AREA]
    v = sub(q, p)
    d2 = dot(v, v)
    cos_l = abs(dot(n, v)) / math.sqrt(d2) if d2 > 0.0 else 0.0
    return d2 * 2.0 * math.pi * one_minus / cos_l if cos_l > 0.0 else 0.0


@nb.njit(**_JIT)
def _cap_of_hit(L, j, p):
    """The cap light (surface-light index) of the point p of linear curve light j off its cone's side: of the
    spheres at the segment's two ends (CAP0, CAP1), the one p lies on (the nearer to its surface) among those p is
    past the planes of, else -1 (an end that is no light)."""
    best = -1
    err = math.inf
    for e in range(2):
        c = L.sl_i[j, SLI_CAP0 + e]
        if c < 0:
            continue
        f = L.sl_f[c]
        x = (p[0] - f[SLF_CENTER], p[1] - f[SLF_CENTER + 1], p[2] - f[SLF_CENTER + 2])
        d = math.sqrt(dot(x, x))
        if d > 0.0 and abs(d - f[SLF_RADIUS]) < err and _cap_past(f, (x[0] / d, x[1] / d, x[2] / d)):
            best = c
            err = abs(d - f[SLF_RADIUS])
    return best


SIDE_TOLERANCE = 1e-3


@nb.njit(**_JIT)
def _side_u(L, j, p):
    """u of the point p of linear curve light j if p is on its cone's side (stored as the straight Bezier whose tube
    of circles the side is: u is p's place along its axis), else -1: a point of a round end or joint, which no light
    sample draws (its emission keeps weight 1).  On the side: within SIDE_TOLERANCE of the segment's larger radius
    (not of r(u), which a tapering tip brings to 0: a side point a light sample can draw must not keep weight 1)."""
    q0, _, _, q3 = _control(L, j)
    axis = (q3[0] - q0[0], q3[1] - q0[1], q3[2] - q0[2])
    x = (p[0] - q0[0], p[1] - q0[1], p[2] - q0[2])
    len2 = dot(axis, axis)
    u = dot(x, axis) / len2 if len2 > 0.0 else -1.0
    if not 0.0 < u < 1.0:
        return -1.0
    r = q0[3] + u * (q3[3] - q0[3])
    y = (x[0] - u * axis[0], x[1] - u * axis[1], x[2] - u * axis[2])
    return u if abs(math.sqrt(dot(y, y)) - r) <= SIDE_TOLERANCE * max(q0[3], q3[3]) else -1.0


@nb.njit(**_JIT)
def _object_dir(L, j, q):
    """The object-space direction from the centre of the sphere or ellipsoid of static surface light j to
    its world point q: A^-1 (q - centre), A its axes (a sphere's: its radius times the placement's linear
    part, whose inverse the host stores for both)."""
    f = L.sl_f[j]
    v = (q[0] - f[SLF_CENTER], q[1] - f[SLF_CENTER + 1], q[2] - f[SLF_CENTER + 2])
    return (f[SLF_INV] * v[0] + f[SLF_INV + 1] * v[1] + f[SLF_INV + 2] * v[2],
            f[SLF_INV + 3] * v[0] + f[SLF_INV + 4] * v[1] + f[SLF_INV + 5] * v[2],
            f[SLF_INV + 6] * v[0] + f[SLF_INV + 7] * v[1] + f[SLF_INV + 8] * v[2])


@nb.njit(**_JIT)
def _ellipsoid_area_at(L, j, p):
    """`_ellipsoid_area` at the point p of the ellipsoid of surface light j (n = A^-1 (p - centre),
    normalised: p is a ray's hit, on the surface to rounding)."""
    return _ellipsoid_area(L, j, normalize(_object_dir(L, j, p)))[0]


@nb.njit(**_JIT)
def _placement(L, tr, j, time):
    """Write the matrix of moving surface light j at the ray time `time` into tr.m (3, 4), Embree's own
    (interpolated exactly as the light's placement was traced: lerped or slerped)."""
    instance_transform(tr.scene, L.sl_i[j, SLI_INST], L.sl_i[j, SLI_INST_PRIM], time, tr.m32)
    for a in range(3):
        for b in range(4):
            tr.m[a, b] = tr.m32[4 * a + b]


@nb.njit(**_JIT)
def _moving_point(L, tr, j, time, u1, u2):
    """(point, unit normal, 1 / density per unit area there) of moving surface light j at `time`: a point
    of its object-space triangles (by object area) or sphere (uniformly), placed by the matrix M at that
    time.  An object area element dA becomes |cof(M) n| dA in the world (n its unit normal), so the world
    density is 1 / (object area x |cof(M) n|) (`_moving_area` at a hit)."""
    _placement(L, tr, j, time)
    if L.sl_i[j, SLI_COUNT] == 0:
        q, n = _sphere_point(L, j, u1, u2)
        at = n                                      # (object space: its direction from the centre)
    else:
        q, n, at = _triangle_point(L, j, u1, u2)
    w = cofactor_dir(tr.m, n)
    return xform_point(tr.m, q), normalize(w), L.sl_f[j, SLF_AREA] * math.sqrt(dot(w, w)), at


@nb.njit(**_JIT)
def _moving_area(L, tr, j, time, ng):
    """1 / the world density per unit area of moving surface light j at a hit at `time` whose unit world
    normal is ng: object area x |cof(M) n| = object area x |det M| / |M^T ng| (n the unit object normal:
    M^T ng = det(M) n / |cof(M) n|)."""
    _placement(L, tr, j, time)
    m = tr.m
    det = cofactors(m)[1]
    t = (m[0, 0] * ng[0] + m[1, 0] * ng[1] + m[2, 0] * ng[2], m[0, 1] * ng[0] + m[1, 1] * ng[1] + m[2, 1] * ng[2],
         m[0, 2] * ng[0] + m[1, 2] * ng[1] + m[2, 2] * ng[2])
    lt = math.sqrt(dot(t, t))
    return L.sl_f[j, SLF_AREA] * abs(det) / lt if lt > 0.0 else 0.0


@nb.njit(**_JIT)
def _st_at(S, L, j, at):
    """The texture coordinates of surface light j at a point of it, `at`: (triangle, b1, b2) on a mesh, the world
    point on a static sphere or ellipsoid, the object-space direction from the centre on a moving sphere: those
    `shapes.surface` gives a ray's hit there."""
    if L.sl_i[j, SLI_COUNT] == 0:
        return sphere_st(normalize(at if L.sl_i[j, SLI_MOVING] != 0 else _object_dir(L, j, at)))
    return triangle_st(S, L.sl_i[j, SLI_GPRIM], int(at[0]), at[1], at[2])


@nb.njit(**_JIT)
def _emission_at(S, L, j, at):
    """The radiance of surface light j at a point of it, `at` (`_st_at`): its factor, times its emissiveColor
    texture there, times its material's textured (or per-corner) opacity there (a(x) E(x): what rays, which find the
    point with probability a(x), see on average)."""
    Le = (L.sl_f[j, SLF_RAD], L.sl_f[j, SLF_RAD + 1], L.sl_f[j, SLF_RAD + 2])
    tex, mat = L.sl_i[j, SLI_EMISSION_TEX], L.sl_i[j, SLI_OPACITY_MAT]
    if not (F_TEXTURES and (tex >= 0 or mat >= 0)):
        return Le
    st = _st_at(S, L, j, at)
    if tex >= 0:
        c = sample_texture(S, tex, st[0], st[1])
        Le = (Le[0] * c[0], Le[1] * c[1], Le[2] * c[2])
    if mat >= 0:
        mesh = L.sl_i[j, SLI_COUNT] != 0
        corner = corner_opacity(S, mat, L.sl_i[j, SLI_GPRIM], int(at[0]), at[1], at[2]) if mesh else 1.0
        a = opacity(S, mat, st, corner)
        Le = (Le[0] * a, Le[1] * a, Le[2] * a)
    return Le


@nb.njit(**_JIT)
def sample_surface(S, L, tr, k, p, time, u1, u2):
    """The light sample of surface light k, as `light_sampling.sample_ld` gives one: (wi, dist, Le, pdf,
    delta = False) seen from p at ray time `time`.
    The point p + dist wi is the sampled point moved just off the surface towards p (`offset_origin`):
    the light is real geometry, which the shadow ray (`shadow_ray`) must stop short of; pdf is that of
    the point on the surface."""
    j = k - L.surface_first
    area = L.sl_f[j, SLF_AREA]
    if F_XF_MOTION and L.sl_i[j, SLI_MOVING] != 0:
        q, nrm, area, at = _moving_point(L, tr, j, time, u1, u2)
    elif L.sl_i[j, SLI_ELLIPSOID] != 0:
        q, nrm, area = _ellipsoid_point(L, j, u1, u2)
        at = q
    elif F_CURVES and L.sl_i[j, SLI_CURVE] == CURVE_CAP:
        q, nrm, area = _cap_point(L, j, p, u1, u2)
        at = q
    elif F_CURVES and L.sl_i[j, SLI_CURVE] != 0:
        q, nrm, area = _curve_point(L, j, p, u1, u2)
        at = q
    elif L.sl_i[j, SLI_COUNT] == 0:
        q, nrm = _sphere_point(L, j, u1, u2)
        at = q
    else:
        q, nrm, at = _triangle_point(L, j, u1, u2)
    Le = _emission_at(S, L, j, at)
    wi, d, d2 = toward(p, q)
    if d2 <= 0.0 or not area > 0.0:
        return NONE
    c = dot(nrm, wi)
    if c == 0.0:
        return NONE
    pdf = d2 / (abs(c) * area)
    qo = offset_origin(q, (-nrm[0], -nrm[1], -nrm[2]) if c > 0.0 else nrm, S.offset_scale[0])
    v = sub((float(qo[0]), float(qo[1]), float(qo[2])), p)
    d = math.sqrt(dot(v, v))
    if not d > 0.0:
        return NONE
    return (v[0] / d, v[1] / d, v[2] / d), d, Le, pdf, False


@nb.njit(**_JIT)
def shadow_ray(vtx, wi, dist, eps):
    """(direction, tmax) of the shadow ray from the vertex's ray origin vtx.po to the point p + dist wi
    that `sample_surface` gave (off the light's surface): aimed point to point, because po is off the
    receiver's surface and a ray from it along wi would meet the light's own surface before its end."""
    p, po = vtx.p, vtx.po
    v = (p[0] + dist * wi[0] - po[0], p[1] + dist * wi[1] - po[1], p[2] + dist * wi[2] - po[2])
    d = math.sqrt(dot(v, v))
    if not d > 0.0:                                 # (the point is po itself: no ray, `path.light_sample` drops it)
        return wi, 0.0
    return (v[0] / d, v[1] / d, v[2] / d), d * (1.0 - eps)


@nb.njit(**_JIT)
def light_of_hit(S, L, u):
    """The light (tree index) of the surface hit in the ray buffer's ids `u`, or -1."""
    row = S.grp_base[u[INST_ID]] + u[INST_PRIM_ID]
    base = L.sl_row[row]
    if base < 0:
        return -1
    proto = S.in_proto[row]
    g = S.pr_geom_gp[S.pr_geom_off[proto] + u[GEOM_ID]]
    k = L.sl_idx[base + g - S.pr_gp_start[proto]]
    if F_SPHERES and k >= 0 and S.gp_flags[g] & GP_CLOUD:
        k += u[PRIM_ID]                              # a point cloud's point: its placement's lights, in order
    if F_CURVES and k >= 0 and S.gp_kind[g] == GP_CURVES:
        k += u[PRIM_ID]                              # a curve segment: its placement's lights, in order
    return k


@nb.njit(**_JIT)
def surface_emission(S, L, tr, Le, hit, prev):
    """Emission Le of the surface hit (ids in the ray buffer tr.u; hit = (its point, its unit geometric
    normal, the ray's direction, the ray's time)) MIS-weighted against the light sample that could have
    drawn it; prev = (p0, n0, bsdf pdf, mode) as in `light_sampling.shape_emission`; hit[4]: its texture
    coordinates (a curve's: Embree's u first)."""
    k = light_of_hit(S, L, tr.u)
    if k < 0:
        return Le
    j = k - L.surface_first
    u = hit[4][0]
    if F_CURVES and L.sl_i[j, SLI_CURVE] == CURVE_LINEAR:
        u = _side_u(L, j, hit[0])
        if u < 0.0:
            j = _cap_of_hit(L, j, hit[0])
            if j < 0:
                return Le
            k = j + L.surface_first
    p0, pb, mode = prev[0], prev[2], prev[3]
    if mode == 2:
        return ZERO
    if mode == 1:
        return Le
    p, ng, d, time = hit[0], hit[1], hit[2], hit[3]
    v = sub(p, p0)
    cos_l = abs(dot(ng, d))
    if not cos_l > 0.0:
        return Le
    if F_XF_MOTION and L.sl_i[j, SLI_MOVING] != 0:
        area = _moving_area(L, tr, j, time, ng)
    elif L.sl_i[j, SLI_ELLIPSOID] != 0:
        area = _ellipsoid_area_at(L, j, p)
    elif F_CURVES and L.sl_i[j, SLI_CURVE] == CURVE_CAP:           # (`_cap_area` at the hit)
        one_minus = _cap_cone(L, j, p0)[2]
        area = dot(v, v) * 2.0 * math.pi * one_minus / cos_l if one_minus > 0.0 else L.sl_f[j, SLF_AREA]
    elif F_CURVES and L.sl_i[j, SLI_CURVE] != 0:
        area = _curve_area_at(L, j, p0, p, u)
        if not area > 0.0:                          # (a point of no area: no light sample draws it)
            return Le
    else:
        area = L.sl_f[j, SLF_AREA]
    pl = vertex_pmf(L, tr.tl, prev, k) * dot(v, v) / (cos_l * area)
    w = pb * pb / (pb * pb + pl * pl)
    return w * Le[0], w * Le[1], w * Le[2]
