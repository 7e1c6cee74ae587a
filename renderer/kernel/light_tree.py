"""Choosing the lights of a path vertex's light samples from the light tree (`host/light_tree.py`; Conty
Estevez & Kulla 2018, pbrt-v4's BVHLightSampler): a walk from the root that takes each child with
probability proportional to its importance at the shading point, splitting where one child is much
the likelier (`choose_lights`), and the expected number of samples of a given light there (for the MIS
weight of a BSDF-sampled ray that finds it).  `L` is the `PathLights` record.

The tree is binary, stored in blocks of three levels (`host/light_tree.py`): entering a block, a walk
computes the importances of its 14 nodes in one loop over the block's field-major row, which LLVM
vectorises (without branches, with numpy's error model: numba's default checks every division for
zero, and a check is a branch), into float32s on the walk's stack (`_stack_floats`), and takes its
binary steps from them (each pair's probability in double).  The choices are the binary tree's, so
its noise is; 1000 lights: 4 loops of 16 float32 lanes instead of 20 importances one by one (whole
renders 1.04-1.11x; `benchmarks/RESULTS.md`, "Many lights").  A walk's position is (block, slot):
slot -1 is the block's root, the children of slot s are slots 2s + 2 and 2s + 3, and a node in the
block's last level is the root of the block tree_i names.
"""
import math

import numba as nb
import numpy as np
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic
from numba.np.arrayobj import make_array, populate_array

from .jit import SHADING_INLINE_JIT as _JIT
from .tables import T_C, T_COS_O, T_PHI, T_RADIUS, T_SIN_O, T_W, TREE_COLS, TREE_SLOTS

ONE_MINUS = 0.99999994
NO_SAMPLE = (-1, 0.0)
# `choose_lights` splits at the first MAX_SPLITS nodes of its trail whose less likely child has a
# probability q of at most SPLIT_BELOW, and below them at every node with q at most SPLIT_DEEP
SPLIT_BELOW = 0.25
MAX_SPLITS = 2
SPLIT_DEEP = 0.01
_ONE32, _ZERO32, _TINY32 = np.float32(1.0), np.float32(0.0), np.float32(1e-30)


def _on_stack(dtype):
    """An intrinsic giving an array of TREE_SLOTS `dtype`s on the stack of the function that calls it
    (an alloca in its entry block: an intrinsic's code is emitted into its caller; no meminfo): the
    walks' scratch (the kernels allocate nothing on the heap)."""
    array = types.Array(dtype, 1, 'C')

    def stack(typingctx):
        def codegen(context, builder, sig, args):
            data = cgutils.alloca_once(builder, context.get_value_type(dtype), size=TREE_SLOTS)
            ary = make_array(array)(context, builder)
            itemsize = context.get_constant(types.intp, dtype.bitwidth // 8)
            populate_array(ary, data=data, shape=[context.get_constant(types.intp, TREE_SLOTS)],
                           strides=[itemsize], itemsize=itemsize, meminfo=None)
            return ary._getvalue()
        return array(), codegen
    stack.__name__ = stack.__qualname__ = f'stack_of_{dtype}'
    return intrinsic(stack)


_stack_floats = _on_stack(types.float32)       # a block's importances (`importances`)
_stack_doubles = _on_stack(types.float64)      # its pairs' probabilities (`_enter`)


@nb.njit(**dict(_JIT, error_model='numpy'))
def importances(tf, block, p, n, w):
    """The importance of each node of block `block` (a row of tf = PathLights.tree_f) at point p with normal n,
    into w (TREE_SLOTS float32s: stored as doubles, LLVM vectorised the loop four lanes a register on AVX2,
    to convert them; float32 stores take eight, and a block 49 ns instead of 96 ns on the AVX2 host of
    `benchmarks/RESULTS.md`, the same values).  A node's importance: its power over the squared distance (at
    least its bounding radius, as pbrt's half diagonal), times upper bounds of the cosine at the lights (the
    angle between the direction to p and the cone of emission normals, less the angle the node's bounding
    sphere subtends; zero beyond pi/2, where no light emits) and of the cosine at the receiver.  Inside the
    bounding sphere every direction is possible: both bounds are 1.  Nodes whose normals point everywhere
    (cos theta_o = -1: points, spheres, mixed nodes) skip the cone bound.  Ten float32 fields a slot (ten
    cache lines a block: the loads are the loop's cost, more than its arithmetic; `benchmarks/RESULTS.md`).
    In float32, as the table is (sixteen lanes of one AVX-512 register; the choices need no more: float32
    can zero a node that lights p only where its cosine bound is within ~1e-7 of 0, a share of its light of
    that order), without branches (selects), and the number of slots read from the table, not a constant, so
    that LLVM vectorises the loop instead of unrolling it."""
    nw = tf.shape[1] // TREE_COLS
    px, py, pz = np.float32(p[0]), np.float32(p[1]), np.float32(p[2])
    nx, ny, nz = np.float32(n[0]), np.float32(n[1]), np.float32(n[2])
    for j in range(nw):
        dx = px - tf[block, T_C * nw + j]
        dy = py - tf[block, (T_C + 1) * nw + j]
        dz = pz - tf[block, (T_C + 2) * nw + j]
        dd = max(dx * dx + dy * dy + dz * dz, _TINY32)
        # one square root and two divisions of dd, side by side; the sines of the angles from their
        # squares: a walk takes one block after the other, so this chain's latency is its cost
        a = _ONE32 / dd
        inv = math.sqrt(dd) * a                      # 1 / distance
        r = tf[block, T_RADIUS * nw + j]
        falloff = tf[block, T_PHI * nw + j] / max(dd, r)
        sin_b2 = min(r * r * a, _ONE32)
        sin_b = math.sqrt(sin_b2)
        cos_b = math.sqrt(_ONE32 - sin_b2)
        cos_o = tf[block, T_COS_O * nw + j]
        so = tf[block, T_SIN_O * nw + j]             # its sign bit: two-sided
        sin_o = abs(so)
        dw = tf[block, T_W * nw + j] * dx + tf[block, (T_W + 1) * nw + j] * dy + tf[block, (T_W + 2) * nw + j] * dz
        dw = abs(dw) if math.copysign(_ONE32, so) < _ZERO32 else dw
        cos_w = dw * inv
        sin_w = math.sqrt(max(_ZERO32, _ONE32 - dw * dw * a))
        within = cos_w > cos_o                       # theta_x = max(0, theta_w - theta_o)
        cos_x = _ONE32 if within else cos_w * cos_o + sin_w * sin_o
        sin_x = _ZERO32 if within else sin_w * cos_o - cos_w * sin_o
        cos_p = _ONE32 if cos_x > cos_b else cos_x * cos_b + sin_x * sin_b     # cos(max(0, theta_x - theta_b))
        cos_p = _ONE32 if cos_o <= -_ONE32 else cos_p
        dn = dx * nx + dy * ny + dz * nz
        ci = abs(dn) * inv
        sin_i = math.sqrt(max(_ZERO32, _ONE32 - dn * dn * a))
        cos_i = _ONE32 if ci >= cos_b else ci * cos_b + sin_i * sin_b           # cos(max(0, theta_i - theta_b))
        inside = dd <= r * r
        v = falloff * (_ONE32 if inside else cos_p * cos_i)
        v = _ZERO32 if (cos_p <= _ZERO32 and not inside) else v    # beyond pi/2 of every normal
        w[j] = v if v > _ZERO32 else _ZERO32         # (and 0 for NaN)


@nb.njit(**dict(_JIT, error_model='numpy'))
def _enter(tf, block, p, n, w, pr):
    """Entering block `block`: its importances at p, n into w (`importances`) and, for each pair k of
    siblings (slots 2k and 2k + 1: the children of slot k - 1, the block root's for k = 0), the
    probability of the first, w[2k] / (w[2k] + w[2k + 1]) in double (as `light_pmf` computes it), into
    pr[k] (NaN where both are 0: no child to take).  One loop over the pairs (LLVM vectorises it)
    instead of a division per binary step: a walk's steps wait on each other, and each waited on its
    division (computing only the three pairs a walk takes, at its steps, measured slower: `benchmarks/
    RESULTS.md`)."""
    importances(tf, block, p, n, w)
    for k in range(TREE_SLOTS // 2):
        a, b = np.float64(w[2 * k]), np.float64(w[2 * k + 1])
        pr[k] = a / (a + b)


@nb.njit(**_JIT)
def _p_unbounded(L):
    """Probability of choosing one of the lights without a position (dome, distant) at all."""
    nu = L.unbounded.shape[0]
    return nu / (nu + (1 if L.n_bounded > 0 else 0)) if nu > 0 else 0.0


@nb.njit(**_JIT)
def _step(tf, ti, block, slot, p, n, w, pr):
    """The position after slot `slot` of block `block` (pr: its pairs' probabilities, `_enter`): (block,
    slot, leaf light or -1); entering a new block computes its importances and probabilities."""
    code = ti[block, slot]
    if code < 0:
        return block, slot, -1 - code
    if code > 0:
        _enter(tf, code, p, n, w, pr)
        return code, -1, -1
    return block, slot, -1


@nb.njit(**_JIT)
def _choice(u, p0, pmf):
    """One binary step: (second child taken, pmf times its probability, u rescaled inside its interval);
    without branches (selects: the choice is a coin toss, which a branch would mispredict half the
    time)."""
    second = u >= p0
    pc = 1.0 - p0 if second else p0
    lo = p0 if second else 0.0
    return second, pmf * pc, min((u - lo) / pc, ONE_MINUS)


@nb.njit(**_JIT)
def _walk(L, p, n, block, slot, pmf, u):
    """The light a plain walk from slot `slot` of block `block` reaches (each child with its
    probability), and its probability (times `pmf`, the probability of reaching that slot)."""
    tf = L.tree_f
    ti = L.tree_i
    w, pr = _stack_floats(), _stack_doubles()
    if ti[block, slot] == 0:                         # an inner slot: its children are in this block
        _enter(tf, block, p, n, w, pr)
    block, slot, light = _step(tf, ti, block, slot, p, n, w, pr)
    while light < 0:
        p0 = pr[slot + 1]
        if not p0 >= 0.0:
            return NO_SAMPLE
        second, pmf, u = _choice(u, p0, pmf)
        block, slot, light = _step(tf, ti, block, 2 * slot + 2 + second, p, n, w, pr)
    return light, pmf


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
    w, pr = _stack_floats(), _stack_doubles()
    _enter(tf, 0, p, n, w, pr)
    block, slot, light = 0, -1, -1
    pmf = 1.0 - pu                                   # probability of reaching the slot (its walk's choices)
    none, once = 1.0, 0.0                            # probability of no, one side-sample chance so far
    b1, s1, w1, u1 = -1, 0, 0.0, 0.0                 # side samples: where their walks start (block, slot),
    b2, s2, w2, u2 = -1, 0, 0.0, 0.0                 # their expected counts there, their u there
    splits = 0
    while light < 0:
        c0 = 2 * slot + 2
        p0 = pr[slot + 1]
        if not p0 >= 0.0:
            pmf = 0.0
            break
        q = min(p0, 1.0 - p0)
        if _splits(q, splits):
            splits += 1
            likely, other = (c0, c0 + 1) if p0 >= 0.5 else (c0 + 1, c0)
            if u < q:                                # the side sample's chance
                u = min(u / q, ONE_MINUS)
                if b1 < 0:
                    b1, s1, w1, u1 = block, other, pmf * q * (none + once), u
                elif b2 < 0:
                    b2, s2, w2, u2 = block, other, pmf * q * (none + once), u
            else:
                u = min((u - q) / (1.0 - q), ONE_MINUS)
            none, once = none * (1.0 - q), once * (1.0 - q) + none * q
            block, slot, light = _step(tf, ti, block, likely, p, n, w, pr)
        else:                                        # (q > SPLIT_BELOW, or splits >= MAX_SPLITS)
            second, pmf, u = _choice(u, p0, pmf)
            block, slot, light = _step(tf, ti, block, c0 + second, p, n, w, pr)
    side1 = _walk(L, p, n, b1, s1, w1, u1) if b1 >= 0 else NO_SAMPLE
    side2 = _walk(L, p, n, b2, s2, w2, u2) if b2 >= 0 else NO_SAMPLE
    if pmf == 0.0:
        return NO_SAMPLE, side1, side2
    return (light, pmf), side1, side2


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
    w = _stack_floats()                              # (its trail is known: no step waits on a division)
    importances(tf, 0, p, n, w)
    block, slot = 0, -1
    pmf = 1.0 - _p_unbounded(L)
    trail = L.trail[k]
    none, once = 1.0, 0.0
    splits = 0
    side = False                                     # k is past a split node's less likely child
    for level in range(d):
        c0 = 2 * slot + 2
        i0, i1 = np.float64(w[c0]), np.float64(w[c0 + 1])
        if not (i0 + i1 > 0.0):
            return 0.0
        p0 = i0 / (i0 + i1)
        bit = (trail >> level) & 1
        pk = 1.0 - p0 if bit else p0
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
        if level + 1 < d:                            # (an inner node: its children here or in block `code`)
            code = ti[block, c0 + bit]
            block, slot = (code, -1) if code > 0 else (block, c0 + bit)
            if code > 0:
                importances(tf, block, p, n, w)
    return pmf
