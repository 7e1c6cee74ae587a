"""A primvar's values: flattened through its indices (`flattened`, which warns where it cannot), and expanded to
the corners of a mesh's triangles by its interpolation (`per_corner`)."""
from __future__ import annotations

from typing import Callable

import numpy as np
from pxr import Tf, UsdGeom

Warn = Callable[[str], None]


def per_corner(values, interpolation: str, face: np.ndarray, corner: np.ndarray,
               vertex_of_corner: np.ndarray, n_points: int, n_faces: int) -> np.ndarray | None:
    """Expand a (flattened) primvar to per-triangle-corner values (m, 3, k); None if its length
    does not match its interpolation."""
    v = np.asarray(values, np.float64)
    if v.ndim == 1:
        v = v[:, None]
    n = len(v)
    if interpolation == UsdGeom.Tokens.constant and n >= 1:
        return np.broadcast_to(v[0], (len(face), 3, v.shape[1])).copy()
    if interpolation == UsdGeom.Tokens.uniform and n == n_faces:
        return np.repeat(v[face][:, None, :], 3, axis=1)
    if interpolation in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying) and n >= n_points:
        return v[vertex_of_corner[corner]]
    if interpolation == UsdGeom.Tokens.faceVarying and n == len(vertex_of_corner):
        return v[corner]
    return None


def flattened(pv: UsdGeom.Primvar, time, warn: Warn, consequence: str):
    """A primvar's values expanded through its indices, or None with one warning naming the prim
    and the attribute and saying in words what is wrong (an index past the values, an element
    size other than one, values that are not an array): the attribute is lost, not the prim."""
    where = f'{pv.GetAttr().GetPrim().GetPath()}: {pv.GetAttr().GetName()}'
    size = pv.GetElementSize()
    try:
        values = pv.ComputeFlattened(time)
    except Tf.ErrorException:
        values = None
    if values is None or not hasattr(values, '__len__') or isinstance(values, str):    # (authored as a string)
        raw = pv.Get(time)
        count = len(raw) if hasattr(raw, '__len__') else 0
        if pv.IsIndexed():
            indices = np.asarray(pv.GetIndices(time), np.int64)
            top = int(indices.max()) if len(indices) else -1
            noun = 'value' if count == 1 else 'values'
            why = (f'its indices reach {top} but it has {count} {noun}' if size == 1 else
                   f'its {len(indices)} indices of elements of {size} values do not fit its {count} {noun}')
        else:
            why = 'it has no readable array of values'
        warn(f'{where} cannot be used ({why}); {consequence}')
        return None
    if size != 1:
        warn(f'{where} has element size {size} (one value per element expected); {consequence}')
        return None
    return values
