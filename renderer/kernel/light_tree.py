"""Choosing the lights of a path vertex's light samples from the light tree (`host/light_tree.py`; Conty
Estevez & Kulla 2018, pbrt-v4's BVHLightSampler): a walk from the root that takes each child with
probability proportional to its importance at the shading point, splitting where one child is much
the likelier (`choose_lights`), and the expected number of samples of a given light there (for the MIS
weight of a BSDF-sampled ray that finds it).  `L` is the `PathLights` record.

A node has up to eight children (TREE_WIDTH); `importances` computes the eight importances in one loop
over the node's field-major row, which LLVM vectorises (without branches, with numpy's error model:
numba's default checks every division for zero, and a check is a branch), into eight doubles on the
walk's stack (`_stack_doubles`).
"""
import math

import numba as nb
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic
from numba.np.arrayobj import make_array, populate_array

from .jit import SHADING_INLINE_JIT as _JIT
from .tables import (T_C, T_COS_E, T_COS_O, T_HALF_DIAG, T_PHI, T_RADIUS, T_SIN_O, T_TWO_SIDED, T_W, TRAIL_BITS,
                     TREE_COLS, TREE_WIDTH)

ONE_MINUS = 0.99999994
NO_SAMPLE = (-1, 0.0)
# `choose_lights` splits at the first MAX_SPLITS nodes of its trail whose less likely children have
# together a probability q of at most SPLIT_BELOW, and below them at every node with q at most SPLIT_DEEP
SPLIT_BELOW = 0.25
MAX_SPLITS = 2
SPLIT_DEEP = 0.01
_SLOT_MASK = (1 << TRAIL_BITS) - 1
_TINY = 1e-300


_DOUBLES = types.Array(types.float64, 1, 'C')


@intrinsic
def _stack_doubles(typingctx):
    """An array of TREE_WIDTH doubles on the stack of the function that calls it (an alloca in its
    entry block: an intrinsic's code is emitted into its caller; no meminfo): the walks' scratch for a
    node's importances (the kernels allocate nothing on the heap)."""
    def codegen(context, builder, sig, args):
        data = cgutils.alloca_once(builder, context.get_value_type(types.float64), size=TREE_WIDTH)
        ary = make_array(_DOUBLES)(context, builder)
        itemsize = context.get_constant(types.intp, 8)
        populate_array(ary, data=data, shape=[context.get_constant(types.intp, TREE_WIDTH)], strides=[itemsize],
                       itemsize=itemsize, meminfo=None)
        return ary._getvalue()
    return _DOUBLES(), codegen


@nb.njit(**dict(_JIT, error_model='numpy'))
def importances(tf, node, p, n, w):
    """The importance of each child of tree node `node` (a row of tf = PathLights.tree_f) at point p
    with normal n, into w[0:width]; returns their sum.  A child's importance: its power over the
    squared distance (at least its half diagonal), times upper bounds of the cosine at the lights (the
    angle between the direction to p and the cone of emission normals, less the angle the child's
    bounding sphere subtends) and of the cosine at the receiver.  Inside the bounding sphere every
    direction is possible: both bounds are 1.  Children whose normals point everywhere (cos theta_o =
    -1: points, spheres, mixed nodes) skip the cone bound.  Written without branches (selects), and the
    width read from the table, not a constant, so that LLVM vectorises the loop instead of unrolling it
    (a sum in the loop would stop it too: strict floating-point order); w holds TREE_WIDTH doubles,
    zeroed past the width, and their sum is taken pairwise (three additions deep, not eight)."""
    nw = tf.shape[1] // TREE_COLS
    for j in range(nw):
        dx = p[0] - tf[node, T_C * nw + j]
        dy = p[1] - tf[node, (T_C + 1) * nw + j]
        dz = p[2] - tf[node, (T_C + 2) * nw + j]
        dd = max(dx * dx + dy * dy + dz * dz, _TINY)
        # one square root and two divisions of dd, side by side; the sines of the angles from their
        # squares: a walk takes one node after the other, so this chain's latency is its cost
        a = 1.0 / dd
        inv = math.sqrt(dd) * a                      # 1 / distance
        falloff = tf[node, T_PHI * nw + j] / max(dd, tf[node, T_HALF_DIAG * nw + j])
        r = tf[node, T_RADIUS * nw + j]
        sin_b2 = min(r * r * a, 1.0)
        sin_b = math.sqrt(sin_b2)
        cos_b = math.sqrt(1.0 - sin_b2)
        cos_o = tf[node, T_COS_O * nw + j]
        sin_o = tf[node, T_SIN_O * nw + j]
        dw = tf[node, T_W * nw + j] * dx + tf[node, (T_W + 1) * nw + j] * dy + tf[node, (T_W + 2) * nw + j] * dz
        dw = abs(dw) if tf[node, T_TWO_SIDED * nw + j] != 0.0 else dw
        cos_w = dw * inv
        sin_w = math.sqrt(max(0.0, 1.0 - dw * dw * a))
        within = cos_w > cos_o                       # theta_x = max(0, theta_w - theta_o)
        cos_x = 1.0 if within else cos_w * cos_o + sin_w * sin_o
        sin_x = 0.0 if within else sin_w * cos_o - cos_w * sin_o
        cos_p = 1.0 if cos_x > cos_b else cos_x * cos_b + sin_x * sin_b     # cos(max(0, theta_x - theta_b))
        cos_p = 1.0 if cos_o <= -1.0 else cos_p
        dn = dx * n[0] + dy * n[1] + dz * n[2]
        ci = abs(dn) * inv
        sin_i = math.sqrt(max(0.0, 1.0 - dn * dn * a))
        cos_i = 1.0 if ci >= cos_b else ci * cos_b + sin_i * sin_b           # cos(max(0, theta_i - theta_b))
        inside = dd <= r * r
        v = falloff * (1.0 if inside else cos_p * cos_i)
        v = 0.0 if (cos_p <= tf[node, T_COS_E * nw + j] and not inside) else v
        w[j] = v if v > 0.0 else 0.0                 # (and 0 for NaN)
    for j in range(nw, TREE_WIDTH):
        w[j] = 0.0
    return ((w[0] + w[1]) + (w[2] + w[3])) + ((w[4] + w[5]) + (w[6] + w[7]))


@nb.njit(**_JIT)
def _likeliest(w, nw):
    """The first slot of the largest importance."""
    best = 0
    for j in range(1, nw):
        if w[j] > w[best]:
            best = j
    return best


@nb.njit(**_JIT)
def _pick(w, nw, total, u, skip):
    """(slot, its probability w / total, u rescaled inside its interval): the slot whose interval of
    the cumulative importances (in slot order, `skip` left out; total: their sum) holds u * total."""
    target = u * total
    cum = 0.0
    last = -1
    for j in range(nw):
        if j == skip or not w[j] > 0.0:
            continue
        last = j
        if target < cum + w[j]:
            return j, w[j] / total, min((target - cum) / w[j], ONE_MINUS)
        cum += w[j]
    return last, (w[last] / total if last >= 0 else 0.0), ONE_MINUS      # (u * total rounded past the sum)


@nb.njit(**_JIT)
def _p_unbounded(L):
    """Probability of choosing one of the lights without a position (dome, distant) at all."""
    nu = L.unbounded.shape[0]
    return nu / (nu + (1 if L.n_bounded > 0 else 0)) if nu > 0 else 0.0


@nb.njit(**_JIT)
def _walk(L, p, n, child, pmf, u):
    """The light a plain walk from `child` (a `tree_i` entry: a node, or -1 - light for a leaf)
    reaches (each child with its probability), and its probability (times `pmf`, the probability of
    reaching `child`)."""
    tf = L.tree_f
    ti = L.tree_i
    nw = ti.shape[1]
    w = _stack_doubles()
    while child >= 0:
        total = importances(tf, child, p, n, w)
        if not total > 0.0:
            return NO_SAMPLE
        j, pj, u = _pick(w, nw, total, u, -1)
        pmf *= pj
        child = ti[child, j]
    return -1 - child, pmf


@nb.njit(**_JIT)
def lone_light(L):
    """The scene's one light when it has exactly one (bounded or not), else -1.  Then there is no choice
    to make: every vertex samples it (`choose_lights` is not called and its 1D sample not drawn), with
    expected count 1 (`light_pmf`); where it cannot light the vertex its sample contributes nothing
    (the light's own sampling and emission are zero there), so the estimate is the tree's."""
    if L.n_bounded + L.unbounded.shape[0] != 1:
        return -1
    return L.unbounded[0] if L.n_bounded == 0 else -1 - L.tree_i[0, 0]


@nb.njit(**_JIT)
def choose_lights(L, p, n, u):
    """The light samples of a path vertex at point p with normal n, u in [0, 1): ((light, its
    expected number of samples there) for the main sample and for up to two side samples), light -1
    where there is none.

    A walk from the root that takes each child with its probability, except at *split* nodes, where
    one child is much the likeliest (the others' probability q at most SPLIT_BELOW: at the first
    MAX_SPLITS such nodes of the trail, and deeper where q is at most SPLIT_DEEP): there it takes the
    likeliest child always and, with probability q, a side sample: one of the others (each with its
    probability over q), and a plain walk from there.  At most two side samples are taken: at the
    first two split nodes where that chance comes up.  So a light that outshines the rest at p is
    sampled at every vertex: its estimate loses the variance of being chosen and keeps the
    stratification of the sampler's light-point samples (the noise of a dominant light, issue 13), at
    the cost of q extra samples where the rest is unlikely; where the children are balanced nothing
    changes.  Unbiased: each light's estimate is divided by its expected number of samples, which
    `light_pmf` returns for the MIS weights."""
    pu = _p_unbounded(L)
    if u < pu:
        nu = L.unbounded.shape[0]
        return (L.unbounded[min(int(u / pu * nu), nu - 1)], pu / nu), NO_SAMPLE, NO_SAMPLE
    if L.n_bounded == 0:
        return NO_SAMPLE, NO_SAMPLE, NO_SAMPLE
    u = min((u - pu) / (1.0 - pu), ONE_MINUS)
    tf = L.tree_f
    ti = L.tree_i
    nw = ti.shape[1]
    w = _stack_doubles()
    child = 0
    pmf = 1.0 - pu                                   # probability of reaching child (its walk's choices)
    none, once = 1.0, 0.0                            # probability of no, one side-sample chance so far
    n_side = 0                                       # side samples: where their walks start, their
    s1, w1, u1 = -1, 0.0, 0.0                        # expected counts there, their u there
    s2, w2, u2 = -1, 0.0, 0.0
    splits = 0
    while child >= 0:
        node = child
        total = importances(tf, node, p, n, w)
        if not total > 0.0:
            pmf = 0.0
            break
        likely = _likeliest(w, nw)
        q = 1.0 - w[likely] / total
        if _splits(q, splits):
            splits += 1
            if u < q:                                # the side sample's chance
                u = min(u / q, ONE_MINUS)
                if n_side < 2:
                    j, pj, us = _pick(w, nw, total - w[likely], u, likely)
                    if j >= 0:
                        if n_side == 0:
                            s1, w1, u1 = ti[node, j], pmf * (none + once) * q * pj, us
                        else:
                            s2, w2, u2 = ti[node, j], pmf * (none + once) * q * pj, us
                        n_side += 1
            else:
                u = min((u - q) / (1.0 - q), ONE_MINUS)
            none, once = none * (1.0 - q), once * (1.0 - q) + none * q
            child = ti[node, likely]
        else:                                        # (q > SPLIT_BELOW, or splits >= MAX_SPLITS)
            j, pj, u = _pick(w, nw, total, u, -1)
            pmf *= pj
            child = ti[node, j]
    side1 = _walk(L, p, n, s1, w1, u1) if n_side >= 1 else NO_SAMPLE
    side2 = _walk(L, p, n, s2, w2, u2) if n_side >= 2 else NO_SAMPLE
    if pmf == 0.0:
        return NO_SAMPLE, side1, side2
    return (-1 - child, pmf), side1, side2


@nb.njit(**_JIT)
def _splits(q, splits):
    """Whether `choose_lights` splits at a node whose less likely children have together probability
    q, after `splits` nodes above it (on its trail) with q in (0, SPLIT_BELOW]."""
    return 0.0 < q <= SPLIT_BELOW and (splits < MAX_SPLITS or q <= SPLIT_DEEP)


@nb.njit(**_JIT)
def light_pmf(L, p, n, k):
    """The expected number of samples `choose_lights` at point p with normal n takes of light k: the
    product of the probabilities of the children on its trail, where a split node's likeliest child
    counts 1 and another child q times its probability among the others times the probability that
    fewer than two side-sample chances came up above it."""
    if lone_light(L) == k:
        return 1.0
    d = L.depth[k]
    if d < 0:                                        # a light without a position
        pu = _p_unbounded(L)
        return pu / L.unbounded.shape[0] if pu > 0.0 else 0.0
    tf = L.tree_f
    ti = L.tree_i
    nw = ti.shape[1]
    w = _stack_doubles()
    pmf = 1.0 - _p_unbounded(L)
    trail = L.trail[k]
    node = 0
    none, once = 1.0, 0.0
    splits = 0
    side = False                                     # k is past a split node's less likely child
    for level in range(d):
        total = importances(tf, node, p, n, w)
        if not total > 0.0:
            return 0.0
        slot = (trail >> (TRAIL_BITS * level)) & _SLOT_MASK
        if not w[slot] > 0.0:
            return 0.0
        split = False
        if not side:
            likely = _likeliest(w, nw)
            q = 1.0 - w[likely] / total
            if _splits(q, splits):
                split = True
                splits += 1
                if slot == likely:
                    none, once = none * (1.0 - q), once * (1.0 - q) + none * q
                else:
                    pmf = pmf * (none + once) * q * (w[slot] / (total - w[likely]))
                    side = True
        if not split:
            pmf *= w[slot] / total
        node = ti[node, slot]
    return pmf
