"""The surface of a curve segment at a hit, as Embree's round curves intersect it (measured: the hits of
`tests/renderer/test_curves.py` lie on these surfaces to float32 precision):

* a cubic (Bezier) segment: the tube of circles of radius r(u) centred on the curve c(u), each in the plane
  perpendicular to the curve there (where the radius is constant: the swept sphere's tube);
* a linear segment: the cone tangent to the spheres of its two ends, with those spheres (round joints and ends):
  the envelope of the spheres of radius r(u) swept along it.

Embree reports the parameter u of the hit's circle or sphere (to float32 precision: refining it by Newton's method on
(p - c) . c' (+ r r' for spheres) changed no test's result, measured).  `surface_point` evaluates the segment there
in float64 and puts the point back on that circle or sphere, c + r w, as `shapes.surface` puts a sphere's hit on the
sphere: its error does not grow with the length of the ray, and new rays leave from the surface, not from inside it.
The normal: a sphere's, w; a circle's, from the surface's two tangents (`_circle_normal`: it leans back along the
curve where the radius grows).

Ribbons (BasisCurves with normals: Embree's normal-oriented Bezier curves) keep Embree's hit point: Embree tessellates
them, and its u is not the parameter of the hit's cross-section (measured: hits 1e-3 of the radius off the plane the
curve's tangent and interpolated normal span there, and up to 0.12 along the curve), so the point cannot be rebuilt
on an exact surface as a tube's is.  Their normal: the Bezier of the control points' normals at u, without its part
along the curve (a shading and offset direction within a small angle of the tessellation's own).

Rows (`SceneData.crv`, float32 (k, 4, 4)): a segment's control points x, y, z, radius, as Embree has them; a
linear segment's two ends in rows 0 and 1 (`GP_LINEAR`), read here as the Bezier of the same line.
"""
import math

import numba as nb

from .jit import SHADING_INLINE_JIT
from .tables import GP_LINEAR, GP_RIBBON
from .vecmath import onb


@nb.njit(**SHADING_INLINE_JIT)
def _control(c, k, linear, i):
    """Bezier control point i (x, y, z, r) of segment row k (a linear row's line, its points at thirds)."""
    if linear:
        a, b = (3 - i) / 3.0, i / 3.0
        return (a * c[k, 0, 0] + b * c[k, 1, 0], a * c[k, 0, 1] + b * c[k, 1, 1],
                a * c[k, 0, 2] + b * c[k, 1, 2], a * c[k, 0, 3] + b * c[k, 1, 3])
    return float(c[k, i, 0]), float(c[k, i, 1]), float(c[k, i, 2]), float(c[k, i, 3])


@nb.njit(**SHADING_INLINE_JIT)
def _weights(u):
    """Cubic Bernstein weights at u and those of the first and second derivatives."""
    s = 1.0 - u
    return ((s * s * s, 3.0 * s * s * u, 3.0 * s * u * u, u * u * u),
            (-3.0 * s * s, 3.0 * s * s - 6.0 * s * u, 6.0 * s * u - 3.0 * u * u, 3.0 * u * u),
            (6.0 * s, 6.0 * u - 12.0 * s, 6.0 * s - 12.0 * u, 6.0 * u))


@nb.njit(**SHADING_INLINE_JIT)
def evaluate(q0, q1, q2, q3, u):
    """(position and radius, first derivative, second derivative) of the Bezier q0..q3 (4-tuples) at u."""
    w, dw, ddw = _weights(u)
    c = (w[0] * q0[0] + w[1] * q1[0] + w[2] * q2[0] + w[3] * q3[0],
         w[0] * q0[1] + w[1] * q1[1] + w[2] * q2[1] + w[3] * q3[1],
         w[0] * q0[2] + w[1] * q1[2] + w[2] * q2[2] + w[3] * q3[2],
         w[0] * q0[3] + w[1] * q1[3] + w[2] * q2[3] + w[3] * q3[3])
    d = (dw[0] * q0[0] + dw[1] * q1[0] + dw[2] * q2[0] + dw[3] * q3[0],
         dw[0] * q0[1] + dw[1] * q1[1] + dw[2] * q2[1] + dw[3] * q3[1],
         dw[0] * q0[2] + dw[1] * q1[2] + dw[2] * q2[2] + dw[3] * q3[2],
         dw[0] * q0[3] + dw[1] * q1[3] + dw[2] * q2[3] + dw[3] * q3[3])
    dd = (ddw[0] * q0[0] + ddw[1] * q1[0] + ddw[2] * q2[0] + ddw[3] * q3[0],
          ddw[0] * q0[1] + ddw[1] * q1[1] + ddw[2] * q2[1] + ddw[3] * q3[1],
          ddw[0] * q0[2] + ddw[1] * q1[2] + ddw[2] * q2[2] + ddw[3] * q3[2],
          ddw[0] * q0[3] + ddw[1] * q1[3] + ddw[2] * q2[3] + ddw[3] * q3[3])
    return c, d, dd


@nb.njit(**SHADING_INLINE_JIT)
def surface_point(S, g, k, u, po, vo):
    """(point on the surface, unit outward normal) in object space of segment row k of curves gprim g at Embree's
    u, for the object-space hit point po of a ray of direction vo."""
    c = S.crv
    linear = S.gp_flags[g] & GP_LINEAR != 0
    q0, q1, q2, q3 = _control(c, k, linear, 0), _control(c, k, linear, 1), _control(c, k, linear, 2), \
        _control(c, k, linear, 3)
    e, d, dd = evaluate(q0, q1, q2, q3, min(1.0, max(0.0, u)))
    speed = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    if S.gp_flags[g] & GP_RIBBON:                       # (Embree's own point: see the module's notes)
        return po, _ribbon_normal(S, S.gp_n_off[g] + k - S.gp_off[g], min(1.0, max(0.0, u)), d, speed, vo)
    x = (po[0] - e[0], po[1] - e[1], po[2] - e[2])
    r = e[3]
    if not linear and speed > 0.0:                      # the circle's plane: x without its part along the curve
        t = (d[0] / speed, d[1] / speed, d[2] / speed)
        a = x[0] * t[0] + x[1] * t[1] + x[2] * t[2]
        x = (x[0] - a * t[0], x[1] - a * t[1], x[2] - a * t[2])
    n2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2]
    if n2 > 0.0:
        inv = 1.0 / math.sqrt(n2)
        w = (x[0] * inv, x[1] * inv, x[2] * inv)
    else:                                               # (the hit on the curve's axis: face the ray)
        inv = -1.0 / math.sqrt(vo[0] * vo[0] + vo[1] * vo[1] + vo[2] * vo[2])
        w = (vo[0] * inv, vo[1] * inv, vo[2] * inv)
    p = (e[0] + r * w[0], e[1] + r * w[1], e[2] + r * w[2])
    if linear or not speed > 0.0:                       # a sphere's normal (constant radius: the circle's too)
        return p, w
    return p, _circle_normal(d, dd, r, speed, w)


@nb.njit(**SHADING_INLINE_JIT)
def _ribbon_normal(S, j, u, d, speed, vo):
    """A ribbon's unit normal at u of segment j's normals (`crv_n`): the Bezier of its four control points' normals,
    without its part along the curve (the ribbon's own direction across is perpendicular to both)."""
    c = S.crv_n
    s = 1.0 - u
    w = (s * s * s, 3.0 * s * s * u, 3.0 * s * u * u, u * u * u)
    n = (w[0] * c[j, 0, 0] + w[1] * c[j, 1, 0] + w[2] * c[j, 2, 0] + w[3] * c[j, 3, 0],
         w[0] * c[j, 0, 1] + w[1] * c[j, 1, 1] + w[2] * c[j, 2, 1] + w[3] * c[j, 3, 1],
         w[0] * c[j, 0, 2] + w[1] * c[j, 1, 2] + w[2] * c[j, 2, 2] + w[3] * c[j, 3, 2])
    if speed > 0.0:
        a = (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) / (speed * speed)
        n = (n[0] - a * d[0], n[1] - a * d[1], n[2] - a * d[2])
    n2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2]
    if not n2 > 0.0:                                    # (no usable normal: face the ray)
        n, n2 = (-vo[0], -vo[1], -vo[2]), vo[0] * vo[0] + vo[1] * vo[1] + vo[2] * vo[2]
    inv = 1.0 / math.sqrt(n2)
    return n[0] * inv, n[1] * inv, n[2] * inv


@nb.njit(**SHADING_INLINE_JIT)
def _circle_cross(d, dd, r, speed, w):
    """a w - r' t, a = |c'| - r w . t' (t: the unit tangent, t' = dt/du): at c + r w of the surface of circles of
    radius r(u) perpendicular to the curve (w: unit, perpendicular to c'), the cross product of the surface's two
    tangents divided by r (those of u, the circle's carried along the curve without twisting, and of its angle)."""
    t = (d[0] / speed, d[1] / speed, d[2] / speed)
    b = dd[0] * t[0] + dd[1] * t[1] + dd[2] * t[2]
    tp = ((dd[0] - b * t[0]) / speed, (dd[1] - b * t[1]) / speed, (dd[2] - b * t[2]) / speed)
    a = speed - r * (w[0] * tp[0] + w[1] * tp[1] + w[2] * tp[2])
    return a * w[0] - d[3] * t[0], a * w[1] - d[3] * t[1], a * w[2] - d[3] * t[2]


@nb.njit(**SHADING_INLINE_JIT)
def _circle_normal(d, dd, r, speed, w):
    """The unit normal at c + r w of the surface of circles (`_circle_cross`): it leans back along the curve where
    the radius grows."""
    n = _circle_cross(d, dd, r, speed, w)
    inv = 1.0 / math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
    return n[0] * inv, n[1] * inv, n[2] * inv


@nb.njit(**SHADING_INLINE_JIT)
def tube_point(q0, q1, q2, q3, u, cs):
    """(point, unit normal, area element J) of the tube of circles of the Bezier segment q0..q3 (x, y, z, radius) at
    u and at the angle whose (cos, sin) is cs around its circle, from a frame perpendicular to the curve (`onb`):
    J = r |a w - r' t| (`_circle_cross`) is the area the map (u, angle) -> point covers per unit of both; J = 0 where
    the segment has no tangent."""
    e, d, dd = evaluate(q0, q1, q2, q3, u)
    speed = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    if not speed > 0.0:
        return (e[0], e[1], e[2]), (0.0, 0.0, 1.0), 0.0
    b1, b2 = onb((d[0] / speed, d[1] / speed, d[2] / speed))
    w = (cs[0] * b1[0] + cs[1] * b2[0], cs[0] * b1[1] + cs[1] * b2[1], cs[0] * b1[2] + cs[1] * b2[2])
    r = e[3]
    n = _circle_cross(d, dd, r, speed, w)
    m = math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
    return (e[0] + r * w[0], e[1] + r * w[1], e[2] + r * w[2]), (n[0] / m, n[1] / m, n[2] / m), abs(r) * m


@nb.njit(**SHADING_INLINE_JIT)
def tube_area_element(q0, q1, q2, q3, u, p):
    """J (`tube_point`) at the point p of the tube of circles of the Bezier segment q0..q3 at u (its angle: p's
    direction from the curve, without its part along it); 0 where it has none."""
    e, d, dd = evaluate(q0, q1, q2, q3, min(1.0, max(0.0, u)))
    speed = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    if not speed > 0.0:
        return 0.0
    x = (p[0] - e[0], p[1] - e[1], p[2] - e[2])
    a = (x[0] * d[0] + x[1] * d[1] + x[2] * d[2]) / (speed * speed)
    x = (x[0] - a * d[0], x[1] - a * d[1], x[2] - a * d[2])
    n2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2]
    if not n2 > 0.0:
        return 0.0
    inv = 1.0 / math.sqrt(n2)
    n = _circle_cross(d, dd, e[3], speed, (x[0] * inv, x[1] * inv, x[2] * inv))
    return abs(e[3]) * math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
