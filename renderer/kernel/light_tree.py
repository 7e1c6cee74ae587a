"""Choosing the lights of a path vertex's light samples from the light tree (`host/light_tree.py`; Conty
Estevez & Kulla 2018, pbrt-v4's BVHLightSampler): a walk from the root that takes each child with
probability proportional to its importance at the shading point, splitting where one child is much
the likelier (`choose_lights`), and the expected number of samples of a given light there (for the MIS
weight of a BSDF-sampled ray that finds it).  `L` is the `PathLights` record.
"""
import math

import numba as nb

from .jit import SHADING_INLINE_JIT as _JIT
from .tables import T_C, T_COS_E, T_COS_O, T_HALF_DIAG, T_PHI, T_RADIUS, T_SIN_O, T_TWO_SIDED, T_W

ONE_MINUS = 0.99999994
NO_SAMPLE = (-1, 0.0)
# `choose_lights` splits at the first MAX_SPLITS nodes of its trail whose less likely child has a
# probability q of at most SPLIT_BELOW, and below them at every node with q at most SPLIT_DEEP
SPLIT_BELOW = 0.25
MAX_SPLITS = 2
SPLIT_DEEP = 0.01


@nb.njit(**_JIT)
def _cos_sub(sa, ca, sb, cb):
    """cos(max(0, a - b)) from the sines and cosines of angles a, b in [0, pi]."""
    return 1.0 if ca > cb else ca * cb + sa * sb


@nb.njit(**_JIT)
def _sin_sub(sa, ca, sb, cb):
    """sin(max(0, a - b))."""
    return 0.0 if ca > cb else sa * cb - ca * sb


@nb.njit(**_JIT)
def importance(tf, node, p, n):
    """Importance of tree node `node` (a row of tf = PathLights.tree_f) at point p with normal n: its
    power over the squared distance (at least the node's half diagonal), times upper bounds of the
    cosine at the lights (the angle between the direction to p and the cone of emission normals, less
    the angle the node's bounding sphere subtends) and of the cosine at the receiver.  Inside the
    bounding sphere every direction is possible: both bounds are 1.  A node whose normals point
    everywhere (cos theta_o = -1: points, spheres, mixed nodes) skips the cone; one square root serves
    sin_i sin_b."""
    dx = p[0] - tf[node, T_C]
    dy = p[1] - tf[node, T_C + 1]
    dz = p[2] - tf[node, T_C + 2]
    dd = dx * dx + dy * dy + dz * dz
    r = tf[node, T_RADIUS]
    if dd <= r * r:
        return max(tf[node, T_PHI] / max(dd, tf[node, T_HALF_DIAG]), 0.0)
    inv = 1.0 / math.sqrt(dd)
    wx, wy, wz = dx * inv, dy * inv, dz * inv
    sin_b = r * inv
    cos_b = math.sqrt(1.0 - sin_b * sin_b)
    cos_p = 1.0
    cos_o = tf[node, T_COS_O]
    if cos_o > -1.0:
        cos_w = tf[node, T_W] * wx + tf[node, T_W + 1] * wy + tf[node, T_W + 2] * wz
        if tf[node, T_TWO_SIDED] != 0.0:
            cos_w = abs(cos_w)
        sin_w = math.sqrt(max(0.0, 1.0 - cos_w * cos_w))
        sin_o = tf[node, T_SIN_O]
        cos_x = _cos_sub(sin_w, cos_w, sin_o, cos_o)
        sin_x = _sin_sub(sin_w, cos_w, sin_o, cos_o)
        cos_p = _cos_sub(sin_x, cos_x, sin_b, cos_b)
        if cos_p <= tf[node, T_COS_E]:
            return 0.0
    cos_i = abs(wx * n[0] + wy * n[1] + wz * n[2])
    if cos_i < cos_b:                                # cos(max(0, theta_i - theta_b))
        cos_i = cos_i * cos_b + math.sqrt(max(0.0, (1.0 - cos_i * cos_i) * (1.0 - cos_b * cos_b)))
    else:
        cos_i = 1.0
    return max(tf[node, T_PHI] * cos_p * cos_i / max(dd, tf[node, T_HALF_DIAG]), 0.0)


@nb.njit(**_JIT)
def _p_unbounded(L):
    """Probability of choosing one of the lights without a position (dome, distant) at all."""
    nu = L.unbounded.shape[0]
    return nu / (nu + (1 if L.n_bounded > 0 else 0)) if nu > 0 else 0.0


@nb.njit(**_JIT)
def _walk(L, p, n, node, pmf, u):
    """The light a plain walk from `node` reaches (each child with its probability), and its
    probability (times `pmf`, the probability of reaching `node`)."""
    tf = L.tree_f
    ti = L.tree_i
    while ti[node, 1] == 0:
        c1 = ti[node, 0]
        i0 = importance(tf, node + 1, p, n)
        i1 = importance(tf, c1, p, n)
        if not (i0 + i1 > 0.0):
            return -1, 0.0
        p0 = i0 / (i0 + i1)
        node, pmf, u = _step(node, c1, p0, pmf, u)
    return ti[node, 0], pmf


@nb.njit(**_JIT)
def _step(node, c1, p0, pmf, u):
    """One step of a walk: (child, pmf times its probability, u rescaled inside its interval), the
    first child (node + 1) when u < p0, else the second (c1)."""
    if u < p0:
        return node + 1, pmf * p0, min(u / p0, ONE_MINUS)
    return c1, pmf * (1.0 - p0), min((u - p0) / (1.0 - p0), ONE_MINUS)


@nb.njit(**_JIT)
def lone_light(L):
    """The scene's one light when it has exactly one (bounded or not), else -1.  Then there is no choice
    to make: every vertex samples it (`choose_lights` is not called and its 1D sample not drawn), with
    expected count 1 (`light_pmf`); where it cannot light the vertex its sample contributes nothing
    (the light's own sampling and emission are zero there), so the estimate is the tree's."""
    if L.n_bounded + L.unbounded.shape[0] != 1:
        return -1
    return L.unbounded[0] if L.n_bounded == 0 else L.tree_i[0, 0]


@nb.njit(**_JIT)
def choose_lights(L, p, n, u):
    """The light samples of a path vertex at point p with normal n, u in [0, 1): ((light, its
    expected number of samples there) for the main sample and for up to two side samples), light -1
    where there is none.

    A walk from the root that takes each child with its probability, except at *split* nodes, where
    one child is much the likelier (the other's probability q at most SPLIT_BELOW: at the first
    MAX_SPLITS such nodes of the trail, and deeper where q is at most SPLIT_DEEP): there it takes the
    likely child always and, with probability q, a side sample: a plain walk from the other child.  At
    most two side samples are taken: at the first two split nodes where that chance comes up.  So a
    light that outshines the rest at p is sampled at every vertex: its estimate loses the variance of
    being chosen and keeps the stratification of the sampler's light-point samples (the noise of a
    dominant light, issue 13), at the cost of q extra samples where the rest is unlikely; where the
    children are balanced nothing changes.  Unbiased: each light's estimate is divided by its expected
    number of samples, which `light_pmf` returns for the MIS weights."""
    pu = _p_unbounded(L)
    if u < pu:
        nu = L.unbounded.shape[0]
        return (L.unbounded[min(int(u / pu * nu), nu - 1)], pu / nu), NO_SAMPLE, NO_SAMPLE
    if L.n_bounded == 0:
        return NO_SAMPLE, NO_SAMPLE, NO_SAMPLE
    u = min((u - pu) / (1.0 - pu), ONE_MINUS)
    tf = L.tree_f
    ti = L.tree_i
    node = 0
    pmf = 1.0 - pu                                   # probability of reaching node (its walk's choices)
    none, once = 1.0, 0.0                            # probability of no, one side-sample chance so far
    s1, w1, u1 = -1, 0.0, 0.0                        # side samples: where their walks start, their
    s2, w2, u2 = -1, 0.0, 0.0                        # expected counts there, their u there
    splits = 0
    while ti[node, 1] == 0:
        c1 = ti[node, 0]
        i0 = importance(tf, node + 1, p, n)
        i1 = importance(tf, c1, p, n)
        if not (i0 + i1 > 0.0):
            pmf = 0.0
            break
        p0 = i0 / (i0 + i1)
        q = min(p0, 1.0 - p0)
        if _splits(q, splits):
            splits += 1
            likely, other = (node + 1, c1) if p0 >= 0.5 else (c1, node + 1)
            if u < q:                                # the side sample's chance
                u = min(u / q, ONE_MINUS)
                if s1 < 0:
                    s1, w1, u1 = other, pmf * q * (none + once), u
                elif s2 < 0:
                    s2, w2, u2 = other, pmf * q * (none + once), u
            else:
                u = min((u - q) / (1.0 - q), ONE_MINUS)
            none, once = none * (1.0 - q), once * (1.0 - q) + none * q
            node = likely
        else:                                        # (q > SPLIT_BELOW, or splits >= MAX_SPLITS)
            node, pmf, u = _step(node, c1, p0, pmf, u)
    side1 = _walk(L, p, n, s1, w1, u1) if s1 >= 0 else NO_SAMPLE
    side2 = _walk(L, p, n, s2, w2, u2) if s2 >= 0 else NO_SAMPLE
    if pmf == 0.0 or (node == 0 and not importance(tf, 0, p, n) > 0.0):   # (a lone light that cannot light p)
        return NO_SAMPLE, side1, side2
    return (ti[node, 0], pmf), side1, side2


@nb.njit(**_JIT)
def _splits(q, splits):
    """Whether `choose_lights` splits at a node whose less likely child has probability q, after
    `splits` nodes above it (on its trail) with q in (0, SPLIT_BELOW]."""
    return 0.0 < q <= SPLIT_BELOW and (splits < MAX_SPLITS or q <= SPLIT_DEEP)


@nb.njit(**_JIT)
def light_pmf(L, p, n, k):
    """The expected number of samples `choose_lights` at point p with normal n takes of light k: the
    product of the probabilities of the children on its trail, where a split node's likely child
    counts 1 and its other child q times the probability that fewer than two side-sample chances came
    up above it."""
    if lone_light(L) == k:
        return 1.0
    d = L.depth[k]
    if d < 0:                                        # a light without a position
        pu = _p_unbounded(L)
        return pu / L.unbounded.shape[0] if pu > 0.0 else 0.0
    tf = L.tree_f
    ti = L.tree_i
    pmf = 1.0 - _p_unbounded(L)
    if d == 0:
        return pmf if importance(tf, 0, p, n) > 0.0 else 0.0
    trail = L.trail[k]
    node = 0
    none, once = 1.0, 0.0
    splits = 0
    side = False                                     # k is past a split node's less likely child
    for level in range(d):
        c1 = ti[node, 0]
        i0 = importance(tf, node + 1, p, n)
        i1 = importance(tf, c1, p, n)
        if not (i0 + i1 > 0.0):
            return 0.0
        p0 = i0 / (i0 + i1)
        pk = 1.0 - p0 if (trail >> level) & 1 else p0
        q = min(p0, 1.0 - p0)
        if not side and _splits(q, splits):
            splits += 1
            if pk > 0.5:
                none, once = none * (1.0 - q), once * (1.0 - q) + none * q
            else:
                pmf *= q * (none + once)
                side = True
        else:
            pmf *= pk
        node = c1 if (trail >> level) & 1 else node + 1
    return pmf
