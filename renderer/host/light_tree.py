"""The light tree the path integrator chooses its light sample from (Conty Estevez & Kulla 2018,
"Importance Sampling of Many Lights with Adaptive Tree Splitting"; pbrt-v4's BVHLightSampler).

Every light with a position (point, rect, disk, sphere, cylinder) is a leaf with its *light bounds*:
a box, its phi (its largest radiant intensity, `light_selection.light_phi`) and the cone of its emission
normals (axis w, half-angle theta_o), one-sided or two-sided.  Every light emits up to pi/2 beyond its
normals (pbrt's theta_e: UsdLux lights emit into a hemisphere about each normal, or everywhere), so theta_e is a
constant of the kernel, not a bound; a spotlight (a point or sphere light with a ShapingAPI cone under 90 degrees)
has its cone for its normals' (theta_o the cone's angle about -Z): beyond theta_o + pi/2 it is never chosen, a bound
looser than its cone's, which keeps the estimate unbiased.  Inner nodes bound their children (union of boxes,
sum of phis, union of cones).  At a shading point the kernel walks from the root to a leaf, taking
each child with probability proportional to its *importance* there: phi / distance^2, times
bounds on the cosines at the light and at the receiver (`kernel/light_tree.py`), so a light far away,
facing away or below the horizon is rarely chosen, whatever its power.  Lights without a position
(dome, distant) are chosen uniformly with probability n / (n + 1) (n of them; the tree the rest).

Split: the lights are cut at the median of their centres along the longest axis of the centres' box (a
balanced binary tree: depth log2 n).  Each light's path from the root is kept as a bit trail, so that the
probability of a given light at a given point (MIS of BSDF-sampled rays that hit it) is one walk down
that path.  The build sorts every node of a level at once (`median_order`) and bounds them with numpy's
reductions over their runs of lights (`_node_bounds`; the cones folded by a compiled loop in large
trees): 200,000 lights in ~3 s (`benchmarks/RESULTS.md`).  The tree is stored in *blocks* of three
levels: the 14 nodes below a node (its children, grandchildren and great-grandchildren), whose
importances the kernel computes in one vectorised loop (float32: sixteen lanes) before it takes the three
binary steps through them (1000 lights: 4 loops instead of 20 importances one by one;
`benchmarks/RESULTS.md`, "Many lights").  The choices are the binary tree's: nodes of eight children
chosen among directly were faster still but measured 7-11 % more noise at equal samples (the importance
of a small cluster is a looser guess than the binary walk's, which weighs it with its parents' bounds).

Arrays (the `PathLights` fields `tree_f`, `tree_i`, `trail`, `depth`, `unbounded`):
  tree_f float32 (blocks, tables.LIGHT_TREE * TREE_SLOTS): the bounds of each slot of a block -
         centre, bounding-sphere radius (half the box's diagonal), phi, w, cos and sin theta_o (the
         sine's sign bit set for a two-sided node: 10 fields, 10 cache lines a block) - field-major (column T_x * TREE_SLOTS + j: field x of slot j); the children of
         slot s are in slots 2s + 2 and 2s + 3, the block root's in slots 0 and 1
  tree_i int64 (blocks, TREE_SLOTS): -1 - light for a leaf; for an inner node of the block's last level
         the block below it (> 0); 0 for the block's other inner nodes; -1 (phi 0) for an empty slot.
         The root block has (height - 1) % 3 + 1 levels, so that every block below it has three
  trail  int64 (lights,): bit d set = the second child at depth d; depth int64 (lights,): the number
         of binary choices on its way (-1: not in the tree)
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from .. import description as D
from ..kernel.tables import LF_LENGTH, LF_M, LF_RADIUS, LIGHT_TREE, TREE_LEVELS, TREE_SLOTS
ENTIRE = (np.array([0.0, 0.0, 1.0]), -1.0)          # the cone of every direction


def cone_union(a, b):
    """The smallest cone (axis, cos half-angle) holding the cones a and b (pbrt's DirectionCone Union)."""
    (wa, ca), (wb, cb) = a, b
    *w, c = _cone_union.py_func(float(wa[0]), float(wa[1]), float(wa[2]), float(ca), float(wb[0]), float(wb[1]),
                                float(wb[2]), float(cb))
    return np.array(w), c


@nb.njit(cache=True)
def _cone_union(a0, a1, a2, ca, b0, b1, b2, cb):
    """`cone_union` of the cones of unit axes a, b and cos half-angles ca, cb: (axis, cos half-angle)."""
    ta, tb = math.acos(max(-1.0, min(1.0, ca))), math.acos(max(-1.0, min(1.0, cb)))
    td = math.acos(max(-1.0, min(1.0, a0 * b0 + a1 * b1 + a2 * b2)))
    if min(td + tb, math.pi) <= ta:
        return a0, a1, a2, ca
    if min(td + ta, math.pi) <= tb:
        return b0, b1, b2, cb
    to = 0.5 * (ta + td + tb)
    x0, x1, x2 = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
    n = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
    if to >= math.pi or n == 0.0:
        return 0.0, 0.0, 1.0, -1.0                    # ENTIRE
    x0, x1, x2 = x0 / n, x1 / n, x2 / n
    tr = to - ta                                      # rotate a by tr about x (Rodrigues)
    c, s = math.cos(tr), math.sin(tr)
    d = (x0 * a0 + x1 * a1 + x2 * a2) * (1.0 - c)
    w0 = a0 * c + (x1 * a2 - x2 * a1) * s + x0 * d
    w1 = a1 * c + (x2 * a0 - x0 * a2) * s + x1 * d
    w2 = a2 * c + (x0 * a1 - x1 * a0) * s + x2 * d
    m = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    return w0 / m, w1 / m, w2 / m, math.cos(to)


@nb.njit(cache=True)
def _fold_cones(w, cos_o, order, first, size, out):
    """The cone of each run (its lights order[first:first + size]): `cone_union` folded over them in order,
    into out (runs, 4: axis, cos half-angle)."""
    for r in range(len(first)):
        k = order[first[r]]
        a0, a1, a2, ca = w[k, 0], w[k, 1], w[k, 2], cos_o[k]
        for j in range(first[r] + 1, first[r] + size[r]):
            k = order[j]
            a0, a1, a2, ca = _cone_union(a0, a1, a2, ca, w[k, 0], w[k, 1], w[k, 2], cos_o[k])
        out[r, 0], out[r, 1], out[r, 2], out[r, 3] = a0, a1, a2, ca


FOLD_COMPILED = 50_000      # unions above which `_fold_cones` runs compiled (its first call loads it: ~0.15 s)


def _fold_cones_python(w, cos_o, order, first, size, out):
    """`_fold_cones` in Python (`cone_union`, the same operations: the same values), for trees too small to
    repay loading the compiled one."""
    for r, (f, m) in enumerate(zip(first, size)):
        cone = (w[order[f]], cos_o[order[f]])
        for k in order[f + 1:f + m]:
            cone = cone_union(cone, (w[k], cos_o[k]))
        out[r] = (*cone[0], cone[1])


def emitting_angle(light: D.Light) -> float:
    """The angle off a light's -Z axis (radians) past which its shaping leaves no emission: its cone's, and its IES
    profile's last vertical angle that emits (the next one's, where the profile falls to 0 between them), mapped back
    through ies:angleScale (`kernel/ies_profiles.py`: theta_ies = pi - (pi - theta) / s); pi when nothing bounds it."""
    theta = np.pi if light.shaping is None else min(np.pi, float(np.radians(light.shaping[0])))
    p = light.ies
    if p is not None:
        lit = np.flatnonzero(p.candela.max(axis=0) > 0.0)
        last = p.vertical[min(lit[-1] + 1, len(p.vertical) - 1)] if len(lit) else 0.0
        s = 1.0 + light.ies_angle_scale
        theta = min(theta, max(0.0, np.pi - s * (np.pi - float(last))) if last < np.pi else np.pi)
    return theta


def light_bounds(desc: D.SceneDescription, li_f: np.ndarray, power: np.ndarray):
    """(indices of the bounded lights, list of (lo, hi, phi, cone, two_sided)) of the scene's
    lights with a position, in world (camera-relative) coordinates of the light table."""
    idx, bounds = [], []
    for k, l in enumerate(desc.lights):
        if l.type in (D.DOME, D.DISTANT) or not power[k] > 0.0:
            continue
        m = li_f[k, LF_M:LF_M + 12].reshape(3, 4)
        c = m[:, 3]
        if l.type in (D.RECT, D.DISK):
            half = (0.5 * l.width, 0.5 * l.height) if l.type == D.RECT else (l.radius, l.radius)
            ex, ey = m[:, 0] * half[0], m[:, 1] * half[1]
            corners = np.array([c - ex - ey, c + ex - ey, c + ex + ey, c - ex + ey])
            lo, hi = corners.min(0), corners.max(0)
            w = -m[:, 2] / max(float(np.linalg.norm(m[:, 2])), 1e-300)           # emits along local -Z
            cone = (w, 1.0)
        elif l.type == D.CYLINDER:                     # the box of the cylinder about its axis (local X)
            a = m[:, 0] / max(float(np.linalg.norm(m[:, 0])), 1e-300)
            ext = np.abs(a) * 0.5 * li_f[k, LF_LENGTH] + li_f[k, LF_RADIUS] * np.sqrt(np.maximum(0.0, 1.0 - a * a))
            lo, hi = c - ext, c + ext
            cone = ENTIRE
        else:                                          # point, sphere (and any round light): everywhere
            r = li_f[k, LF_RADIUS] if l.type != D.POINT else 0.0
            lo, hi = c - r, c + r
            cone = ENTIRE
            theta = emitting_angle(l)
            if theta < 0.5 * np.pi:                    # a spotlight, a downlight: its cone about its -Z axis
                w = -m[:, 2] / max(float(np.linalg.norm(m[:, 2])), 1e-300)
                cone = (w, float(np.cos(theta)))
        idx.append(k)
        bounds.append((lo, hi, float(power[k]), cone, False))
    return idx, bounds


def median_order(centres: np.ndarray) -> tuple[np.ndarray, list]:
    """(the leaves of the balanced binary tree over lights with these centres (n, 3), in its order; its inner
    nodes, a (start, size) pair of arrays a level): each node's lights are cut at the median of their centres
    along the longest axis of the centres' box (the first half, n // 2 lights, its first child), sorted stably,
    so that ties keep the order the parent had; one level of the tree at a time, each a sort of every node's
    lights at once.  A node is a run of this order: (start, n) has the children (start, n // 2) and
    (start + n // 2, n - n // 2); a run of one is a leaf."""
    order = np.arange(len(centres))
    start, size = np.zeros(1, np.int64), np.array([len(centres)])
    levels = []
    while True:
        start, size = start[size > 1], size[size > 1]
        if not len(start):
            return order, levels
        levels.append((start, size))
        run, pos, first = _runs(start, size)
        c = centres[order[pos]]
        axis = np.argmax(np.maximum.reduceat(c, first) - np.minimum.reduceat(c, first), 1)
        order[pos] = order[pos[np.lexsort((c[np.arange(len(pos)), axis[run]], run))]]
        half = size // 2
        start, size = np.concatenate([start, start + half]), np.concatenate([half, size - half])


def _runs(start: np.ndarray, size: np.ndarray):
    """(each element's run, its position in the order, each run's first element in `pos`) of disjoint runs."""
    first = np.cumsum(size) - size
    run = np.repeat(np.arange(len(start)), size)
    return run, start[run] + np.arange(int(size.sum())) - first[run], first


def _node_bounds(bounds: list, order: np.ndarray, levels: list) -> tuple[np.ndarray, dict]:
    """(LIGHT_TREE records of the lights (rows 0..n-1, `bounds` order) and of the inner nodes after them,
    {(start, size): row} of the inner nodes) - a node's box and two-sidedness its lights', its phi their sum, its
    cone their cones' union folded in the tree's order (`_fold_cones`: folded one light at a time, a cone stays
    tighter than the union of its children's unions; measured in `benchmarks/RESULTS.md`); a level of the tree
    at a time, numpy's reductions over its nodes' runs of `order`."""
    n = len(bounds)
    lo = np.array([b[0] for b in bounds], np.float64).reshape(n, 3)
    hi = np.array([b[1] for b in bounds], np.float64).reshape(n, 3)
    phi = np.array([b[2] for b in bounds], np.float64)
    w = np.array([b[3][0] for b in bounds], np.float64).reshape(n, 3)
    cos_o = np.array([b[3][1] for b in bounds], np.float64)
    two = np.array([bool(b[4]) for b in bounds])
    parts, rows = [(lo, hi, phi, w, cos_o, two)], {}
    fold = _fold_cones if sum(int(size.sum()) for _, size in levels) > FOLD_COMPILED else _fold_cones_python
    for start, size in levels:
        run, pos, first = _runs(start, size)
        k = order[pos]
        cones = np.empty((len(start), 4))
        fold(w, cos_o, order, start, size, cones)
        parts.append((np.minimum.reduceat(lo[k], first), np.maximum.reduceat(hi[k], first),
                      np.add.reduceat(phi[k], first), cones[:, :3], cones[:, 3],
                      np.logical_or.reduceat(two[k], first)))
        base = n + sum(len(p[2]) for p in parts[1:-1])
        rows.update(zip(zip(start.tolist(), size.tolist()), range(base, base + len(start))))
    lo, hi, phi, w, cos_o, two = (np.concatenate(x) for x in zip(*parts))
    sin_o = np.sqrt(np.maximum(0.0, 1.0 - cos_o * cos_o)) * np.where(two, -1.0, 1.0)
    rec = np.zeros((len(phi), LIGHT_TREE.width))
    LIGHT_TREE.write_rows(rec, C=0.5 * (lo + hi), RADIUS=0.5 * np.linalg.norm(hi - lo, axis=1), PHI=phi, W=w,
                          COS_O=cos_o, SIN_O=sin_o)
    return rec, rows


def build_tree(lights: list[int], bounds: list) -> tuple[np.ndarray, np.ndarray, dict, np.ndarray]:
    """(tree_f, tree_i, {light: (trail, depth)}, leaves) of the balanced binary tree over `bounds` (one per
    light, `median_order`), stored in blocks of TREE_LEVELS levels (`tables.LIGHT_TREE`): a block holds the
    nodes below its root node down to TREE_LEVELS levels (the root block fewer, so that the deepest
    blocks are full), so that the kernel computes their importances in one vectorised loop and walks
    the levels from them.  tree_f (blocks, LIGHT_TREE.width * TREE_SLOTS): each slot's bounds
    (`_node_bounds`), field-major; tree_i (blocks, TREE_SLOTS): -1 - light for a leaf, for a node in the
    block's last level the block (> 0) it is the root of, 0 for the block's other nodes, -1 for an empty
    slot (phi 0: never chosen).  A light's trail has bit d set where its way takes the second child at
    depth d; its depth is the number of binary choices on that way (a lone light: 1, between it and an
    empty slot).  leaves float32 (LIGHT_TREE.width, len(lights)): each light's own bounds, field-major, in the
    order of `lights` (`kernel/tile_lights.py` weighs every light at once from them)."""
    if not lights:
        return (np.zeros((0, LIGHT_TREE.width * TREE_SLOTS), np.float32), np.zeros((0, TREE_SLOTS), np.int64), {},
                np.zeros((LIGHT_TREE.width, 0), np.float32))
    order, levels = median_order(0.5 * (np.array([b[0] for b in bounds]) + np.array([b[1] for b in bounds])))
    records, inner = _node_bounds(bounds, order, levels)
    rows_i, placed, leaves = [], [], {}

    def block(start, size, trail, depth, levels):
        """A new block whose root is the run (start, size): its index."""
        b = len(rows_i)
        row_i = np.full(TREE_SLOTS, -1, np.int64)
        rows_i.append(row_i)

        def fill(slot, start, size, level, trail, depth):          # the run's node: at binary depth `depth`
            if size == 1:
                k = int(order[start])
                row_i[slot], leaves[lights[k]] = -1 - lights[k], (trail, depth)
                placed.append((b, slot, k))
                return
            placed.append((b, slot, inner[start, size]))
            if level == levels - 1:
                row_i[slot] = block(start, size, trail, depth, TREE_LEVELS)
                return
            row_i[slot], h = 0, size // 2
            fill(2 * slot + 2, start, h, level + 1, trail, depth + 1)
            fill(2 * slot + 3, start + h, size - h, level + 1, trail | (1 << depth), depth + 1)

        h = size // 2                                                # (a lone light: one child)
        kids = ((start, 1),) if size == 1 else ((start, h), (start + h, size - h))
        for j, (s, m) in enumerate(kids):
            fill(j, s, m, 0, trail | (j << depth), depth + 1)
        return b

    height = (len(lights) - 1).bit_length()                        # ceil(log2 n)
    block(0, len(lights), 0, 0, (max(height, 1) - 1) % TREE_LEVELS + 1)
    tree_f = np.zeros((len(rows_i), LIGHT_TREE.width, TREE_SLOTS))   # (empty slots: phi 0)
    b, slot, node = np.array(placed).T
    tree_f[b, :, slot] = records[node]
    return (tree_f.astype(np.float32).reshape(-1, LIGHT_TREE.width * TREE_SLOTS),
            np.array(rows_i, np.int64).reshape(-1, TREE_SLOTS), leaves,
            np.ascontiguousarray(records[:len(lights)].T, np.float32))


def leaf_record(tree_f: np.ndarray, tree_i: np.ndarray, light: int) -> np.ndarray:
    """The LIGHT_TREE fields (a view) of the leaf of `light` in a tree `build_tree` made."""
    b, slot = np.argwhere(tree_i == -1 - light)[0]
    return tree_f[b].reshape(LIGHT_TREE.width, TREE_SLOTS)[:, slot]


def light_tree(desc: D.SceneDescription, li_f: np.ndarray, power: np.ndarray, extra=()):
    """(tree_f, tree_i, trail, depth, unbounded, n_bounded, (leaf bounds, their lights)) of the scene's lights
    (`power`: one per light) and of `extra` lights (bounds as `light_bounds` gives them: the emissive surfaces,
    `surface_lights.py`), numbered after the scene's; the leaves' bounds as `build_tree` gives them, and the light
    of each (int64)."""
    n = max(len(desc.lights) + len(extra), 1)
    idx, bounds = light_bounds(desc, li_f, power)
    idx += [len(desc.lights) + j for j in range(len(extra))]
    bounds += list(extra)
    tree_f, tree_i, leaves, leaf_f = build_tree(idx, bounds)
    trail = np.zeros(n, np.int64)
    depth = np.full(n, -1, np.int64)                   # -1: not in the tree
    for k, (t, d) in leaves.items():
        trail[k], depth[k] = t, d
    if len(tree_f) == 0:                               # kernels index row 0: a node of empty slots
        tree_f, tree_i = np.zeros((1, LIGHT_TREE.width * TREE_SLOTS), np.float32), np.full((1, TREE_SLOTS), -1, np.int64)
    unbounded = [k for k, l in enumerate(desc.lights) if l.type in (D.DOME, D.DISTANT) and power[k] > 0.0]
    return tree_f, tree_i, trail, depth, np.array(unbounded, np.int64), len(idx), (leaf_f, np.array(idx, np.int64))
