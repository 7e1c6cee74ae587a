"""Shapes rtc tests itself, as Embree user geometry (``RTC_GEOMETRY_TYPE_USER``): spheres and open cylinders,
their ray tests in float64, in numba ``@cfunc`` callbacks that Embree calls from its traversal.  The path
integrator's top level uses them (`build.path_top`); the cook integrator keeps Embree's spheres.

Why: Embree's own ``RTC_GEOMETRY_TYPE_SPHERE_POINT`` costs a ray that reaches a sphere as much as a 16k-triangle
tessellation of it; with this test a one-sphere scene takes 20 against 39 ns a ray in ``rtcOccluded16``
packets, 23 against 56 in ``rtcIntersect16``, 60 against 72 alone (RESULTS.md, "Spheres as user geometry";
path renders of sphere scenes 1.08-1.16x faster a sample).  Cylinders (the cylinder lights' shapes) were
Embree round linear curves (capsules), and an Embree scene that holds curves and user geometry together is
traversed 1.6x slower: so they are user geometry too, the exact open cylinder.  Not for point clouds:
10,000 spheres in one geometry are 2.5x slower in packets (Embree calls the callback per leaf for few lanes).

The callbacks (Embree 4.4 structs, `/work/shared/embree.md` section 4, 64-bit):

* bounds  ``{void* user @0, u32 primID @8, u32 timeStep @12, RTCBounds* @16}``;
* intersect ``{int* valid @0, void* user @8, u32 primID @16, RTCRayQueryContext* @24, RTCRayHitN* @32,
  u32 N @40, u32 geomID @44}``, occluded the same with an RTCRayN*.

``user`` points at float64 rows: spheres (x, y, z, r), cylinders (x0, y0, z0, x1, y1, z1, r, 0), one per
primitive.  A hit reports what Embree's own primitives report: t, Ng (object space, unnormalised: p - c on
a sphere, the radial vector on a cylinder), u = v = 0, the primID and geomID, and the instance it was found
in (the query context's instID / instPrimID, which a user geometry must copy itself).  The nearer crossing
at or beyond tnear is the hit (the farther one from inside; a cylinder's side only, between its ends);
the roots come from the numerically stable quadratic (the discriminant from the distance of the centre,
or axis, to the ray's line: Haines et al., Ray Tracing Gems ch. 7), in float64, so a shape far from the ray
origin loses no precision.

Lifetime: Embree keeps the raw pointer, not the array: `embree.Device` keeps the rows alive as long as any
scene that holds the geometry (`embree.Scene.keep`).
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np
from numba import types
from numba.extending import intrinsic

_SIG = types.void(types.uint64)          # every callback takes the address of its arguments struct


def _pointer_intrinsic(ty):
    @intrinsic
    def as_pointer(typingctx, address):
        sig = types.CPointer(ty)(address)

        def codegen(context, builder, signature, args):
            return builder.inttoptr(args[0], context.get_value_type(types.CPointer(ty)))
        return sig, codegen
    return as_pointer


_f32p = _pointer_intrinsic(types.float32)
_f64p = _pointer_intrinsic(types.float64)
_u32p = _pointer_intrinsic(types.uint32)
_i32p = _pointer_intrinsic(types.int32)
_u64p = _pointer_intrinsic(types.uint64)

# field k of an RTCRayHitN lives at k * N + lane (4-byte fields)
_ORG, _TNEAR, _DIR, _TFAR = 0, 3, 4, 8
_NG, _U, _V, _PRIM, _GEOM, _INST, _INST_PRIM = 12, 15, 16, 17, 18, 19, 20
SPHERE_FLOATS, CYLINDER_FLOATS = 4, 8          # float64 a row


@nb.njit(cache=True, inline='always')
def _lane_ray(R, N, i):
    """(origin, direction) of lane i of the RTCRay(Hit)N R, in float64."""
    o = (np.float64(R[_ORG * N + i]), np.float64(R[(_ORG + 1) * N + i]), np.float64(R[(_ORG + 2) * N + i]))
    d = (np.float64(R[_DIR * N + i]), np.float64(R[(_DIR + 1) * N + i]), np.float64(R[(_DIR + 2) * N + i]))
    return o, d


@nb.njit(cache=True, inline='always')
def _quadratic(a, b, c, l2, r2):
    """(real, t0, t1): the roots t0 <= t1 of a t^2 + 2 b t + c = 0, whose discriminant b^2 - a c is given as
    a (r2 - l2) (l2: the squared distance of the centre, or axis, to the ray's line: no cancellation)."""
    disc = a * (r2 - l2)
    if a == 0.0 or not disc >= 0.0:
        return False, 0.0, 0.0
    q = -(b + math.copysign(math.sqrt(disc), b))
    if q == 0.0:                                      # the origin on the surface, the ray tangent
        return True, 0.0, 0.0
    t0 = q / a
    t1 = c / q
    return True, min(t0, t1), max(t0, t1)


@nb.njit(cache=True, inline='always')
def _sphere(o, d, s):
    """(real, t0, t1, o - c) of the ray (o, d) against the sphere row s."""
    oc = (o[0] - s[0], o[1] - s[1], o[2] - s[2])
    a = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
    b = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2]
    k = b / a if a > 0.0 else 0.0
    l2 = (oc[0] - k * d[0]) ** 2 + (oc[1] - k * d[1]) ** 2 + (oc[2] - k * d[2]) ** 2
    real, t0, t1 = _quadratic(a, b, oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - s[3] * s[3], l2, s[3] * s[3])
    return real, t0, t1, oc


@nb.njit(cache=True, inline='always')
def _cylinder(o, d, c):
    """(real, t0, t1, the parts across the axis of o - p0 and of d, the axial parts (in units of the
    length) of o - p0 and of d) of the ray (o, d) against the infinite cylinder of the row c."""
    ax = (c[3] - c[0], c[4] - c[1], c[5] - c[2])
    inv_l2 = 1.0 / (ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2])
    oc = (o[0] - c[0], o[1] - c[1], o[2] - c[2])
    sa = (oc[0] * ax[0] + oc[1] * ax[1] + oc[2] * ax[2]) * inv_l2
    da = (d[0] * ax[0] + d[1] * ax[1] + d[2] * ax[2]) * inv_l2
    op = (oc[0] - sa * ax[0], oc[1] - sa * ax[1], oc[2] - sa * ax[2])
    dp = (d[0] - da * ax[0], d[1] - da * ax[1], d[2] - da * ax[2])
    a = dp[0] * dp[0] + dp[1] * dp[1] + dp[2] * dp[2]
    b = op[0] * dp[0] + op[1] * dp[1] + op[2] * dp[2]
    k = b / a if a > 0.0 else 0.0
    l2 = (op[0] - k * dp[0]) ** 2 + (op[1] - k * dp[1]) ** 2 + (op[2] - k * dp[2]) ** 2
    real, t0, t1 = _quadratic(a, b, op[0] * op[0] + op[1] * op[1] + op[2] * op[2] - c[6] * c[6], l2, c[6] * c[6])
    return real, t0, t1, op, dp, sa, da


@nb.njit(cache=True, inline='always')
def _report(R, RI, N, i, t, ng, ids, context):
    """Write the hit at t (normal ng) of ids = (primitive, geometry) into lane i of the RTCRayHitN R."""
    R[_TFAR * N + i] = t
    R[_NG * N + i] = ng[0]
    R[(_NG + 1) * N + i] = ng[1]
    R[(_NG + 2) * N + i] = ng[2]
    R[_U * N + i] = 0.0
    R[_V * N + i] = 0.0
    RI[_PRIM * N + i] = ids[0]
    RI[_GEOM * N + i] = ids[1]
    RI[_INST * N + i] = context[0]
    RI[_INST_PRIM * N + i] = context[1]


@nb.njit(cache=True, inline='always')
def _args(args, floats):
    """(N, geomID, primID, valid, the primitive's row, the query context, the rays as float32 and uint32)."""
    a = nb.carray(_u64p(args), 6)
    n = np.int64(a[5] & 0xFFFFFFFF)
    prim = np.uint32(a[2] & 0xFFFFFFFF)
    row = nb.carray(_f64p(a[1] + prim * floats * 8), floats)
    return (n, np.uint32(a[5] >> 32), prim, nb.carray(_i32p(a[0]), n), row, nb.carray(_u32p(a[3]), 2),
            nb.carray(_f32p(a[4]), 21 * n), nb.carray(_u32p(a[4]), 21 * n))


@nb.njit(cache=True, inline='always')
def _box(args, lo, hi):
    """Write float32 bounds that contain [lo, hi] (float64) into the RTCBounds of the bounds arguments."""
    a = nb.carray(_u64p(args), 3)
    box = nb.carray(_f32p(a[2]), 8)
    for j in range(3):
        box[j] = np.nextafter(np.float32(lo[j]), np.float32(-np.inf))
        box[4 + j] = np.nextafter(np.float32(hi[j]), np.float32(np.inf))


@nb.njit(cache=True, inline='always')
def _row(args, floats):
    a = nb.carray(_u64p(args), 3)
    return nb.carray(_f64p(a[0] + (a[1] & 0xFFFFFFFF) * floats * 8), floats)


# ----------------------------------------------------------------------------- spheres
@nb.cfunc(_SIG, nopython=True, cache=True)
def _sphere_bounds(args):
    s = _row(args, SPHERE_FLOATS)
    r = s[3]
    _box(args, (s[0] - r, s[1] - r, s[2] - r), (s[0] + r, s[1] + r, s[2] + r))


@nb.njit(cache=True, inline='always')
def _sphere_t(R, N, i, s):
    """(t of the nearest crossing of sphere row s at or beyond tnear and within tfar, or -1; p - c there)."""
    o, d = _lane_ray(R, N, i)
    real, t0, t1, oc = _sphere(o, d, s)
    tnear = np.float64(R[_TNEAR * N + i])
    t = t0 if t0 >= tnear else t1
    if real and tnear <= t <= R[_TFAR * N + i]:
        return t, (oc[0] + t * d[0], oc[1] + t * d[1], oc[2] + t * d[2])
    return -1.0, (0.0, 0.0, 0.0)


@nb.cfunc(_SIG, nopython=True, cache=True)
def _sphere_intersect(args):
    n, geom, prim, valid, s, context, R, RI = _args(args, SPHERE_FLOATS)
    for i in range(n):
        if valid[i] != 0:
            t, ng = _sphere_t(R, n, i, s)
            if t >= 0.0:
                _report(R, RI, n, i, t, ng, (prim, geom), context)


@nb.cfunc(_SIG, nopython=True, cache=True)
def _sphere_occluded(args):
    n, _, _, valid, s, _, R, _ = _args(args, SPHERE_FLOATS)
    for i in range(n):
        if valid[i] != 0 and _sphere_t(R, n, i, s)[0] >= 0.0:
            R[_TFAR * n + i] = -np.inf


# ----------------------------------------------------------------------------- open cylinders
@nb.cfunc(_SIG, nopython=True, cache=True)
def _cylinder_bounds(args):
    c = _row(args, CYLINDER_FLOATS)
    r = c[6]
    _box(args, (min(c[0], c[3]) - r, min(c[1], c[4]) - r, min(c[2], c[5]) - r),
         (max(c[0], c[3]) + r, max(c[1], c[4]) + r, max(c[2], c[5]) + r))


@nb.njit(cache=True, inline='always')
def _cylinder_t(R, N, i, c):
    """(t of the nearest crossing of the side of cylinder row c at or beyond tnear and within tfar, or
    -1; the radial vector there)."""
    o, d = _lane_ray(R, N, i)
    real, t0, t1, op, dp, sa, da = _cylinder(o, d, c)
    tnear = np.float64(R[_TNEAR * N + i])
    tfar = np.float64(R[_TFAR * N + i])
    if real:
        for t in (t0, t1):
            if tnear <= t <= tfar and 0.0 <= sa + t * da <= 1.0:
                return t, (op[0] + t * dp[0], op[1] + t * dp[1], op[2] + t * dp[2])
    return -1.0, (0.0, 0.0, 0.0)


@nb.cfunc(_SIG, nopython=True, cache=True)
def _cylinder_intersect(args):
    n, geom, prim, valid, c, context, R, RI = _args(args, CYLINDER_FLOATS)
    for i in range(n):
        if valid[i] != 0:
            t, ng = _cylinder_t(R, n, i, c)
            if t >= 0.0:
                _report(R, RI, n, i, t, ng, (prim, geom), context)


@nb.cfunc(_SIG, nopython=True, cache=True)
def _cylinder_occluded(args):
    n, _, _, valid, c, _, R, _ = _args(args, CYLINDER_FLOATS)
    for i in range(n):
        if valid[i] != 0 and _cylinder_t(R, n, i, c)[0] >= 0.0:
            R[_TFAR * n + i] = -np.inf


def sphere_rows(centers_radii) -> np.ndarray:
    """The float64 rows (x, y, z, r) the sphere callbacks read, one per sphere (a fresh contiguous array)."""
    return np.array(centers_radii, np.float64).reshape(-1, SPHERE_FLOATS)


def cylinder_rows(segments) -> np.ndarray:
    """The float64 rows (x0, y0, z0, x1, y1, z1, r, 0) the cylinder callbacks read, from segments (k, 2, 4):
    the two ends' x, y, z and the radius (the first end's), as Embree's round linear curves take them."""
    seg = np.asarray(segments, np.float64).reshape(-1, 2, 4)
    rows = np.zeros((len(seg), CYLINDER_FLOATS))
    rows[:, 0:3], rows[:, 3:6], rows[:, 6] = seg[:, 0, :3], seg[:, 1, :3], seg[:, 0, 3]
    return rows


SPHERES = (_sphere_bounds.address, _sphere_intersect.address, _sphere_occluded.address)
CYLINDERS = (_cylinder_bounds.address, _cylinder_intersect.address, _cylinder_occluded.address)
