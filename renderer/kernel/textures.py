"""Image texture lookups for the kernels.

Images are decoded once by the stage reader (OpenImageIO) into linear float32 and packed into one
flat array (`SceneData.tex_data`, offsets in `tex_i`); an 8-bit image keeps its bytes (`tex_bytes`), read through
the table of what each byte decodes to (`tex_lut`, `images.byte_lut`): the same values in a quarter of the memory.
Lookups are bilinear with the UsdUVTexture wrap modes; `st` follows USD: s to the right, t **up** (row 0 of the
file is the top, t = 1).
Lat-long maps follow the OpenEXR / UsdLux DomeLight convention: +Y is the top row, longitude 0 is +Z,
longitude +pi/2 is +X, and longitude decreases to the right.
"""
import math

import numba as nb

from .features import F_UDIM
from .jit import INLINE_JIT, SHADING_JIT
from .tables import (TF_BIAS, TF_SCALE, TF_XF, TI_BYTES, TI_CHANNELS, TI_HEIGHT, TI_OFFSET, TI_UDIM, TI_UDIM_ROWS,
                     TI_WIDTH, TI_WRAP_S, TI_WRAP_T, WRAP_CLAMP as CLAMP, WRAP_MIRROR as MIRROR,
                     WRAP_REPEAT as REPEAT)


@nb.njit(**INLINE_JIT)
def _wrap(i, n, mode):
    """-> (index, inside) for integer texel coordinate i."""
    if 0 <= i < n:
        return i, True
    if mode == REPEAT:
        return i % n, True
    if mode == MIRROR:
        p = i % (2 * n)
        return (p if p < n else 2 * n - 1 - p), True
    if mode == CLAMP:
        return (0 if i < 0 else n - 1), True
    return 0, False


@nb.njit(**INLINE_JIT)
def _texel(S, tid, x, y, c):
    off = S.tex_i[tid, TI_OFFSET]
    w = S.tex_i[tid, TI_WIDTH]
    h = S.tex_i[tid, TI_HEIGHT]
    ch = S.tex_i[tid, TI_CHANNELS]
    xi, okx = _wrap(x, w, S.tex_i[tid, TI_WRAP_S])
    yi, oky = _wrap(y, h, S.tex_i[tid, TI_WRAP_T])
    if not (okx and oky):
        return 0.0
    srgb = S.tex_i[tid, TI_BYTES]
    if srgb >= 0:                                    # an 8-bit image: its byte's value (`images.byte_lut`)
        return S.tex_lut[1 if c < srgb else 0, S.tex_bytes[off + (yi * w + xi) * ch + c]]
    return S.tex_data[off + (yi * w + xi) * ch + c]


@nb.njit(**INLINE_JIT)
def _source_channel(c, ch):
    """The channel of a texel of `ch` channels that a UsdUVTexture's output channel c (0-3: r, g, b, a) reads,
    or -1 for 1: one channel is grey (r = g = b), two are grey and alpha, three have no alpha (a = 1)."""
    if c == 3:
        return 3 if ch >= 4 else (1 if ch == 2 else -1)
    return c if ch >= 3 else 0


@nb.njit(**INLINE_JIT)
def _footprint(S, tid, s, t):
    """(ix, iy, fx, fy): the texel whose centre is below and left of texture coordinates (s, t), mapped by the
    texture's transform (TF_XF: a UsdTransform2d's), (t up: row 0 of the image is its top) and the bilinear
    weights of the texel after it."""
    f = S.tex_f
    s, t = (f[tid, TF_XF] * s + f[tid, TF_XF + 1] * t + f[tid, TF_XF + 2],
            f[tid, TF_XF + 3] * s + f[tid, TF_XF + 4] * t + f[tid, TF_XF + 5])
    x = s * S.tex_i[tid, TI_WIDTH] - 0.5
    y = (1.0 - t) * S.tex_i[tid, TI_HEIGHT] - 0.5
    x0 = math.floor(x)
    y0 = math.floor(y)
    return int(x0), int(y0), x - x0, y - y0


@nb.njit(**INLINE_JIT)
def _bilinear(S, tid, at, src):
    """Channel src of the texels around footprint `at` (`_footprint`), weighted bilinearly."""
    ix, iy, fx, fy = at
    return ((1 - fx) * (1 - fy) * _texel(S, tid, ix, iy, src) + fx * (1 - fy) * _texel(S, tid, ix + 1, iy, src)
            + (1 - fx) * fy * _texel(S, tid, ix, iy + 1, src) + fx * fy * _texel(S, tid, ix + 1, iy + 1, src))


@nb.njit(**INLINE_JIT)
def udim_tile(S, tid, s, t):
    """(texture, s, t) that UDIM texture tid reads at (s, t): the coordinates mapped by its transform (TF_XF), tile
    1001 + 10 floor(t) + floor(s) at (s - floor s, t - floor t) where 0 <= s < 10 and 0 <= t < UDIM_ROWS, else the
    entry of a texel 0 (as a missing tile: Storm draws both black, with the texture's scale and bias)."""
    f = S.tex_f
    s, t = (f[tid, TF_XF] * s + f[tid, TF_XF + 1] * t + f[tid, TF_XF + 2],
            f[tid, TF_XF + 3] * s + f[tid, TF_XF + 4] * t + f[tid, TF_XF + 5])
    zero = S.tex_i[tid, TI_UDIM]
    u = math.floor(s)
    v = math.floor(t)
    if 0.0 <= u < 10.0 and 0.0 <= v < S.tex_i[tid, TI_UDIM_ROWS]:
        return zero + 1 + 10 * int(v) + int(u), s - u, t - v
    return zero, 0.5, 0.5


@nb.njit(**SHADING_JIT)
def sample_texture(S, tid, s, t):
    """Bilinear RGB lookup at texture coordinates (s, t), with UsdUVTexture scale and bias (the channels of
    `_source_channel`: one or two channels are grey); a UDIM texture's from the tile there (`udim_tile`)."""
    if F_UDIM and S.tex_i[tid, TI_UDIM] >= 0:
        tid, s, t = udim_tile(S, tid, s, t)
    at = _footprint(S, tid, s, t)
    ch = S.tex_i[tid, TI_CHANNELS]
    out0 = 0.0
    out1 = 0.0
    out2 = 0.0
    for c in range(3):
        v = _bilinear(S, tid, at, _source_channel(c, ch)) * S.tex_f[tid, TF_SCALE + c] + S.tex_f[tid, TF_BIAS + c]
        if c == 0:
            out0 = v
        elif c == 1:
            out1 = v
        else:
            out2 = v
    return (out0, out1, out2)


@nb.njit(**SHADING_JIT)
def sample_channel(S, tid, s, t, c):
    """Bilinear lookup of one output channel c (0-3: r, g, b, a; `_source_channel`) at texture coordinates
    (s, t), with that channel's UsdUVTexture scale and bias: a scalar input's texture."""
    if F_UDIM and S.tex_i[tid, TI_UDIM] >= 0:
        tid, s, t = udim_tile(S, tid, s, t)
    src = _source_channel(c, S.tex_i[tid, TI_CHANNELS])
    v = _bilinear(S, tid, _footprint(S, tid, s, t), src) if src >= 0 else 1.0
    return v * S.tex_f[tid, TF_SCALE + c] + S.tex_f[tid, TF_BIAS + c]


@nb.njit(**SHADING_JIT)
def sample_latlong(S, tid, d):
    """Colour of a lat-long environment image in local direction d (unit)."""
    lon = math.atan2(d[0], d[2])
    lat = math.asin(max(-1.0, min(1.0, d[1])))
    s = 0.5 - lon / (2.0 * math.pi)
    t = 0.5 + lat / math.pi
    return sample_texture(S, tid, s, t)
