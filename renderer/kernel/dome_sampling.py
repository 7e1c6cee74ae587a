"""A textured dome light's directions drawn by importance: the piecewise-constant distribution over its
lat-long image that `host/light_images.py` tabulates (texels weighted by luminance x sin(theta); one
marginal CDF over rows, one conditional CDF per row), its inverse (`sample_dome_texture`) and its density
per unit solid angle (`dome_pdf`, which also gives an untextured dome's cosine-weighted pdf), for
`light_sampling.sample_ld` and for the MIS weight of a ray that escapes (`light_sampling.escaped_emission`).
"""
import math

import numba as nb

from .features import F_DOME_TEXTURE
from .jit import SHADING_INLINE_JIT as _JIT
from .tables import LF_M
from .vecmath import dot, normalize


@nb.njit(**_JIT)
def _search(cdf, lo, n, u):
    """Largest i in [0, n) with cdf[lo + i] <= u (cdf[lo] = 0, cdf[lo + n] = 1)."""
    a = 0
    b = n
    while b - a > 1:
        m = (a + b) // 2
        if cdf[lo + m] <= u:
            a = m
        else:
            b = m
    return a


@nb.njit(**_JIT)
def invert(cdf, lo, n, u):
    """(i, where u lies in bin i as a fraction of it, the bin's probability) of the piecewise-constant
    distribution of CDF cdf[lo .. lo + n] at u; probability 0: an empty bin (no fraction)."""
    i = _search(cdf, lo, n, u)
    c0 = cdf[lo + i]
    p = cdf[lo + i + 1] - c0
    return i, ((u - c0) / p if p > 0.0 else 0.0), p


@nb.njit(**_JIT)
def _axis(lf, k, j):
    return normalize((lf[k, LF_M + j], lf[k, LF_M + 4 + j], lf[k, LF_M + 8 + j]))


@nb.njit(**_JIT)
def _dome_frame(S, k):
    lf = S.li_f
    return _axis(lf, k, 0), _axis(lf, k, 1), _axis(lf, k, 2)


@nb.njit(**_JIT)
def sample_dome_texture(S, L, k, u1, u2):
    """(world direction, solid-angle pdf) from the piecewise-constant distribution of the dome's
    lat-long image (texels weighted by luminance x sin(theta)); rows = latitude, top row = +Y."""
    moff, coff, w, h = L.image_i[k, 0], L.image_i[k, 1], L.image_i[k, 2], L.image_i[k, 3]
    y, fy, pm = invert(L.image_cdf, moff, h, u2)
    if not pm > 0.0:
        return (0.0, 0.0, 1.0), 0.0
    x, fx, pc = invert(L.image_cdf, coff + y * (w + 1), w, u1)
    if not pc > 0.0:
        return (0.0, 0.0, 1.0), 0.0
    s = (x + fx) / w
    v = (y + fy) / h
    lat = (0.5 - v) * math.pi
    lon = (0.5 - s) * 2.0 * math.pi
    cl = math.cos(lat)
    if cl <= 0.0:
        return (0.0, 0.0, 1.0), 0.0
    loc = (cl * math.sin(lon), math.sin(lat), cl * math.cos(lon))
    ax, ay, az = _dome_frame(S, k)
    wd = (loc[0] * ax[0] + loc[1] * ay[0] + loc[2] * az[0], loc[0] * ax[1] + loc[1] * ay[1] + loc[2] * az[1],
          loc[0] * ax[2] + loc[1] * ay[2] + loc[2] * az[2])
    return wd, pm * pc * w * h / (2.0 * math.pi * math.pi * cl)


@nb.njit(**_JIT)
def dome_pdf(S, L, k, wd, n):
    """Solid-angle pdf with which `sample_ld` draws world direction wd for dome k (n: shading normal
    of the vertex, for an untextured dome)."""
    if not F_DOME_TEXTURE or L.image_i[k, 0] < 0:
        c = dot(wd, n)
        return c / math.pi if c > 0.0 else 0.0
    moff, coff, w, h = L.image_i[k, 0], L.image_i[k, 1], L.image_i[k, 2], L.image_i[k, 3]
    ax, ay, az = _dome_frame(S, k)
    loc = (dot(wd, ax), dot(wd, ay), dot(wd, az))
    lat = math.asin(max(-1.0, min(1.0, loc[1])))
    cl = math.cos(lat)
    if cl <= 0.0:
        return 0.0
    s = 0.5 - math.atan2(loc[0], loc[2]) / (2.0 * math.pi)
    v = 0.5 - lat / math.pi
    x = min(max(int(s * w), 0), w - 1)
    y = min(max(int(v * h), 0), h - 1)
    pm = L.image_cdf[moff + y + 1] - L.image_cdf[moff + y]
    row = coff + y * (w + 1)
    pc = L.image_cdf[row + x + 1] - L.image_cdf[row + x]
    return pm * pc * w * h / (2.0 * math.pi * math.pi * cl)
