"""Scalar vector helpers for the numba kernels (float64 triples passed as plain tuples), and the
robust ray-origin offset.

Tuples keep everything in registers; numba inlines these.  The offset follows Waechter & Binder,
"A Fast and Robust Method for Avoiding Self-Intersection" (Ray Tracing Gems, ch. 6): move the float32
origin by a fixed number of ULPs along the geometric normal, which is scale-invariant; near the origin
(|p| < scale/32), where ULPs vanish, by a fixed float distance scale/65536.  Ray Tracing Gems uses
scale = 1, which assumes objects of size ~1 or more: a scene scaled by 1e-4 then loses its contact
shadows (the fixed offset is 0.15 of the scene's own units).  `build.offset_scale` shrinks `scale`
with the smallest placed object, so the offset is invariant under a global change of units.
"""
import math

import numba as nb
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from .jit import INLINE_JIT


@intrinsic
def _f32_bits(typingctx, x):
    sig = types.int32(types.float32)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(32))
    return sig, codegen


@intrinsic
def _bits_f32(typingctx, x):
    sig = types.float32(types.int32)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.FloatType())
    return sig, codegen


@nb.njit(**INLINE_JIT)
def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@nb.njit(**INLINE_JIT)
def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@nb.njit(**INLINE_JIT)
def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@nb.njit(**INLINE_JIT)
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@nb.njit(**INLINE_JIT)
def scale(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


@nb.njit(**INLINE_JIT)
def mul(a, b):
    return (a[0] * b[0], a[1] * b[1], a[2] * b[2])


@nb.njit(**INLINE_JIT)
def madd(a, b, s):
    """a + s * b"""
    return (a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2])


@nb.njit(**INLINE_JIT)
def length(a):
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@nb.njit(**INLINE_JIT)
def normalize(a):
    """a / |a| ((0, 0, 1) for a zero vector).  One reciprocal and three products, not three
    divisions: the shading code is bound by the latency of square-root -> division chains
    (perf, ellipsoids.xml: the hottest instructions of the kernel were normalisations' divisions)."""
    n2 = a[0] * a[0] + a[1] * a[1] + a[2] * a[2]
    if n2 > 0.0:
        inv = 1.0 / math.sqrt(n2)
        return (a[0] * inv, a[1] * inv, a[2] * inv)
    return (0.0, 0.0, 1.0)


@nb.njit(**INLINE_JIT)
def reflect(d, n):
    """Mirror direction of incident d about n."""
    k = 2.0 * dot(d, n)
    return (d[0] - k * n[0], d[1] - k * n[1], d[2] - k * n[2])


@nb.njit(**INLINE_JIT)
def sincos_quarter(x):
    """(sin x, cos x) for |x| <= pi/4: Taylor polynomials to x^15 / x^16 (truncation < 1e-16),
    a few multiply-adds instead of two libm calls."""
    x2 = x * x
    s = x * (1.0 + x2 * (-1.0 / 6.0 + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (
        1.0 / 362880.0 + x2 * (-1.0 / 39916800.0 + x2 * (1.0 / 6227020800.0 + x2 * (-1.0 / 1307674368000.0))))))))
    c = 1.0 + x2 * (-0.5 + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40320.0 + x2 * (
        -1.0 / 3628800.0 + x2 * (1.0 / 479001600.0 + x2 * (-1.0 / 87178291200.0 + x2 * (1.0 / 20922789888000.0))))))))
    return s, c


@nb.njit(**INLINE_JIT)
def turn(u):
    """(cos 2 pi u, sin 2 pi u) for u in [0, 1) (a sample's azimuth): u is reduced exactly to the
    nearest quarter turn k / 4, the rest x in [-pi/4, pi/4] goes through `sincos_quarter` (error
    ~1e-16, as libm's), and the quadrant k swaps and signs them without a branch.  The path
    integrator's samplers call it instead of libm's sincos, which took 8 % of a diffuse path render
    (perf, Cornell box: a call per bounce and light sample)."""
    q = 4.0 * u
    k = math.floor(q + 0.5)
    s, c = sincos_quarter((q - k) * (0.5 * math.pi))      # q - k is exact
    m = np.int64(k) & 3
    swap = (m & 1) == 1
    cs = s if swap else c
    sn = c if swap else s
    return (1 - 2 * (((m + 1) >> 1) & 1)) * cs, (1 - 2 * ((m >> 1) & 1)) * sn


@nb.njit(**INLINE_JIT)
def onb(n):
    """Orthonormal tangents (t, b) of unit n (Duff et al. 2017, branchless)."""
    s = 1.0 if n[2] >= 0.0 else -1.0
    a = -1.0 / (s + n[2])
    bb = n[0] * n[1] * a
    t = (1.0 + s * n[0] * n[0] * a, s * bb, -s * n[0])
    b = (bb, s + n[1] * n[1] * a, -n[1])
    return t, b


@nb.njit(**INLINE_JIT)
def to_world(local, t, b, n):
    return (local[0] * t[0] + local[1] * b[0] + local[2] * n[0],
            local[0] * t[1] + local[1] * b[1] + local[2] * n[1],
            local[0] * t[2] + local[1] * b[2] + local[2] * n[2])


@nb.njit(**INLINE_JIT)
def xform_point(m, p):
    """m: (3, 4) float64 array view, column-vector convention."""
    return (m[0, 0] * p[0] + m[0, 1] * p[1] + m[0, 2] * p[2] + m[0, 3],
            m[1, 0] * p[0] + m[1, 1] * p[1] + m[1, 2] * p[2] + m[1, 3],
            m[2, 0] * p[0] + m[2, 1] * p[1] + m[2, 2] * p[2] + m[2, 3])


@nb.njit(**INLINE_JIT)
def xform_dir(m, v):
    return (m[0, 0] * v[0] + m[0, 1] * v[1] + m[0, 2] * v[2],
            m[1, 0] * v[0] + m[1, 1] * v[1] + m[1, 2] * v[2],
            m[2, 0] * v[0] + m[2, 1] * v[1] + m[2, 2] * v[2])


@nb.njit(**INLINE_JIT)
def cofactors(m):
    """Cofactor matrix C (row-major 9-tuple) and determinant of the 3x3 part L of m.
    C = det(L) L^-T, so L^-1 = C^T / det(L)."""
    c00 = m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1]
    c01 = m[1, 2] * m[2, 0] - m[1, 0] * m[2, 2]
    c02 = m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0]
    c10 = m[0, 2] * m[2, 1] - m[0, 1] * m[2, 2]
    c11 = m[0, 0] * m[2, 2] - m[0, 2] * m[2, 0]
    c12 = m[0, 1] * m[2, 0] - m[0, 0] * m[2, 1]
    c20 = m[0, 1] * m[1, 2] - m[0, 2] * m[1, 1]
    c21 = m[0, 2] * m[1, 0] - m[0, 0] * m[1, 2]
    c22 = m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0]
    det = m[0, 0] * c00 + m[0, 1] * c01 + m[0, 2] * c02
    return (c00, c01, c02, c10, c11, c12, c20, c21, c22), det


@nb.njit(**INLINE_JIT)
def cofactor_dir(m, v):
    """sign(det L) cof(L) v = |det L| L^-T v.  Normals transform with L^-T; the cofactor form needs
    no division, stays finite for near-singular L, and with the sign keeps a mirrored (det < 0)
    placement's outside outside."""
    c, det = cofactors(m)
    sgn = 1.0 if det >= 0.0 else -1.0
    return (sgn * (c[0] * v[0] + c[1] * v[1] + c[2] * v[2]),
            sgn * (c[3] * v[0] + c[4] * v[1] + c[5] * v[2]),
            sgn * (c[6] * v[0] + c[7] * v[1] + c[8] * v[2]))


@nb.njit(**INLINE_JIT)
def inverse_xform(m, p, v):
    """Object-space point and direction of a world point p and direction v under m = [L | T]
    (L^-1 = cof(L)^T / det L)."""
    c, det = cofactors(m)
    inv = 1.0 / det
    q = (p[0] - m[0, 3], p[1] - m[1, 3], p[2] - m[2, 3])
    po = ((c[0] * q[0] + c[3] * q[1] + c[6] * q[2]) * inv,
          (c[1] * q[0] + c[4] * q[1] + c[7] * q[2]) * inv,
          (c[2] * q[0] + c[5] * q[1] + c[8] * q[2]) * inv)
    vo = ((c[0] * v[0] + c[3] * v[1] + c[6] * v[2]) * inv,
          (c[1] * v[0] + c[4] * v[1] + c[7] * v[2]) * inv,
          (c[2] * v[0] + c[5] * v[1] + c[8] * v[2]) * inv)
    return po, vo


OFFSET_INT_SCALE = 256.0
OFFSET_FLOAT_SCALE = 1.0 / 65536.0
OFFSET_ORIGIN = 1.0 / 32.0


@nb.njit(**INLINE_JIT)
def _offset1(p, n, scale):
    pf = np.float32(p)
    if abs(pf) < OFFSET_ORIGIN * scale:
        return np.float32(pf + np.float32(OFFSET_FLOAT_SCALE * scale * n))
    of = np.int32(OFFSET_INT_SCALE * n)
    bits = _f32_bits(pf)
    if pf < 0:
        return _bits_f32(np.int32(bits - of))
    return _bits_f32(np.int32(bits + of))


@nb.njit(**INLINE_JIT)
def offset_origin(p, n, scale):
    """float32-representable origin just off the surface at p on the side n points to (n unit).
    `scale` (a power of two <= 1, `SceneData.offset_scale[0]`) scales the near-origin fallback."""
    return (_offset1(p[0], n[0], scale), _offset1(p[1], n[1], scale), _offset1(p[2], n[2], scale))


@nb.njit(**INLINE_JIT)
def lerp_xf(xf, row, time, out):
    """Instance matrix of `row` at normalised shutter time in [0, 1] (Embree lerps time steps the same
    way), written into out (3, 4)."""
    k = xf.shape[1]
    if k == 1:
        for i in range(3):
            for j in range(4):
                out[i, j] = xf[row, 0, i, j]
        return
    f = time * (k - 1)
    k0 = min(int(f), k - 2)
    a = f - k0
    for i in range(3):
        for j in range(4):
            out[i, j] = (1.0 - a) * xf[row, k0, i, j] + a * xf[row, k0 + 1, i, j]


@nb.njit(**INLINE_JIT)
def toward(p, q):
    """(unit direction, distance, squared distance) from p to q; all zero (direction +Z) when they
    coincide."""
    v = sub(q, p)
    d2 = dot(v, v)
    if d2 <= 0.0:
        return (0.0, 0.0, 1.0), 0.0, 0.0
    d = math.sqrt(d2)
    return (v[0] / d, v[1] / d, v[2] / d), d, d2
