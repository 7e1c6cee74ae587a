"""Spheres as Embree user geometry (``RTC_GEOMETRY_TYPE_USER``): the ray-sphere test in float64, in numba
``@cfunc`` callbacks that Embree calls from its traversal.

Why: Embree's own ``RTC_GEOMETRY_TYPE_SPHERE_POINT`` costs a ray that reaches a sphere as much as a 16k-triangle
tessellation of it; with this test a one-sphere scene takes 20 against 39 ns a ray in ``rtcOccluded16``
packets, 23 against 56 in ``rtcIntersect16``, 60 against 72 alone (RESULTS.md, "Spheres as user geometry";
path renders of sphere scenes 1.08-1.16x faster a sample).  Not for point clouds: 10,000 spheres in one
geometry are 2.5x slower in packets (Embree calls the callback per leaf for few lanes), and an Embree scene
that holds curves too is traversed 1.6x slower (`build.path_top` keeps Embree's spheres there).

The callbacks (Embree 4.4 structs, `/work/shared/embree.md` section 4, 64-bit):

* bounds  ``{void* user @0, u32 primID @8, u32 timeStep @12, RTCBounds* @16}``;
* intersect ``{int* valid @0, void* user @8, u32 primID @16, RTCRayQueryContext* @24, RTCRayHitN* @32,
  u32 N @40, u32 geomID @44}``, occluded the same with an RTCRayN*.

``user`` points at float64 rows (x, y, z, r), one per primitive.  A hit reports what SPHERE_POINT reports:
t, Ng = p - c (object space, unnormalised), u = v = 0, the primID and geomID, and the instance it was
found in (the query context's instID / instPrimID, which a user geometry must copy itself).  The nearer
root at or beyond tnear is the hit (the farther one from inside); the roots come from the numerically
stable quadratic (the discriminant from the distance of the centre to the ray's line, Haines et al.,
Ray Tracing Gems ch. 7), in float64, so a sphere far from the ray origin loses no precision.

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


@nb.njit(cache=True, inline='always')
def _roots(R, N, i, s):
    """The ray of lane i of the RTCRay(Hit)N R against the sphere s (float64 x, y, z, r): (hit, t0, t1,
    origin - centre), t0 <= t1 the ray parameters of the two crossings."""
    ox = np.float64(R[_ORG * N + i]) - s[0]
    oy = np.float64(R[(_ORG + 1) * N + i]) - s[1]
    oz = np.float64(R[(_ORG + 2) * N + i]) - s[2]
    dx = np.float64(R[_DIR * N + i])
    dy = np.float64(R[(_DIR + 1) * N + i])
    dz = np.float64(R[(_DIR + 2) * N + i])
    a = dx * dx + dy * dy + dz * dz
    b = ox * dx + oy * dy + oz * dz                   # half the linear coefficient
    c = ox * ox + oy * oy + oz * oz - s[3] * s[3]
    if a == 0.0:
        return False, 0.0, 0.0, (ox, oy, oz)
    # b^2 - a c from the centre's distance to the ray's line: no cancellation for a far sphere
    inv_a = 1.0 / a
    k = b * inv_a
    lx = ox - k * dx
    ly = oy - k * dy
    lz = oz - k * dz
    disc = a * (s[3] * s[3] - (lx * lx + ly * ly + lz * lz))
    if not disc >= 0.0:
        return False, 0.0, 0.0, (ox, oy, oz)
    q = -(b + math.copysign(math.sqrt(disc), b))
    if q == 0.0:                                      # the origin on the sphere, the ray tangent
        return True, 0.0, 0.0, (ox, oy, oz)
    t0 = q * inv_a
    t1 = c / q
    if t0 > t1:
        t0, t1 = t1, t0
    return True, t0, t1, (ox, oy, oz)


@nb.cfunc(_SIG, nopython=True, cache=True)
def _bounds(args):
    a = nb.carray(_u64p(args), 3)
    prim = a[1] & 0xFFFFFFFF
    s = nb.carray(_f64p(a[0] + prim * 32), 4)
    box = nb.carray(_f32p(a[2]), 8)
    r = s[3]
    for j in range(3):        # float32 bounds that contain the float64 sphere
        box[j] = np.nextafter(np.float32(s[j] - r), np.float32(-np.inf))
        box[4 + j] = np.nextafter(np.float32(s[j] + r), np.float32(np.inf))


@nb.cfunc(_SIG, nopython=True, cache=True)
def _intersect(args):
    a = nb.carray(_u64p(args), 6)
    n = np.int64(a[5] & 0xFFFFFFFF)
    geom = np.uint32(a[5] >> 32)
    prim = np.uint32(a[2] & 0xFFFFFFFF)
    valid = nb.carray(_i32p(a[0]), n)
    s = nb.carray(_f64p(a[1] + prim * 32), 4)
    context = nb.carray(_u32p(a[3]), 2)
    R = nb.carray(_f32p(a[4]), 21 * n)
    RI = nb.carray(_u32p(a[4]), 21 * n)
    for i in range(n):
        if valid[i] == 0:
            continue
        hit, t0, t1, oc = _roots(R, n, i, s)
        if not hit:
            continue
        tnear = np.float64(R[_TNEAR * n + i])
        t = t0 if t0 >= tnear else t1
        if t < tnear or t > R[_TFAR * n + i]:
            continue
        R[_TFAR * n + i] = t
        R[_NG * n + i] = oc[0] + t * R[_DIR * n + i]
        R[(_NG + 1) * n + i] = oc[1] + t * R[(_DIR + 1) * n + i]
        R[(_NG + 2) * n + i] = oc[2] + t * R[(_DIR + 2) * n + i]
        R[_U * n + i] = 0.0
        R[_V * n + i] = 0.0
        RI[_PRIM * n + i] = prim
        RI[_GEOM * n + i] = geom
        RI[_INST * n + i] = context[0]
        RI[_INST_PRIM * n + i] = context[1]


@nb.cfunc(_SIG, nopython=True, cache=True)
def _occluded(args):
    a = nb.carray(_u64p(args), 6)
    n = np.int64(a[5] & 0xFFFFFFFF)
    prim = np.uint32(a[2] & 0xFFFFFFFF)
    valid = nb.carray(_i32p(a[0]), n)
    s = nb.carray(_f64p(a[1] + prim * 32), 4)
    R = nb.carray(_f32p(a[4]), 12 * n)
    for i in range(n):
        if valid[i] == 0:
            continue
        hit, t0, t1, _ = _roots(R, n, i, s)
        if not hit:
            continue
        tnear = np.float64(R[_TNEAR * n + i])
        tfar = np.float64(R[_TFAR * n + i])
        if (tnear <= t0 <= tfar) or (tnear <= t1 <= tfar):
            R[_TFAR * n + i] = -np.inf


def rows(centers_radii) -> np.ndarray:
    """The float64 rows (x, y, z, r) the callbacks read, one per sphere (a fresh contiguous array)."""
    return np.array(centers_radii, np.float64).reshape(-1, 4)


BOUNDS, INTERSECT, OCCLUDED = _bounds.address, _intersect.address, _occluded.address
