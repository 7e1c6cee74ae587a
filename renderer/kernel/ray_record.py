"""The ray recorder: every ray a render traces, for benchmarks/bench_render.py, which replays the
renderer's own rays on bare Embree to separate Embree's time from the shading's.

`Renderer.run_pass(..., ray_record=rec)` (the kernels' `Scratch.rec`, both integrators) with
`rec = new_ray_record(n_tiles, cap)` records; with `rec=None` (every
render) numba compiles a specialisation in which each `if rec is not None:` branch is pruned before
type inference, so rendering pays nothing for the feature (measured: benchmarks/RESULTS.md).
"""
from collections import namedtuple

import numba as nb
import numpy as np
from numba import types
from numba.extending import overload

from .jit import INLINE_JIT

# ray fields (float32 columns of RayRecord.rays)
R_OX, R_OY, R_OZ, R_DX, R_DY, R_DZ, R_TNEAR, R_TFAR, R_TIME = range(9)
R_FIELDS = 9

RayRecord = namedtuple('RayRecord', ['rays', 'kind', 'count'])


def new_ray_record(n_tiles, rays_per_tile):
    """Room for `rays_per_tile` rays of each tile: rays float32 (n_tiles, cap, R_FIELDS), kind int8
    (n_tiles, cap) (the integrator's RAYS_* counter of the ray), count int64 (n_tiles,) = rays traced,
    including those beyond the capacity."""
    return RayRecord(np.zeros((n_tiles, rays_per_tile, R_FIELDS), np.float32),
                     np.full((n_tiles, rays_per_tile), -1, np.int8), np.zeros(n_tiles, np.int64))


@nb.njit(**INLINE_JIT)
def record(rec, tile, kind, o, d, tnear, tfar, time):
    """Append the ray (o, d, [tnear, tfar], time) of kind `kind` to tile `tile`'s record."""
    n = rec.count[tile]
    if n < rec.rays.shape[1]:
        r = rec.rays
        r[tile, n, R_OX] = o[0]
        r[tile, n, R_OY] = o[1]
        r[tile, n, R_OZ] = o[2]
        r[tile, n, R_DX] = d[0]
        r[tile, n, R_DY] = d[1]
        r[tile, n, R_DZ] = d[2]
        r[tile, n, R_TNEAR] = tnear
        r[tile, n, R_TFAR] = tfar
        r[tile, n, R_TIME] = time
        rec.kind[tile, n] = kind
    rec.count[tile] = n + 1


def record_if(rec, tile, kind, o, d, tnear, tfar, time):
    """`record` when `rec` is a RayRecord; nothing at all (no code, no test) when it is None: for kernels
    that carry the record in a record (`Tracer.rec`), where numba cannot prune `if tr.rec is not None`."""


@overload(record_if, jit_options=dict(cache=True, nogil=True, _nrt=False))
def _record_if(rec, tile, kind, o, d, tnear, tfar, time):
    if isinstance(rec, types.NoneType):
        return lambda rec, tile, kind, o, d, tnear, tfar, time: None
    return lambda rec, tile, kind, o, d, tnear, tfar, time: record(rec, tile, kind, o, d, tnear, tfar, time)
