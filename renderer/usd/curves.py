"""UsdGeom.BasisCurves (and NurbsCurves, as their control cage) -> a `Curves` record: round tubes of the curve's
width, as ray tracers draw curves (Embree's round curves, as Cycles' hair; their surfaces: `kernel/curves.py`).

* ``type`` linear: chains of cones with round joints (Embree's round linear curves).  ``type`` cubic (the
  fallback), every ``basis`` (bezier, the fallback; bspline; catmullRom): cubic Bezier segments, each
  segment's four control points converted from its basis exactly (a change of basis of the same cubic).
* ``wrap``: nonperiodic (the fallback); periodic (the curve closes: its last segments take their control points
  from its start); pinned (bspline and catmullRom pass through their end points, by a phantom point at each
  end, 2 P0 - P1, as the schema defines it; a pinned bezier or linear curve is nonperiodic).
* ``widths`` are diameters (the radius is half): constant, uniform (a curve), varying (a segment's ends) or
  vertex (a control point); unauthored, 1 (as Hydra draws them); 0 where a curve tapers to a point.  A width
  that fits no interpolation is warned about and the first one used; the gprim's transform scales the radius by
  its mean scale, |det|^(1/3).
* ``primvars:displayColor`` that varies over the curves (uniform, varying, vertex) is kept at each segment's
  two ends (`Curves.colors`) and interpolated along it by the kernel (`shapes.corner_color`), as the mesh's
  colours are; constant: the material fallback's colour.  ``primvars:displayOpacity`` likewise (the fourth
  channel of `Curves.colors`, `shapes.corner_opacity`), clamped to [0, 1]: strands that fade towards their tips.
* Authored ``normals`` (ribbons facing them, in Storm) are warned about: the curves are drawn round.
* UsdGeom.NurbsCurves: their control cage, linear curves through their control points, as usdImaging draws them
  (its NurbsCurves adapter gives Storm a linear BasisCurves topology of the same points), warned.

A curve whose vertex count does not fit its type, basis and wrap (a cubic bezier of 5 vertices, a curve of
one) is left out and warned about, with the others kept; points that are not finite make the whole gprim
unusable (`GeometryError`).
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from pxr import UsdGeom

from ..description import Curves

Warn = Callable[[str], None]

# a segment's Bezier control points from its basis' four control points (rows: Bezier points)
TO_BEZIER = {
    'bezier': np.eye(4),
    'bspline': np.array([[1.0, 4.0, 1.0, 0.0], [0.0, 4.0, 2.0, 0.0], [0.0, 2.0, 4.0, 0.0], [0.0, 1.0, 4.0, 1.0]]) / 6,
    'catmullRom': np.array([[0.0, 6.0, 0.0, 0.0], [-1.0, 6.0, 1.0, 0.0], [0.0, 1.0, 6.0, -1.0], [0.0, 0.0, 6.0, 0.0]])
    / 6,
}
NEIGHBOR_LEFT, NEIGHBOR_RIGHT = 1, 2         # Embree's RTC_CURVE_FLAG_NEIGHBOR_LEFT / _RIGHT


def segment_counts(counts: np.ndarray, linear: bool, basis: str, wrap: str) -> np.ndarray:
    """Segments of each curve of `counts` vertices (0 where the count does not fit), as UsdGeomBasisCurves
    counts them."""
    counts = np.asarray(counts, np.int64)
    if linear:
        return np.where(counts >= 2, counts - (wrap != 'periodic'), 0)
    if basis == 'bezier':
        if wrap == 'periodic':
            return np.where((counts >= 3) & (counts % 3 == 0), counts // 3, 0)
        return np.where((counts >= 4) & ((counts - 4) % 3 == 0), (counts - 4) // 3 + 1, 0)
    if wrap == 'periodic':
        return np.where(counts >= 3, counts, 0)
    if wrap == 'pinned':
        return np.where(counts >= 2, counts - 1, 0)
    return np.where(counts >= 4, counts - 3, 0)


def _pinned(values: np.ndarray, counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-vertex values with a phantom vertex 2 v0 - v1 before each curve and 2 v[n-1] - v[n-2] after it;
    -> (values, counts + 2)."""
    off = np.concatenate([[0], np.cumsum(counts)[:-1]])
    last = off + counts - 1
    where = np.column_stack([off, last + 1]).ravel()             # a curve's end before the next one's start
    phantom = np.stack([2.0 * values[off] - values[off + 1], 2.0 * values[last] - values[last - 1]], axis=1)
    out = np.insert(values, where, phantom.reshape(-1, *values.shape[1:]), axis=0)
    return out, counts + 2


def _control_index(counts: np.ndarray, nseg: np.ndarray, step: int, width: int, periodic: bool) -> np.ndarray:
    """int64 (k, width): the vertices of each segment (curve after curve), wrapped within periodic curves."""
    off = np.concatenate([[0], np.cumsum(counts)[:-1]])
    curve = np.repeat(np.arange(len(counts)), nseg)
    first = np.arange(int(nseg.sum())) - np.repeat(np.cumsum(nseg) - nseg, nseg)
    local = first[:, None] * step + np.arange(width)
    if periodic:
        local = local % counts[curve][:, None]
    return off[curve][:, None] + local


WIDTHS = {'colour': 3, 'opacity': 1, 'normal': 3}      # the columns of each value kept along the curves


def _per_vertex(values, interpolation: str, counts: np.ndarray, ends: int, what: str, warn: Warn):
    """A primvar (widths: (n,), colours: (n, 3)) per vertex -> (values per vertex, or None; values per segment
    end (varying), or None).  None, None: unusable (warned)."""
    n, v = int(counts.sum()), np.asarray(values, np.float64)
    if interpolation == UsdGeom.Tokens.constant or len(v) == 1:
        return np.repeat(v[:1], n, axis=0), None
    if interpolation == UsdGeom.Tokens.uniform and len(v) == len(counts):
        return np.repeat(v, counts, axis=0), None
    if interpolation == UsdGeom.Tokens.vertex and len(v) == n:
        return v, None
    if interpolation == UsdGeom.Tokens.varying and len(v) == ends:
        return None, v
    if len(v) == n:                                  # a count that only vertex interpolation fits
        return v, None
    curves = f'{len(counts)} curve' + ('s' if len(counts) != 1 else '')
    warn(f'{what}: {len(v)} values for {curves} of {n} vertices ({ends} segment ends) do not fit interpolation '
         f'{interpolation}')
    return None, None


def basis_curves(prim, m: np.ndarray, time, warn: Warn, error, display_color, posed=None,
                 display_opacity=None) -> list[Curves]:
    """The `Curves` record of one BasisCurves prim (gprim-to-container matrix m).  `error`: the exception
    class to raise where the gprim cannot be used; `display_color(prim, time)`: (values, interpolation) of a
    displayColor that varies over it, or None (`geometry.varying_display_color`); `display_opacity`: the same of
    its displayOpacity (`geometry.varying_display_opacity`)."""
    curves = UsdGeom.BasisCurves(prim)
    kind = curves.GetTypeAttr().Get(time) or 'cubic'
    basis = curves.GetBasisAttr().Get(time) or 'bezier'
    wrap = curves.GetWrapAttr().Get(time) or 'nonperiodic'
    if kind not in ('linear', 'cubic') or wrap not in ('nonperiodic', 'periodic', 'pinned') or \
            (kind == 'cubic' and basis not in TO_BEZIER):
        raise error(f'{prim.GetPath()}: curves of type {kind!r}, basis {basis!r}, wrap {wrap!r} are not drawn')
    return _curves(curves, (kind, basis, wrap), m, time, warn, error, (display_color, display_opacity), posed)


def nurbs_curves(prim, m: np.ndarray, time, warn: Warn, error, display_color, posed=None,
                 display_opacity=None) -> list[Curves]:
    """The `Curves` record of one NurbsCurves prim: its control cage, linear segments through its control points,
    with its widths and colours, as usdImaging draws NurbsCurves (`UsdImagingNurbsCurvesAdapter`: a linear,
    nonperiodic BasisCurves topology of the same points; knots, order, weights and ranges unused), warned."""
    warn(f'{prim.GetPath()}: NurbsCurves drawn as their control cage (linear segments through the control points), '
         'as usdImaging draws them')
    cage = ('linear', 'bezier', 'nonperiodic')
    return _curves(UsdGeom.NurbsCurves(prim), cage, m, time, warn, error, (display_color, display_opacity), posed)


def _curves(curves, shape, m, time, warn: Warn, error, display, posed=None) -> list[Curves]:
    """The record of a UsdGeom.Curves prim read as curves of `shape` = (type, basis, wrap); `display`: the
    callbacks giving its displayColor and its displayOpacity where they vary over it (`basis_curves`); `posed`: its
    points posed by a skeleton (`skinning.py`) in place of its own."""
    kind, basis, wrap = shape
    path = str(curves.GetPath())
    linear = kind == 'linear'
    p = curves.GetPointsAttr().Get(time) if posed is None else posed
    p = np.zeros((0, 3)) if p is None else np.asarray(p, np.float64).reshape(-1, 3)
    counts = np.asarray(curves.GetCurveVertexCountsAttr().Get(time) or [], np.int64)
    if int(counts.sum()) != len(p) or np.any(counts < 0):
        raise error(f'{path}: curveVertexCounts sum to {int(counts.sum())} but there are {len(p)} points')
    if not np.all(np.isfinite(p)):
        raise error(f'{path}: points that are not finite')
    nseg = segment_counts(counts, linear, basis, wrap)
    if np.any(nseg == 0):
        warn(f'{path}: {int(np.sum(nseg == 0))} of {len(counts)} curves have a vertex count that does not fit '
             f'{kind} {"" if linear else basis + " "}{wrap} curves; left out')
    if not nseg.any():
        raise error(f'{path}: no curve to draw')
    ends = int(np.sum(np.where(nseg > 0, nseg + (wrap != 'periodic'), 0)))
    w = curves.GetWidthsAttr().Get(time)
    w = np.ones(1) if w is None or len(w) == 0 else np.asarray(w, np.float64).reshape(-1)
    w_vertex, w_ends = _per_vertex(w, curves.GetWidthsInterpolation(), counts, ends, f'{path}: widths', warn)
    if w_vertex is None and w_ends is None:
        w_vertex = np.full(len(p), w[0])
    kept = {}
    for name, primvar, read in (('colour', 'displayColor', display[0]), ('opacity', 'displayOpacity', display[1])):
        found = read(curves.GetPrim(), time) if read is not None else None
        if found is not None:
            v_vertex, v_ends = _per_vertex(found[0], found[1], counts, ends, f'{path}: primvars:{primvar}', warn)
            if v_vertex is None and v_ends is None:
                v_vertex = np.repeat(np.asarray(found[0].mean(0)).reshape(1, -1), len(p), axis=0)
            kept[name] = (v_vertex, v_ends)
    scale = float(abs(np.linalg.det(m[:3, :3])) ** (1.0 / 3.0))
    g = m[:3, :3].T @ m[:3, :3]
    if not np.allclose(g, np.trace(g) / 3.0 * np.eye(3), rtol=1e-6, atol=1e-12 * abs(np.trace(g))):
        warn(f'{path}: a non-uniform scale; the curves stay round, their widths scaled by its mean scale')
    columns = [p @ m[:3, :3].T + m[:3, 3]]
    columns += [0.5 * scale * (w_vertex if w_vertex is not None else np.zeros(len(p)))[:, None]]
    varying = {3: 0.5 * scale * w_ends if w_ends is not None else None}
    for name, (v_vertex, v_ends) in kept.items():             # colours, opacities: kept at segment ends
        columns.append(v_vertex.reshape(len(p), -1) if v_vertex is not None else np.zeros((len(p), WIDTHS[name])))
        varying[name] = v_ends
    n_vertex, n_ends = _normals(curves, counts, ends, time, warn)
    if n_vertex is not None or n_ends is not None:           # ribbons: normals as normals go, by m's cofactors
        cof = np.linalg.inv(m[:3, :3]).T
        columns.append(n_vertex @ cof.T if n_vertex is not None else np.zeros((len(p), 3)))
        varying['normal'] = n_ends @ cof.T if n_ends is not None else None
    shape = (linear, basis, wrap, 'normal' in varying)
    return [_segments(path, np.column_stack(columns), counts, nseg, shape, varying, warn, error)]


def _normals(curves, counts, ends: int, time, warn: Warn):
    """A BasisCurves' authored `normals` (ribbons facing them) -> (per vertex, or None; per segment end, or None);
    (None, None) without normals, or with normals that fit no interpolation (warned: drawn as tubes)."""
    if not isinstance(curves, UsdGeom.BasisCurves) or not curves.GetNormalsAttr().HasAuthoredValue():
        return None, None
    n = curves.GetNormalsAttr().Get(time)
    n = np.zeros((0, 3)) if n is None else np.asarray(n, np.float64).reshape(-1, 3)
    where = f'{curves.GetPath()}: normals'
    if not len(n) or not np.all(np.isfinite(n)):
        warn(f'{where} are empty or not finite; the curves are drawn as round tubes')
        return None, None
    n_vertex, n_ends = _per_vertex(n, curves.GetNormalsInterpolation(), counts, ends, where, warn)
    if n_vertex is None and n_ends is None:
        warn(f'{where}: the curves are drawn as round tubes')
    return n_vertex, n_ends


def _segments(path, values, counts, nseg, shape, varying: dict, warn, error) -> Curves:
    """The record from per-vertex values (n, 4 [+ 3 colours] [+ 3 normals]: columns 0-2 the point, 3 the radius,
    then those `varying` names, in that order) of the curves `counts` (nseg segments each; 0: left out) of
    `shape` = (linear, basis, wrap, ribbons); `varying`: {3 (radius) | 'colour' | 'normal': values at each
    segment end (in curve order, the kept curves' alone), or None where the per-vertex columns hold them}.
    Ribbons (normals) are cubic: a linear curve's segments become straight Bezier segments."""
    linear, basis, wrap, ribbons = shape
    keep = np.repeat(nseg > 0, counts)
    values, counts, nseg = values[keep], counts[nseg > 0], nseg[nseg > 0]
    if wrap == 'pinned' and not linear and basis != 'bezier':
        values, counts = _pinned(values, counts)
    periodic = wrap == 'periodic'
    end_first = np.cumsum(nseg + (not periodic)) - (nseg + (not periodic))       # each curve's first segment end
    seg_end = np.repeat(end_first, nseg) + np.arange(int(nseg.sum())) - np.repeat(np.cumsum(nseg) - nseg, nseg)
    seg_last = np.repeat(np.cumsum(nseg) - 1, nseg)
    after = np.where(np.arange(len(seg_end)) == seg_last, np.repeat(end_first, nseg), seg_end + 1) \
        if periodic else seg_end + 1
    thirds = np.arange(4) / 3.0
    if linear and not ribbons:
        index = _control_index(counts, nseg, 1, 2, periodic)
        vertices = np.concatenate([values[index[:, 0]], values[index[:, 1]]], axis=1).reshape(-1, values.shape[1])
        first = np.arange(int(nseg.sum())) - np.repeat(np.cumsum(nseg) - nseg, nseg)
        # shared vertices: a curve's segments are consecutive, so each segment's end is the next one's start
        vertices, starts, flags = _chain(vertices, 2 * np.arange(len(index)), first, nseg)
        rows, t = np.column_stack([starts, starts + 1]), np.array([0.0, 1.0])
    else:
        if linear:                                      # (a straight Bezier: its points at thirds)
            two = values[_control_index(counts, nseg, 1, 2, periodic)]
            bez = (1.0 - thirds)[None, :, None] * two[:, :1] + thirds[None, :, None] * two[:, 1:]
        else:
            index = _control_index(counts, nseg, 3 if basis == 'bezier' else 1, 4, periodic)
            bez = np.einsum('ij,kjc->kic', TO_BEZIER[basis], values[index])       # (k, 4, columns)
        vertices, starts, flags = bez.reshape(-1, values.shape[1]), 4 * np.arange(len(bez)), None
        rows, t = starts[:, None] + np.arange(4), thirds
    cols, nxt = {3: [3]}, 4
    for name in varying:
        if name != 3:
            cols[name], nxt = list(range(nxt, nxt + WIDTHS[name])), nxt + WIDTHS[name]
    for name, ends in varying.items():
        if ends is not None:                            # values at segment ends: along the segment, linearly
            a, b = ends[seg_end], ends[after]
            for k, c in enumerate(cols[name]):
                vertices[rows, c] = (1.0 - t) * (a if a.ndim == 1 else a[:, k])[:, None] \
                    + t * (b if b.ndim == 1 else b[:, k])[:, None]
    return _record(path, vertices, starts, flags, cols, (linear and not ribbons, ribbons), warn, error)


def _record(path, vertices, starts, flags, cols, kind, warn, error) -> Curves:
    """The `Curves` record of the control points `vertices` (columns `cols`) of segments `starts`; kind =
    (linear, ribbons)."""
    linear, ribbons = kind
    last = starts + (1 if linear else 3)
    colors = None
    if 'colour' in cols or 'opacity' in cols:            # (k, 2, 3), or (k, 2, 4) with an opacity
        at_ends = {name: np.stack([vertices[starts][:, c], vertices[last][:, c]], axis=1)
                   for name, c in cols.items() if name in ('colour', 'opacity')}
        colors = np.maximum(at_ends['colour'], 0.0) if 'colour' in at_ends else np.ones((len(starts), 2, 3))
        if 'opacity' in at_ends:
            colors = np.concatenate([colors, np.clip(at_ends['opacity'], 0.0, 1.0)], axis=2)
        colors = np.ascontiguousarray(colors, np.float32)
    normals = None
    if ribbons:
        normals = vertices[:, cols['normal']]
        length = np.linalg.norm(normals, axis=1)
        normals = normals / np.where(length > 0.0, length, 1.0)[:, None]
    radius = vertices[:, 3]
    bad = ~(np.isfinite(radius) & (radius >= 0.0))      # (0: a curve tapering to a point, as hair tips do)
    if bad.any():
        warn(f'{path}: {int(bad.sum())} control points with a width that is negative or not finite; drawn with '
             'width 0')
        vertices[bad, 3] = 0.0
    if not np.any(vertices[:, 3] > 0.0):
        raise error(f'{path}: no width is positive')
    return Curves(path=path, vertices=np.ascontiguousarray(vertices[:, :4]), segments=starts.astype(np.int64),
                  linear=linear, flags=flags, colors=colors,
                  normals=None if normals is None else np.ascontiguousarray(normals))


def _chain(vertices, starts, first, nseg):
    """Linear segments (two vertices each, in curve order) -> shared vertices: each curve's vertices once, a
    segment starting at its first; flags: the segments before and after it in the same curve join it."""
    n_curves = len(nseg)
    curve_of = np.repeat(np.arange(n_curves), nseg)
    last = first == nseg[curve_of] - 1
    keep = np.ones(len(vertices), bool)
    keep[starts[~last] + 1] = False                  # a segment's end, but for a curve's last segment
    new_index = np.cumsum(keep) - 1
    flags = np.where(first > 0, NEIGHBOR_LEFT, 0) | np.where(~last, NEIGHBOR_RIGHT, 0)
    return vertices[keep].copy(), new_index[starts], flags.astype(np.uint8)
