"""A rect light's points drawn towards a glossy lobe: the second strategy of a rect light's light sample
at a vertex with a narrow GGX lobe (`light_sampling.sample_ld_lobe`).

Seen from a glossy vertex, the light that a rect light reflects towards the viewer comes from where
the lobe's mirror direction r meets the light's plane, within a few 2 alpha t of it (t: the distance
along r; 2 alpha: the spread of the reflected direction about r, twice the GGX slopes' scale).  A
sample drawn uniformly over the light's solid angle rarely lands there when the lobe is narrow, and a
BSDF sample misses the light at the highlight's edge, where the lobe straddles the light's border:
there both strategies are noisy, and MIS cannot make either better.  This strategy draws the point
(a, b) of the rect (q = c + a ex + b ey, a in [-w/2, w/2], b in [-h/2, h/2]) from two independent
Cauchy distributions centred at the lobe's point (a0, b0), scale 2 alpha t in each axis, each truncated
to the rect's side: a product density that follows the lobe where it lies on the light and the lobe's
tail where it does not (the GGX slope distribution falls as 1 / x^3 away from its peak; Cauchy's 1 / x^2
is heavier, so the strategy never under-samples the lobe's tail).  Its density is positive over the
whole rect, in closed form (`cauchy_pdf`), and its inverse CDF is one tangent (`cauchy_sample`), both
computed without cancellation however far the lobe's point lies outside the rect.

The light sample draws from the mixture (1 - beta) uniform + beta lobe, beta the probability of the
vertex's GGX lobe (`glossy_lobe`), and both the light sample and a BSDF-sampled ray that finds the
light weigh it by the mixture's pdf (`light_sampling.hit_shape` and `shape_emission`).
"""
import math

import numba as nb

from .bsdf import L_GGX
from .features import B_GGX, F_MODELS
from .jit import SHADING_INLINE_JIT as _JIT
from .vecmath import cross, dot, sub, to_world

# The widest lobe (GGX alpha, roughness 0.5) sampled this way: a wider lobe covers the rect more evenly
# than the uniform strategy would miss it.
LOBE_ALPHA_MAX = 0.25
# The smallest cosine between r and the light's normal for which the lobe's point is computed (beyond
# it the point is nearly at infinity and the strategy would be uniform by area).
LOBE_MIN_COS = 1e-3
NO_LOBE = (0.0, 0.0, 1.0, 0.0, 0.0)             # (r x, y, z, spread 2 alpha, beta): beta = 0, not used
NO_WINDOW = (False, (0.0, 1.0, 0.0, 1.0, 1.0), (0.0, 1.0, 0.0, 1.0, 1.0), 1.0)


@nb.njit(**_JIT)
def glossy_lobe(sb, frame):
    """(r world, 2 alpha, beta) of the vertex whose BSDF seen from its wo is sb (`bsdf.seen_from`) and
    whose shading frame is frame = (tt, bb, ns): its GGX lobe's mirror direction, spread and probability;
    NO_LOBE without a GGX lobe of alpha <= LOBE_ALPHA_MAX."""
    if not F_MODELS & B_GGX:
        return NO_LOBE
    alpha = sb.b.alpha
    beta = sb.p[L_GGX]
    if not (0.0 < alpha <= LOBE_ALPHA_MAX and beta > 0.0):
        return NO_LOBE
    wo = sb.wo
    r = to_world((-wo[0], -wo[1], wo[2]), frame[0], frame[1], frame[2])
    return r[0], r[1], r[2], 2.0 * alpha, beta


@nb.njit(**_JIT)
def rect_coords(q, c, ex, ey, nrm):
    """(a, b) with q - c = a ex + b ey, for q in the plane of ex, ey (which need be neither unit nor
    orthogonal)."""
    rv = sub(q, c)
    cy = cross(ey, nrm)
    cx = cross(nrm, ex)
    return dot(rv, cy) / dot(ex, cy), dot(rv, cx) / dot(ey, cx)


@nb.njit(**_JIT)
def _cauchy(x0, s, half):
    """The Cauchy distribution of centre x0 and scale s truncated to [-half, half]: (x0, s, A, delta, half),
    A = (-half - x0) / s and delta = atan(B) - atan(A) > 0 its mass in angle (B = (half - x0) / s),
    computed from the side's length, not from A and B, so that a centre far outside the side loses no
    digits."""
    A = (-half - x0) / s
    B = (half - x0) / s
    w = 2.0 * half / s
    ab = A * B
    if ab > -1.0:
        delta = math.atan(w / (1.0 + ab))
    else:
        delta = math.atan(B) - math.atan(A)
    return x0, s, A, delta, half


@nb.njit(**_JIT)
def cauchy_sample(cw, u):
    """The point of the truncated Cauchy cw (`_cauchy`) at CDF u: x0 + s tan(atan A + u delta), by
    the tangent's addition formula (A may be huge), within the side [-half, half]."""
    x0, s, A, delta, half = cw
    tau = math.tan(u * delta)
    den = 1.0 - A * tau                   # (negative where u delta > pi / 2: tau < 0 there)
    if den == 0.0:                        # x at infinity: the far end, by rounding
        return half
    return min(max(x0 + s * (A + tau) / den, -half), half)


@nb.njit(**_JIT)
def cauchy_pdf(cw, x):
    """The density of the truncated Cauchy cw at x (inside its window)."""
    z = (x - cw[0]) / cw[1]
    return 1.0 / (cw[1] * cw[3] * (1.0 + z * z))


@nb.njit(**_JIT)
def lobe_window(p, lobe, plane, w, h):
    """(valid, Cauchy of a, Cauchy of b, |ex x ey|) of the rect light plane = (c, ex, ey, nrm) of sides w, h
    seen from p with `glossy_lobe` lobe; not valid when the lobe's mirror direction does not meet the
    light's plane from its emitting side."""
    c, ex, ey, nrm = plane
    den = lobe[0] * nrm[0] + lobe[1] * nrm[1] + lobe[2] * nrm[2]
    if not den > LOBE_MIN_COS:
        return NO_WINDOW
    t = dot(sub(c, p), nrm) / den
    if not t > 0.0:
        return NO_WINDOW
    m = (p[0] + t * lobe[0], p[1] + t * lobe[1], p[2] + t * lobe[2])
    a0, b0 = rect_coords(m, c, ex, ey, nrm)
    s = lobe[3] * t
    lx = math.sqrt(dot(ex, ex))
    ly = math.sqrt(dot(ey, ey))
    if not (s > 0.0 and math.isfinite(a0) and math.isfinite(b0)):
        return NO_WINDOW
    jac = cross(ex, ey)
    return True, _cauchy(a0, s / lx, 0.5 * w), _cauchy(b0, s / ly, 0.5 * h), math.sqrt(dot(jac, jac))


@nb.njit(**_JIT)
def lobe_area_pdf(win, a, b):
    """The lobe strategy's density per unit area of the rect at its point (a, b)."""
    return cauchy_pdf(win[1], a) * cauchy_pdf(win[2], b) / win[3]


@nb.njit(**_JIT)
def mixture_pdf(p, lobe, rect, pu, q):
    """The solid-angle pdf with which `light_sampling.sample_ld_lobe` draws the point q of the rect light
    rect = (plane (c, ex, ey, nrm), w, h) from p with `glossy_lobe` lobe; pu: the uniform strategy's pdf
    of q."""
    plane, w, h = rect
    win = lobe_window(p, lobe, plane, w, h)
    if not win[0]:
        return pu
    a, b = rect_coords(q, plane[0], plane[1], plane[2], plane[3])
    v = sub(q, p)
    d2 = dot(v, v)
    cos_l = dot(v, plane[3]) / math.sqrt(d2) if d2 > 0.0 else 0.0
    if not cos_l > 0.0:
        return pu
    beta = lobe[4]
    return (1.0 - beta) * pu + beta * lobe_area_pdf(win, a, b) * d2 / cos_l
