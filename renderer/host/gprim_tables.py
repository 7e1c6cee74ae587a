"""The gprim tables the kernels shade with, a row a gprim slot (`SceneData.gp_*`), filled container by container
as `build` converts them, and the per-primitive tables those rows point into: triangles' corners (`tri_v`,
`tri_n`, `tri_uv`, `tri_c`), spheres (`sph`) and curve segments (`crv`).

* A mesh: its triangles' vertices in object space, and per-corner normals, texture coordinates and colours
  where it has them (`gp_n_off`, `gp_uv_off`, `gp_c_off`: its first row of each, -1 without); a corner's colour is
  RGBA (`rgba`): its displayColor and its displayOpacity, 1 where only the other varies.
* A sphere or a point cloud: a row (centre, radius) a sphere (`gp_off`: the first), a cloud's colour a point.
* Curves: a row of four control points (x, y, z, radius; a linear segment's two ends, then its end again) a
  segment, the same float32 numbers Embree intersects (`gp_off`: the first; flag GP_LINEAR for linear
  segments); where their displayColor varies, a colour at each segment end (corners 0 and 1 of a `tri_c` row);
  ribbons (flag GP_RIBBON), the four control points' normals a segment (`crv_n`, from `gp_n_off`).
"""
from __future__ import annotations

import numpy as np

from .. import description as D
from ..kernel.tables import (GP_CLOUD, GP_CURVES, GP_HAS_COLORS, GP_HAS_NORMALS, GP_HAS_UVS, GP_LINEAR, GP_MESH,
                             GP_RIBBON, GP_SPHERE)


def rgba(colors: np.ndarray | None) -> np.ndarray | None:
    """Colours (..., 3) or (..., 4) as float32 RGBA (the `tri_c` table's rows): an opacity of 1 where none is given."""
    if colors is None:
        return None
    c = np.asarray(colors, np.float32)
    return c if c.shape[-1] == 4 else np.concatenate([c, np.ones(c.shape[:-1] + (1,), np.float32)], axis=-1)


class GprimTables:
    """Accumulates per-gprim rows while containers are converted."""

    def __init__(self):
        self.kind, self.off, self.flags, self.material, self.n_off, self.uv_off = [], [], [], [], [], []
        self.c_off, self.tri_c = [], []
        self.tri_v, self.tri_n, self.tri_uv, self.sph, self.crv, self.crv_n = [], [], [], [], [], []
        self.n_crv_n = 0
        self.n_tri = self.n_crv = 0
        self._rows = {}                    # per-corner table -> rows so far

    def add_mesh(self, v32: np.ndarray, tris: np.ndarray, m: D.Mesh) -> None:
        flags = 0
        self.kind.append(GP_MESH)
        self.off.append(self.n_tri)
        self.material.append(m.material)
        self.tri_v.append(v32[tris])
        for values, flag, offsets, table in ((m.normals, GP_HAS_NORMALS, self.n_off, self.tri_n),
                                             (m.uvs, GP_HAS_UVS, self.uv_off, self.tri_uv),
                                             (rgba(m.colors), GP_HAS_COLORS, self.c_off, self.tri_c)):
            if values is None:                 # per-corner values: a row a triangle, from the gprim's offset
                offsets.append(-1)
                continue
            flags |= flag
            offsets.append(self._rows.get(id(table), 0))
            table.append(np.asarray(values, np.float32))
            self._rows[id(table)] = offsets[-1] + len(tris)
        self.flags.append(flags)
        self.n_tri += len(tris)

    def add_sphere(self, center_radius: np.ndarray | None, material: int, colors=None) -> None:
        """A sphere slot: `center_radius` (n, 4), a row per sphere of the gprim (a point cloud's: its
        primitives, `shapes.surface` reads row gp_off + primID); None for a sphere moved to the unit-sphere
        container.  `colors` (n, 3) or (n, 4): a cloud's colour a point (rows of the per-corner table, its three corners
        alike: `shapes.corner_color` reads row c_off + primID)."""
        self.kind.append(GP_SPHERE)
        self.material.append(material)
        cloud = center_radius is not None and len(center_radius) > 1
        coloured = center_radius is not None and colors is not None      # (a cloud of one point left: its row)
        self.flags.append(GP_HAS_UVS | (GP_CLOUD if cloud else 0) | (GP_HAS_COLORS if coloured else 0))
        self.n_off.append(-1)
        self.uv_off.append(-1)
        if coloured:
            self.c_off.append(self._rows.get(id(self.tri_c), 0))
            self.tri_c.append(np.repeat(rgba(colors)[:, None, :], 3, axis=1))
            self._rows[id(self.tri_c)] = self.c_off[-1] + len(colors)
        else:
            self.c_off.append(-1)
        if center_radius is None:
            self.off.append(-1)
        else:
            self.off.append(len(self.sph))
            self.sph.extend(center_radius)

    def add_curves(self, geometry, c: D.Curves) -> None:
        """A curves slot of `geometry` (an `embree.CurveGeometry`): its segments' control points as Embree has them;
        a ribbon's normals a control point (`crv_n`, from `n_off`; flag GP_RIBBON)."""
        rows = geometry.segment_rows()
        self.kind.append(GP_CURVES)
        self.material.append(c.material)
        self.uv_off.append(-1)
        flags = GP_LINEAR if c.linear else 0
        if geometry.normals is None:
            self.n_off.append(-1)
        else:
            flags |= GP_RIBBON
            self.n_off.append(self.n_crv_n)
            self.crv_n.append(D.segment_rows(geometry.normals, geometry.segments, False))
            self.n_crv_n += len(rows)
        if c.colors is not None:
            flags |= GP_HAS_COLORS
            self.c_off.append(self._rows.get(id(self.tri_c), 0))
            self.tri_c.append(rgba(np.concatenate([c.colors, c.colors[:, 1:]], axis=1)))
            self._rows[id(self.tri_c)] = self.c_off[-1] + len(rows)
        else:
            self.c_off.append(-1)
        self.flags.append(flags)
        self.off.append(self.n_crv)
        self.crv.append(rows)
        self.n_crv += len(rows)
