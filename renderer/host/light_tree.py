"""The light tree the path integrator chooses its light sample from (Conty Estevez & Kulla 2018,
"Importance Sampling of Many Lights with Adaptive Tree Splitting"; pbrt-v4's BVHLightSampler).

Every light with a position (point, rect, disk, sphere, cylinder) is a leaf with its *light bounds*:
a box, its phi (its largest radiant intensity, `light_selection.light_phi`), the cone of its emission normals (axis w, half-angle theta_o) and the angle
theta_e beyond the normals up to which it emits (pi/2 for every UsdLux light: they emit into a
hemisphere about each normal, or everywhere).  Inner nodes bound their children (union of boxes,
sum of phis, union of cones).  At a shading point the kernel walks from the root to a leaf, taking
each child with probability proportional to its *importance* there: phi / distance^2, times
bounds on the cosines at the light and at the receiver (`kernel/light_tree.py`), so a light far away,
facing away or below the horizon is rarely chosen, whatever its power.  Lights without a position
(dome, distant) are chosen uniformly with probability n / (n + 1) (n of them; the tree the rest).

Split: the lights are cut at the median of their centres along the longest axis of the centres'
box (a balanced tree: depth log2 n).  Each light's path from the root is kept as a bit trail, so
that the probability of a given light at a given point (MIS of BSDF-sampled rays that hit it) is
one walk down that path.

Arrays (the `PathLights` fields `tree_f`, `tree_i`, `trail`, `depth`, `unbounded`):
  tree_f float64 (nodes, tables.LIGHT_TREE): centre, half diagonal length, bounding-sphere radius, phi, w,
         cos and sin theta_o, cos theta_e, two-sided (0/1)
  tree_i int64 (nodes, 2): second child (the first is node + 1) or the light of a leaf; 1 for a leaf
  trail  int64 (lights,): bit d set = the second child at depth d; depth int64 (lights,): the leaf's depth
"""
from __future__ import annotations

import math

import numpy as np

from .. import description as D
from ..kernel.tables import LF_LENGTH, LF_M, LF_RADIUS, LIGHT_TREE
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
    """(indices of the bounded lights, list of (lo, hi, phi, cone, cos_e, two_sided)) of the scene's
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
        bounds.append((lo, hi, float(power[k]), cone, 0.0, False))
    return idx, bounds


def _union(items):
    lo = np.min([b[0] for b in items], 0)
    hi = np.max([b[1] for b in items], 0)
    cone = items[0][3]
    for b in items[1:]:
        cone = cone_union(cone, b[3])
    return lo, hi, sum(b[2] for b in items), cone, min(b[4] for b in items), any(b[5] for b in items)


def build_tree(lights: list[int], bounds: list) -> tuple[np.ndarray, np.ndarray, dict]:
    """(tree_f, tree_i, {light: (trail, depth)}) of a balanced tree over `bounds` (one per light)."""
    rows_f, rows_i, leaves = [], [], {}

    def node(items, trail, depth):
        i = len(rows_f)
        lo, hi, phi, (w, cos_o), cos_e, two = _union([bounds[j] for j in items])
        c = 0.5 * (lo + hi)
        row = np.zeros(LIGHT_TREE.width)
        LIGHT_TREE.write(row, C=c, HALF_DIAG=0.5 * float(np.linalg.norm(hi - lo)), RADIUS=float(np.linalg.norm(hi - c)),
                         PHI=phi, W=w, COS_O=cos_o, SIN_O=math.sqrt(max(0.0, 1.0 - cos_o * cos_o)), COS_E=cos_e,
                         TWO_SIDED=float(two))
        rows_f.append(row)
        rows_i.append([0, 0])
        if len(items) == 1:
            rows_i[i] = [lights[items[0]], 1]
            leaves[lights[items[0]]] = (trail, depth)
            return
        centres = np.array([0.5 * (bounds[j][0] + bounds[j][1]) for j in items])
        axis = int(np.argmax(centres.max(0) - centres.min(0)))
        order = [items[j] for j in np.argsort(centres[:, axis], kind='stable')]
        half = len(order) // 2
        node(order[:half], trail, depth + 1)
        rows_i[i] = [len(rows_f), 0]
        node(order[half:], trail | (1 << depth), depth + 1)

    if lights:
        node(list(range(len(lights))), 0, 0)
    return (np.array(rows_f, np.float64).reshape(-1, LIGHT_TREE.width), np.array(rows_i, np.int64).reshape(-1, 2),
            leaves)


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
    if len(tree_f) == 0:                               # kernels index row 0: an empty, zero-power node
        tree_f, tree_i = np.zeros((1, LIGHT_TREE.width)), np.array([[-1, 1]], np.int64)
    unbounded = [k for k, l in enumerate(desc.lights) if l.type in (D.DOME, D.DISTANT) and power[k] > 0.0]
    return tree_f, tree_i, trail, depth, np.array(unbounded, np.int64), len(idx)
