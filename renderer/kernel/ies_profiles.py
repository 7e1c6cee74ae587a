"""A light's IES profile (UsdLux.ShapingAPI `shaping:ies:*`; `usd/ies.py` reads the file) as the kernels weigh its
emission by it: the profile's intensity towards the emission direction, interpolated bilinearly between its angles
(0 at vertical angles it does not cover), times the light's gain (1, or 1 / the profile's mean with
`ies:normalize`: `description.Light.ies_gain`).

The direction's angles are taken as Pixar's hdEmbree takes them, in the light's frame, from the direction towards
the light (wi, from the lit point): the vertical angle acos(wi . Z), so 0 along the light's axis of emission (-Z,
the profile's nadir); the horizontal angle atan2(wi . Y, wi . X).  `shaping:ies:angleScale` a maps the vertical
angle theta to the profile's pi - (pi - theta) / (1 + a) (the UsdLux specification's, RenderMan's; clamped to
[0, pi]): a > 0 takes the profile's upper angles further down, a < 0 widens its nadir.

`li_ies` (SceneData) holds each profile once (`host/build._light_tables`), a block from its offset: the counts of
vertical and horizontal angles nv and nh, the vertical angles (radians, ascending), the horizontal angles (0 to
2 pi), then the intensities, nh rows of nv; a profile the same all round is one row (nh = 1, its angle 0), and its
horizontal angle is not computed.  A light's columns: LF_IES (its profile's offset, -1 without),
LF_IES + 1 (1 + angleScale), LF_IES + 2 (its gain).
"""
import math

import numba as nb

from .jit import SHADING_INLINE_JIT
from .tables import LF_IES


@nb.njit(**SHADING_INLINE_JIT)
def _bracket(a, lo, n, x):
    """(i, t): the interval [a[lo + i], a[lo + i + 1]] of the n ascending values from a[lo] that holds x (clamped
    into the first or last interval), and x's place in it (0 to 1); a binary search."""
    i, j = 0, n - 1
    while j - i > 1:
        m = (i + j) >> 1
        if x < a[lo + m]:
            j = m
        else:
            i = m
    x0, x1 = a[lo + i], a[lo + i + 1]
    t = (x - x0) / (x1 - x0) if x1 > x0 else 0.0
    return i, min(max(t, 0.0), 1.0)


@nb.njit(**SHADING_INLINE_JIT)
def ies_weight(li_ies, lf, k, x, y, z):
    """The factor light k's IES profile weighs its emission by towards the direction whose components towards the
    light, in the light's frame, are (x, y, z) (a unit vector): the gain times the interpolated intensity."""
    off = int(lf[k, LF_IES])
    theta = math.acos(max(-1.0, min(1.0, z)))
    s = lf[k, LF_IES + 1]
    if s != 1.0:
        theta = min(max(math.pi - (math.pi - theta) / s, 0.0), math.pi)
    nv, nh = int(li_ies[off]), int(li_ies[off + 1])
    v0 = off + 2
    h0 = v0 + nv
    if theta < li_ies[v0] - 1e-12 or theta > li_ies[v0 + nv - 1] + 1e-12:
        return 0.0                                   # beyond the profile's vertical angles
    j, tj = _bracket(li_ies, v0, nv, theta)
    if nh == 1:                                      # the same all round: one row, no horizontal angle
        c = h0 + 1 + j
        return lf[k, LF_IES + 2] * (li_ies[c] + tj * (li_ies[c + 1] - li_ies[c]))
    phi = math.atan2(y, x)
    if phi < 0.0:
        phi += 2.0 * math.pi
    i, ti = _bracket(li_ies, h0, nh, phi)
    c = h0 + nh + i * nv + j
    a = li_ies[c] + tj * (li_ies[c + 1] - li_ies[c])
    b = li_ies[c + nv] + tj * (li_ies[c + nv + 1] - li_ies[c + nv])
    return lf[k, LF_IES + 2] * (a + ti * (b - a))
