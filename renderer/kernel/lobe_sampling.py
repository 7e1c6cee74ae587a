"""A light's points drawn towards a glossy lobe: the light sample of a rect or disk light at a vertex with a
narrow GGX lobe (`light_sampling.sample_ld_lobe`).

Seen from a glossy vertex, the light that a light shape reflects towards the viewer comes from where
the lobe's mirror direction r meets the light, within a few 2 alpha t of it (t: the distance
along r; 2 alpha: the spread of the reflected direction about r, twice the GGX slopes' scale).  A
sample drawn uniformly over the light's solid angle rarely lands there when the lobe is narrow, and a
BSDF sample misses the light at the highlight's edge, where the lobe straddles the light's border:
there both strategies are noisy, and MIS cannot make either better.  This strategy draws the point
(a, b) of the rect (q = c + a ex + b ey, a in [-w/2, w/2], b in [-h/2, h/2]) from two independent
Cauchy distributions centred at the lobe's point (a0, b0), each truncated to the rect's side, of scale
2 alpha t / |x - (r.x) r| along each unit axis x of the rect (an angle e about r moves the point by
e t / |x - (r.x) r| along x: the footprint stretches along the axis r runs along): a product density
that follows the lobe where it lies on the light and the lobe's tail where it does not (the GGX slope
distribution falls as 1 / x^3 away from its peak; Cauchy's 1 / x^2 is heavier, so the strategy never
under-samples the lobe's tail).  Its density is positive over the whole rect, in closed form
(`cauchy_pdf`), and its inverse CDF is one tangent (`cauchy_sample`), both computed without
cancellation however far the lobe's point lies outside the rect.

A disk light is drawn the same way over its bounding square; a point of the square outside the disk is a
sample of no light (the density is a sub-probability over the disk: unbiased, and the BSDF ray that meets the
light gets the same density).  Those samples are lost, up to 1 - pi/4 of them where the density is flat over
the square: a disk takes this strategy only where the lobe's footprint is narrower than the disk (both Cauchy
scales below LOBE_NARROW times its radius) and meets it (LOBE_REACH).  Sphere lights keep their uniform cone:
the same strategy on the plane across the cone's axis (a direction w + a tt + b bb, its density the plane's
times cos^3) was measured and not kept (no gain in relative RMSE on two scenes of metals under a sphere light,
1.07-1.17x the time; benchmarks/RESULTS.md): a sphere light's cone is narrow beside its distance, so a lobe
rarely sees it much wider than itself.

A vertex whose GGX lobe carries most of its albedo (`glossy_lobe`: a metal, a mirror-like coat) draws its
lights' samples this way instead of uniformly, and a BSDF-sampled ray from it that meets the light is
weighed by this strategy's pdf (`lobe_pdf`, in `light_sampling.shape_emission`).
"""
import math

import numba as nb

from .bsdf import L_GGX
from .features import B_GGX, B_PLANAR, F_LIGHTS, F_MODELS
from .jit import SHADING_INLINE_JIT as _JIT
from .vecmath import cross, dot, sub, to_world

# The widest lobe (GGX alpha, roughness 0.5) sampled this way: a wider lobe covers the rect more evenly
# than the uniform strategy would miss it.
LOBE_ALPHA_MAX = 0.25
# The smallest cosine between r and the light's normal for which the lobe's point is computed (beyond
# it the point is nearly at infinity and the strategy would be uniform by area).
LOBE_MIN_COS = 1e-3
# The share of a vertex's albedo its GGX lobe must carry for its light samples to follow it: below it they
# serve the diffuse lobe (uniform in the rect's solid angle).  One strategy or the other, not a mixture:
# splitting the light sample's first number between two strategies cost the stratification of both (a
# plastic floor under a rect light: relative RMSE 1.20-1.27x at 16 spp, even with the lobe strategy made
# uniform; benchmarks/RESULTS.md).
LOBE_SHARE_MIN = 0.5
NO_LOBE = (0.0, 0.0, 1.0, 0.0, 0.0)             # (r x, y, z, spread 2 alpha, in use 1 / 0)
NO_WINDOW = (False, (0.0, 1.0, 0.0, 1.0, 1.0), (0.0, 1.0, 0.0, 1.0, 1.0), 1.0)
NO_FOOTPRINT = (False, 0.0, 0.0, 1.0, 1.0, 1.0)
# A disk takes the strategy where both Cauchy scales are below LOBE_NARROW times its radius: a wider lobe
# covers the disk about evenly, and the uniform strategy loses no samples.
LOBE_NARROW = 1.0
# ... and where the lobe's point lies within LOBE_REACH Cauchy scales of the disk's edge: farther out, the
# truncated density piles up in the bounding square's corner nearest it, mostly outside the disk.
LOBE_REACH = 2.0
NO_PLANE = ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


@nb.njit(**_JIT)
def glossy_lobe(sb, frame):
    """(r world, 2 alpha, 1) of the vertex whose BSDF seen from its wo is sb (`bsdf.seen_from`) and whose
    shading frame is frame = (tt, bb, ns), when its GGX lobe, of alpha <= LOBE_ALPHA_MAX, carries at least
    LOBE_SHARE_MIN of its albedo at wo (the lobe's probability: a metal's, not a plastic's): its mirror
    direction and spread; else NO_LOBE."""
    if not (F_MODELS & B_GGX and F_LIGHTS & B_PLANAR):      # (no GGX lobe, or no light to draw towards it)
        return NO_LOBE
    alpha = sb.b.alpha
    if not (0.0 < alpha <= LOBE_ALPHA_MAX and sb.p[L_GGX] >= LOBE_SHARE_MIN):
        return NO_LOBE
    wo = sb.wo
    r = to_world((-wo[0], -wo[1], wo[2]), frame[0], frame[1], frame[2])
    return r[0], r[1], r[2], 2.0 * alpha, 1.0


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
def lobe_footprint(p, lobe, plane):
    """(valid, a0, b0, sx, sy, |ex x ey|): where the `glossy_lobe` lobe's mirror direction from p meets the light
    plane = (c, ex, ey, nrm) (a0, b0: in the coordinates of q = c + a ex + b ey), and the Cauchy scales along ex
    and ey; not valid when it does not meet the plane from the emitting side."""
    c, ex, ey, nrm = plane
    den = lobe[0] * nrm[0] + lobe[1] * nrm[1] + lobe[2] * nrm[2]
    if not den > LOBE_MIN_COS:
        return NO_FOOTPRINT
    t = dot(sub(c, p), nrm) / den
    if not t > 0.0:
        return NO_FOOTPRINT
    m = (p[0] + t * lobe[0], p[1] + t * lobe[1], p[2] + t * lobe[2])
    a0, b0 = rect_coords(m, c, ex, ey, nrm)
    s = lobe[3] * t
    lx = math.sqrt(dot(ex, ex))
    ly = math.sqrt(dot(ey, ey))
    if not (s > 0.0 and math.isfinite(a0) and math.isfinite(b0)):
        return NO_FOOTPRINT
    # an angle e about r moves the point along the unit axis x of the plane by e t / |x - (r.x) r|: the
    # lobe's footprint stretches along an axis r runs along
    rx = (lobe[0] * ex[0] + lobe[1] * ex[1] + lobe[2] * ex[2]) / lx
    ry = (lobe[0] * ey[0] + lobe[1] * ey[1] + lobe[2] * ey[2]) / ly
    sx = s / (lx * math.sqrt(max(1.0 - rx * rx, 1e-12)))
    sy = s / (ly * math.sqrt(max(1.0 - ry * ry, 1e-12)))
    jac = cross(ex, ey)
    return True, a0, b0, sx, sy, math.sqrt(dot(jac, jac))


@nb.njit(**_JIT)
def lobe_window(p, lobe, plane, w, h):
    """(valid, Cauchy of a, Cauchy of b, |ex x ey|) of the rect light plane = (c, ex, ey, nrm) of sides w, h
    seen from p with `glossy_lobe` lobe (`lobe_footprint`); not valid when the lobe's mirror direction does
    not meet the light's plane from its emitting side."""
    f = lobe_footprint(p, lobe, plane)
    if not f[0]:
        return NO_WINDOW
    return True, _cauchy(f[1], f[3], 0.5 * w), _cauchy(f[2], f[4], 0.5 * h), f[5]


@nb.njit(**_JIT)
def round_window(p, lobe, plane, radius):
    """`lobe_window` of a disk of radius `radius` in plane (its bounding square) where the lobe's footprint is
    narrower than the disk and meets it (its point within LOBE_REACH scales of the disk's edge), else NO_WINDOW."""
    f = lobe_footprint(p, lobe, plane)
    s = max(f[3], f[4])
    reach = radius + LOBE_REACH * s
    if not (f[0] and s < LOBE_NARROW * radius and f[1] * f[1] + f[2] * f[2] < reach * reach):
        return NO_WINDOW
    return True, _cauchy(f[1], f[3], radius), _cauchy(f[2], f[4], radius), f[5]


@nb.njit(**_JIT)
def lobe_area_pdf(win, a, b):
    """The lobe strategy's density per unit area of the rect at its point (a, b)."""
    return cauchy_pdf(win[1], a) * cauchy_pdf(win[2], b) / win[3]


@nb.njit(**_JIT)
def lobe_pdf(win, plane, lim, po, q):
    """The solid-angle pdf with which `light_sampling.sample_ld_lobe` draws, from po, the point q of the
    light's plane (c, ex, ey, nrm) in the window win (`lobe_window`, `round_window`); 0 outside the disk of
    radius lim (inf for a rect)."""
    a, b = rect_coords(q, plane[0], plane[1], plane[2], plane[3])
    if a * a + b * b > lim * lim:
        return 0.0
    v = sub(q, po)
    d2 = dot(v, v)
    cos_l = dot(v, plane[3]) / math.sqrt(d2) if d2 > 0.0 else 0.0
    if not cos_l > 0.0:
        return 0.0
    return lobe_area_pdf(win, a, b) * d2 / cos_l
