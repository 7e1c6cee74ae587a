"""Gprims that Hydra draws as polygon meshes of their own points: UsdGeom.TetMesh (its surface faces) and
UsdGeom.NurbsPatch (its control hull).

usdImaging hands Storm a mesh for each, and rtc reads the same mesh, so that usdview and rtc show one shape:

- A TetMesh is drawn as its `surfaceFaceVertexIndices` (usdImaging's TetMesh adapter: triangles, the prim's
  orientation, the catmullClark scheme, so smooth normals where none are authored).  Where they are not authored,
  usdImaging draws nothing; rtc computes them from `tetVertexIndices` (`UsdGeom.TetMesh.ComputeSurfaceFaces`, the
  schema's own function: the faces no two tetrahedra share) and warns.
- A NurbsPatch is drawn as its control hull: a quad for each cell of the `uVertexCount` x `vVertexCount` grid of
  its points (u varying fastest), as usdImaging's NurbsPatch adapter does.  Knots, orders, ranges, weights and trim
  curves are not used (warned).

Both then go through the Mesh reader's own path (`geometry.polygons`): normals, texture coordinates, displayColor
varying over the faces or points, materialBind subsets.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from pxr import UsdGeom

Warn = Callable[[str], None]


def tet_mesh(prim, m: np.ndarray, time, warn: Warn, polygons, error, posed=None) -> list:
    """Mesh records of a TetMesh's surface faces (authored, or computed from its tetrahedra, warned)."""
    tet = UsdGeom.TetMesh(prim)
    path = str(prim.GetPath())
    faces = tet.GetSurfaceFaceVertexIndicesAttr().Get(time)
    faces = np.zeros((0, 3), np.int64) if faces is None else np.asarray(faces, np.int64).reshape(-1, 3)
    if len(faces) == 0:
        tets = tet.GetTetVertexIndicesAttr().Get(time)
        tets = np.zeros((0, 4), np.int64) if tets is None else np.asarray(tets, np.int64).reshape(-1, 4)
        if len(tets) == 0:
            raise error(f'{path}: a TetMesh with neither surfaceFaceVertexIndices nor tetVertexIndices')
        n = len(tet.GetPointsAttr().Get(time) or [])
        if tets.min() < 0 or tets.max() >= n:
            raise error(f'{path}: tetVertexIndices out of range ({n} points)')
        faces = np.asarray(UsdGeom.TetMesh.ComputeSurfaceFaces(tet, time), np.int64).reshape(-1, 3)
        warn(f'{path}: surfaceFaceVertexIndices not authored; the {len(faces)} surface faces of its {len(tets)} '
             'tetrahedra computed (UsdGeom.TetMesh.ComputeSurfaceFaces; usdview draws nothing here)')
        if len(faces) == 0:
            raise error(f'{path}: its tetrahedra have no surface face')
    counts = np.full(len(faces), 3, np.int64)
    return polygons(prim, m, time, warn, (counts, faces.reshape(-1), np.zeros(0, np.int64)), True, posed)


def nurbs_patch(prim, m: np.ndarray, time, warn: Warn, polygons, error, posed=None) -> list:
    """Mesh records of a NurbsPatch's control hull (warned: its surface is not evaluated)."""
    patch = UsdGeom.NurbsPatch(prim)
    path = str(prim.GetPath())
    nu, nv = patch.GetUVertexCountAttr().Get(time), patch.GetVVertexCountAttr().Get(time)
    if nu is None or nv is None or nu < 2 or nv < 2:
        raise error(f'{path}: uVertexCount {nu} and vVertexCount {nv} make no control hull (2 or more each)')
    n = len(patch.GetPointsAttr().Get(time) or [])
    if n != nu * nv:
        raise error(f'{path}: {n} points for a {nu} x {nv} control grid')
    warn(f'{path}: NurbsPatch drawn as its control hull ({nu} x {nv} points), as usdImaging draws it; its knots, '
         'weights and trim curves are not used')
    idx = (np.arange(nv - 1)[:, None] * nu + np.arange(nu - 1)[None, :]).reshape(-1)
    quads = np.stack([idx, idx + 1, idx + nu + 1, idx + nu], axis=1)
    counts = np.full(len(quads), 4, np.int64)
    return polygons(prim, m, time, warn, (counts, quads.reshape(-1), np.zeros(0, np.int64)), True, posed)
