"""Image tiles: the unit of work of a render pass.

A pass covers the image - or a window of it, `PassParams.window` = (x0, y0, x1, y1) with x0, y0 multiples
of TILE and x1, y1 multiples of TILE or the image's edges (a shot's tile task) - with TILE x TILE pixel
tiles, numbered as in the whole image; every render thread runs the integrator's entry
point, which claims tiles one at a time from the pass's shared counter (`next_tile`: an atomic
fetch-and-add, so threads share the tiles dynamically, whatever else the machine is doing) in a
scattered order (neighbouring tiles, which cost about the same, go to different claims).  A tile's
pixels, counters and ray-record row belong to it alone: which thread renders it changes nothing.
"""
import numba as nb
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from .jit import INLINE_JIT
from .records import Tile

TILE = 8
_STRIDE = 7919                 # a prime: tile i of the claim order is tile (i * 7919) mod n


@nb.njit(**INLINE_JIT)
def n_tiles(width, height):
    """Tiles of TILE x TILE pixels covering a width x height image (one counter row, one ray record
    row each)."""
    return ((width + TILE - 1) // TILE) * ((height + TILE - 1) // TILE)


@intrinsic
def _fetch_add(typingctx, counter, value):
    """Atomically add `value` to counter[0] (int64 array) and return the value before."""
    sig = types.int64(counter, types.int64)

    def codegen(context, builder, signature, args):
        aryty = signature.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, aryty, ary, [context.get_constant(types.intp, 0)])
        return builder.atomic_rmw('add', ptr, args[1], 'monotonic')
    return sig, codegen


@nb.njit(**INLINE_JIT)
def next_tile(work, ntiles):
    """The next unclaimed tile of the pass whose counter is `work` (int64 [1], 0 at the start of the
    pass), or -1 when every tile is claimed."""
    i = _fetch_add(work, 1)
    if i >= ntiles:
        return -1
    stride = _STRIDE if ntiles % _STRIDE != 0 else 1
    return (i * stride) % ntiles


@nb.njit(**INLINE_JIT)
def claim_tile(pp, work):
    """The next unclaimed `Tile` of the pass's window (its index in the whole image's numbering, its
    pixels), or a Tile of index -1 when every tile is claimed."""
    x0, y0, x1, y1 = pp.window
    ntx = (pp.width + TILE - 1) // TILE
    wtx = (x1 - x0 + TILE - 1) // TILE
    i = next_tile(work, wtx * ((y1 - y0 + TILE - 1) // TILE))
    if i < 0:
        return Tile(-1, 0, 0, 0, 0)
    tx = x0 // TILE + i % wtx
    ty = y0 // TILE + i // wtx
    return Tile(ty * ntx + tx, tx * TILE, ty * TILE, min(tx * TILE + TILE, x1), min(ty * TILE + TILE, y1))
