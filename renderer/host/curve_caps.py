"""The round ends and joints of emissive linear curves as lights of the path integrator (`surface_lights.py`).

Embree's round linear curve is, segment by segment, the convex hull of the spheres at its two ends: the side of a
cone tangent to both (`surface_lights.cone_sides`, a light of its own), and the parts of the spheres beyond it.  The
sphere of radius r at an end of a segment of direction d (from its first end to its second) and slope
s = (r1 - r0) / L touches the cone on the circle (x - c) . d = -r s; its points on the cone's side of that plane lie
inside the hull.  So the point c + r n of the sphere (n a unit vector) is on the surface as that segment sees it where
n . a >= z, with (a, z) = (d, -s) at the segment's second end and (-d, s) at its first.

A sphere that segments share (a joint: ends equal in value, as consecutive segments' are; also a closed curve's first
and last ends) is one light: its points past every segment that meets it (at most CAP_PLANES planes, the one of the
largest z first: its cap, of area 2 pi r^2 (1 - z), a cap's area being proportional to its height, holds them all).
The kernel draws it in the cone of directions from the shading point that meet the sphere, or, from inside it,
uniformly on that first cap; the points that are not past every plane are not drawn (they lie inside other cones,
whose sides are their own lights; `kernel/surface_lights._cap_point`).  Similarities keep s and the angles, so every placement of a gprim has the same planes, turned.

A segment with no side (L = 0, or |s| >= 1: one sphere holds the other) hides its smaller sphere and bounds the
larger nowhere.  No light: a sphere of radius 0, a hidden one, one met by more than CAP_PLANES segments, and one
with no part on the surface (a straight joint between cones of one radius: its circle only): a ray that hits those
keeps their emission whole, as a BSDF ray alone finds it.  The light tree sees a light's box, and its part on the
surface over pi as its largest projected area, as a cone side's: the drawn cap's area times its share past the other
planes, exact for one or two (most ends and joints), from a GRID x GRID grid for more.
"""
from __future__ import annotations

import numpy as np

from ..kernel.tables import CAP_PLANES

GRID = 32


def round_caps(ends: np.ndarray):
    """The light of each end and joint sphere of one linear curves gprim at its R placements (similarities).

    ends: (R, n, 2, 4) its n segments' two ends (x, y, z, radius) in the world.  Returns (spheres (R, m, 4): the
    lights' centres and radii; planes (R, m, CAP_PLANES, 4): (a, z) rows, the drawn cap's first ((0, 0, 1, -1), the
    whole sphere, where no segment bounds it), unused rows (0, 0, 0, -2); area (R, m): the drawn caps' areas;
    share (m,): each drawn cap's share on the surface (`_share`);
    caps (n, 2): each segment end's light among the m, -1 for none)."""
    R, n = ends.shape[:2]
    flat = ends.reshape(R, 2 * n, 4)
    _, first, which = np.unique(flat[0], axis=0, return_index=True, return_inverse=True)
    which = which.reshape(n, 2)
    m = len(first)
    radius = flat[0, first, 3]
    r0, r1 = ends[0, :, 0, 3], ends[0, :, 1, 3]
    length = np.linalg.norm(ends[0, :, 1, :3] - ends[0, :, 0, :3], axis=-1)
    side = (length > 0.0) & (np.abs(r1 - r0) < length)
    s = np.where(side, (r1 - r0) / np.where(side, length, 1.0), 0.0)
    vec = ends[:, :, 1, :3] - ends[:, :, 0, :3]
    norm = np.linalg.norm(vec, axis=-1)
    d = vec / np.where(norm > 0.0, norm, 1.0)[..., None]                  # (R, n, 3)
    smaller = np.stack([r0 < r1, r1 < r0], 1) & (which[:, 0] != which[:, 1])[:, None]
    hidden = np.zeros(m, bool)
    hidden[which[~side[:, None] & smaller]] = True
    seg, end = np.nonzero(np.repeat(side[:, None], 2, 1))                  # the segment ends with a plane
    u = which[seg, end]
    order = np.argsort(u, kind='stable')
    seg, end, u = seg[order], end[order], u[order]
    rank = np.arange(len(u)) - np.searchsorted(u, u)
    crowded = np.bincount(u, minlength=m) > CAP_PLANES
    keep = rank < CAP_PLANES
    sign = np.where(end == 1, 1.0, -1.0)[keep]
    planes = np.zeros((R, m, CAP_PLANES, 4))
    planes[..., 3] = -2.0
    planes[:, u[keep], rank[keep], :3] = sign[None, :, None] * d[:, seg[keep]]
    planes[:, u[keep], rank[keep], 3] = -sign * s[seg[keep]]
    by_z = np.argsort(-planes[0, :, :, 3], axis=1, kind='stable')
    planes = np.take_along_axis(planes, by_z[None, :, :, None], axis=2)
    planes[:, np.flatnonzero(planes[0, :, 0, 3] < -1.5), 0] = (0.0, 0.0, 1.0, -1.0)   # no plane: the whole sphere
    top = np.minimum(planes[0, :, 0, 3], 1.0)
    spheres = flat[:, first]
    area = 2.0 * np.pi * spheres[..., 3] ** 2 * (1.0 - top)[None]
    share = _share(planes[0])
    lit = (radius > 0.0) & ~hidden & ~crowded & (top < 1.0) & (share > 0.0)
    index = np.where(lit, np.cumsum(lit) - 1, -1)
    return spheres[:, lit], planes[:, lit], area[:, lit], share[lit], index[which]


def _share(planes: np.ndarray) -> np.ndarray:
    """The share of each sphere's drawn cap (planes (m, CAP_PLANES, 4), the first the drawn one) past its other
    planes: 1 with one plane, the two caps' intersection over the drawn cap's area with two (`_lens`, exact), a
    GRID x GRID grid's share with more."""
    used = (planes[:, :, 3] > -1.5).sum(1)
    share = np.ones(len(planes))
    two = used == 2
    z0, z1 = np.minimum(planes[two, 0, 3], 1.0), planes[two, 1, 3]
    cap = 2.0 * np.pi * (1.0 - z0)
    lens = _lens(z0, z1, np.einsum('mc,mc->m', planes[two, 0, :3], planes[two, 1, :3]))
    share[two] = np.where(cap > 0.0, lens / np.where(cap > 0.0, cap, 1.0), 0.0)
    more = np.flatnonzero(used > 2)
    for k in range(0, len(more), 1024):
        share[more[k:k + 1024]] = _grid_share(planes[more[k:k + 1024]])
    return share


def _lens(z1: np.ndarray, z2: np.ndarray, c: np.ndarray) -> np.ndarray:
    """The area of {n . a >= z1} and {n . b >= z2} on the unit sphere, a . b = c: of two caps of angular radii t1, t2
    whose centres lie g apart, 0 if g >= t1 + t2, the smaller if g <= |t1 - t2|, else the lens of their overlap by
    Gauss-Bonnet: 2 pi - 2 acos((c - z1 z2) / (sin t1 sin t2)) - 2 z1 acos((z2 - c z1) / (sin g sin t1))
    - 2 z2 acos((z1 - c z2) / (sin g sin t2))."""
    t1, t2, g = (np.arccos(np.clip(x, -1.0, 1.0)) for x in (z1, z2, c))
    s1, s2, sg = (np.maximum(np.sin(x), 1e-300) for x in (t1, t2, g))
    arc = lambda x: np.arccos(np.clip(x, -1.0, 1.0))
    lens = (2.0 * np.pi - 2.0 * arc((c - z1 * z2) / (s1 * s2)) - 2.0 * z1 * arc((z2 - c * z1) / (sg * s1))
            - 2.0 * z2 * arc((z1 - c * z2) / (sg * s2)))
    smaller = 2.0 * np.pi * (1.0 - np.maximum(z1, z2))
    return np.where(g >= t1 + t2, 0.0, np.where(g <= np.abs(t1 - t2), smaller, np.clip(lens, 0.0, smaller)))


def _grid_share(planes: np.ndarray) -> np.ndarray:
    """The share of a GRID x GRID grid (cell centres; z even in [z0, 1] as a uniform draw is, the angle even) over
    each sphere's drawn cap (planes (m, CAP_PLANES, 4), the first the drawn one) that the other planes keep."""
    a, z0 = planes[:, 0, :3], np.minimum(planes[:, 0, 3], 1.0)
    t = np.where(np.abs(a[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t = np.cross(a, t)
    t /= np.maximum(np.linalg.norm(t, axis=1), 1e-300)[:, None]
    b = np.cross(a, t)
    z = 1.0 - (np.arange(GRID) + 0.5)[None, :] / GRID * (1.0 - z0)[:, None]          # (m, GRID)
    ring = np.sqrt(np.maximum(1.0 - z * z, 0.0))
    phi = 2.0 * np.pi * (np.arange(GRID) + 0.5) / GRID
    x, y = ring[:, :, None] * np.cos(phi), ring[:, :, None] * np.sin(phi)              # (m, GRID, GRID)
    n = (x[..., None] * t[:, None, None] + y[..., None] * b[:, None, None]
         + z[:, :, None, None] * a[:, None, None])
    past = np.einsum('mijc,mkc->mijk', n, planes[:, 1:, :3]) >= planes[:, None, None, 1:, 3]
    return past.all(-1).mean((1, 2))
