"""The light tree the path integrator chooses its light sample from (Conty Estevez & Kulla 2018,
"Importance Sampling of Many Lights with Adaptive Tree Splitting"; pbrt-v4's BVHLightSampler).

Every light with a position (point, rect, disk, sphere, cylinder) is a leaf with its *light bounds*:
a box, its phi (its largest radiant intensity, `light_selection.light_phi`) and the cone of its emission
normals (axis w, half-angle theta_o), one-sided or two-sided.  Every light emits up to pi/2 beyond its
normals (pbrt's theta_e: UsdLux lights emit into a hemisphere about each normal, or everywhere; rtc reads
no ShapingAPI cone), so theta_e is a constant of the kernel, not a bound.  Inner nodes bound their children (union of boxes,
sum of phis, union of cones).  At a shading point the kernel walks from the root to a leaf, taking
each child with probability proportional to its *importance* there: phi / distance^2, times
bounds on the cosines at the light and at the receiver (`kernel/light_tree.py`), so a light far away,
facing away or below the horizon is rarely chosen, whatever its power.  Lights without a position
(dome, distant) are chosen uniformly with probability n / (n + 1) (n of them; the tree the rest).

Split: the lights are cut at the median of their centres along the longest axis of the centres'
box (a balanced binary tree: depth log2 n).  Each light's path from the root is kept as a bit trail,
so that the probability of a given light at a given point (MIS of BSDF-sampled rays that hit it) is
one walk down that path.  The tree is stored in *blocks* of three levels: the 14 nodes below a node
(its children, grandchildren and great-grandchildren), whose importances the kernel computes in one
vectorised loop (float32: sixteen lanes) before it takes the three binary steps through them (1000
lights: 4 loops instead of 20 importances one by one; `benchmarks/RESULTS.md`, "Many lights").  The
choices are the binary tree's: nodes of eight children chosen among directly were faster still but
measured 7-11 % more noise at equal samples (the importance of a small cluster is a looser guess
than the binary walk's, which weighs it with its parents' bounds).

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

import numpy as np

from .. import description as D
from ..kernel.tables import LF_LENGTH, LF_M, LF_RADIUS, LIGHT_TREE, TREE_LEVELS, TREE_SLOTS
ENTIRE = (np.array([0.0, 0.0, 1.0]), -1.0)          # the cone of every direction


def _angle(a, b):
    return math.acos(max(-1.0, min(1.0, float(np.dot(a, b)))))


def cone_union(a, b):
    """The smallest cone (axis, cos half-angle) holding the cones a and b (pbrt's DirectionCone Union)."""
    (wa, ca), (wb, cb) = a, b
    ta, tb = math.acos(max(-1.0, min(1.0, ca))), math.acos(max(-1.0, min(1.0, cb)))
    td = _angle(wa, wb)
    if min(td + tb, math.pi) <= ta:
        return a
    if min(td + ta, math.pi) <= tb:
        return b
    to = 0.5 * (ta + td + tb)
    if to >= math.pi:
        return ENTIRE
    axis = np.cross(wa, wb)
    n = float(np.linalg.norm(axis))
    if n == 0.0:
        return ENTIRE
    axis /= n
    tr = to - ta                                      # rotate wa by tr about axis (Rodrigues)
    w = wa * math.cos(tr) + np.cross(axis, wa) * math.sin(tr) + axis * float(np.dot(axis, wa)) * (1 - math.cos(tr))
    return w / np.linalg.norm(w), math.cos(to)


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
        idx.append(k)
        bounds.append((lo, hi, float(power[k]), cone, False))
    return idx, bounds


def _union(items):
    lo = np.min([b[0] for b in items], 0)
    hi = np.max([b[1] for b in items], 0)
    cone = items[0][3]
    for b in items[1:]:
        cone = cone_union(cone, b[3])
    return lo, hi, sum(b[2] for b in items), cone, any(b[4] for b in items)


def _record(b) -> np.ndarray:
    """The LIGHT_TREE fields of bounds b = (lo, hi, phi, (w, cos_o), two_sided)."""
    lo, hi, phi, (w, cos_o), two = b
    rec = np.zeros(LIGHT_TREE.width)
    sin_o = math.sqrt(max(0.0, 1.0 - cos_o * cos_o))
    LIGHT_TREE.write(rec, C=0.5 * (lo + hi), RADIUS=0.5 * float(np.linalg.norm(hi - lo)), PHI=phi, W=w, COS_O=cos_o,
                     SIN_O=math.copysign(sin_o, -1.0 if two else 1.0))
    return rec


def _binary(items: list[int], bounds: list):
    """The balanced binary tree over `items` (indices into bounds): an int for a leaf, else (left,
    right): split at the median of the centres along the longest axis of their box."""
    if len(items) == 1:
        return items[0]
    centres = np.array([0.5 * (bounds[j][0] + bounds[j][1]) for j in items])
    axis = int(np.argmax(centres.max(0) - centres.min(0)))
    order = [items[j] for j in np.argsort(centres[:, axis], kind='stable')]
    half = len(order) // 2
    return _binary(order[:half], bounds), _binary(order[half:], bounds)


def _leaves(t) -> list[int]:
    return [t] if isinstance(t, int) else _leaves(t[0]) + _leaves(t[1])


def _height(t) -> int:
    return 0 if isinstance(t, int) else 1 + max(_height(t[0]), _height(t[1]))


def build_tree(lights: list[int], bounds: list) -> tuple[np.ndarray, np.ndarray, dict]:
    """(tree_f, tree_i, {light: (trail, depth)}) of the balanced binary tree over `bounds` (one per
    light, `_binary`), stored in blocks of TREE_LEVELS levels (`tables.LIGHT_TREE`): a block holds the
    nodes below its root node down to TREE_LEVELS levels (the root block fewer, so that the deepest
    blocks are full), so that the kernel computes their importances in one vectorised loop and walks
    the levels from them.  tree_f (blocks, LIGHT_TREE.width * TREE_SLOTS): each slot's bounds,
    field-major; tree_i (blocks, TREE_SLOTS): -1 - light for a leaf, for a node in the block's last
    level the block (> 0) it is the root of, 0 for the block's other nodes, -1 for an empty slot (phi
    0: never chosen).  A light's trail has bit d set where its way takes the second child at depth d;
    its depth is the number of binary choices on that way (a lone light: 1, between it and an empty
    slot)."""
    rows_f, rows_i, leaves = [], [], {}

    def block(t, trail, depth, levels):
        b = len(rows_f)
        row_f = np.zeros((LIGHT_TREE.width, TREE_SLOTS))            # (empty slots: phi 0)
        row_i = np.full(TREE_SLOTS, -1, np.int64)
        rows_f.append(row_f)
        rows_i.append(row_i)

        def fill(slot, node, level, trail, depth):                   # node: at binary depth `depth`
            items = _leaves(node)
            row_f[:, slot] = _record(_union([bounds[k] for k in items]) if len(items) > 1 else bounds[items[0]])
            if isinstance(node, int):
                row_i[slot] = -1 - lights[node]
                leaves[lights[node]] = (trail, depth)
            elif level == levels - 1:
                row_i[slot] = block(node, trail, depth, TREE_LEVELS)
            else:
                row_i[slot] = 0
                fill(2 * slot + 2, node[0], level + 1, trail, depth + 1)
                fill(2 * slot + 3, node[1], level + 1, trail | (1 << depth), depth + 1)

        kids = (t,) if isinstance(t, int) else t                     # (a lone light: one child)
        for j, c in enumerate(kids):
            fill(j, c, 0, trail | (j << depth), depth + 1)
        return b

    if lights:
        root = _binary(list(range(len(lights))), bounds)
        block(root, 0, 0, (max(_height(root), 1) - 1) % TREE_LEVELS + 1)
    return (np.array([r.reshape(-1) for r in rows_f], np.float32).reshape(-1, LIGHT_TREE.width * TREE_SLOTS),
            np.array(rows_i, np.int64).reshape(-1, TREE_SLOTS), leaves)


def leaf_record(tree_f: np.ndarray, tree_i: np.ndarray, light: int) -> np.ndarray:
    """The LIGHT_TREE fields (a view) of the leaf of `light` in a tree `build_tree` made."""
    b, slot = np.argwhere(tree_i == -1 - light)[0]
    return tree_f[b].reshape(LIGHT_TREE.width, TREE_SLOTS)[:, slot]


def light_tree(desc: D.SceneDescription, li_f: np.ndarray, power: np.ndarray, extra=()):
    """(tree_f, tree_i, trail, depth, unbounded) of the scene's lights (`power`: one per light) and of
    `extra` lights (bounds as `light_bounds` gives them: the emissive surfaces, `surface_lights.py`),
    numbered after the scene's."""
    n = max(len(desc.lights) + len(extra), 1)
    idx, bounds = light_bounds(desc, li_f, power)
    idx += [len(desc.lights) + j for j in range(len(extra))]
    bounds += list(extra)
    tree_f, tree_i, leaves = build_tree(idx, bounds)
    trail = np.zeros(n, np.int64)
    depth = np.full(n, -1, np.int64)                   # -1: not in the tree
    for k, (t, d) in leaves.items():
        trail[k], depth[k] = t, d
    if len(tree_f) == 0:                               # kernels index row 0: a node of empty slots
        tree_f, tree_i = np.zeros((1, LIGHT_TREE.width * TREE_SLOTS), np.float32), np.full((1, TREE_SLOTS), -1, np.int64)
    unbounded = [k for k, l in enumerate(desc.lights) if l.type in (D.DOME, D.DISTANT) and power[k] > 0.0]
    return tree_f, tree_i, trail, depth, np.array(unbounded, np.int64), len(idx)
