"""Image files' pixels and their sRGB encoding: one reader (OpenImageIO) and one transfer function pair,
used by the film (output images, references) and the USD textures.

`srgb_encode` / `srgb_decode` are the exact piecewise sRGB OETF / EOTF (IEC 61966-2-1); `srgb_decode`
computes in the precision of its input (float32 textures stay float32, bit for bit what the texture
loader always produced).  The compiler decodes the course's cube-map faces with its own copy
(compiler/envmap.py): the compiler and the renderer never import each other.
"""
from __future__ import annotations

import functools
import os
from typing import Optional

import numpy as np


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """sRGB OETF of linear values clamped to [0, 1] (float64)."""
    x = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def srgb_decode(encoded: np.ndarray) -> np.ndarray:
    """Inverse of `srgb_encode` (sRGB EOTF) for values in [0, 1], in the input's float precision."""
    v = np.asarray(encoded)
    if not np.issubdtype(v.dtype, np.floating):
        v = v.astype(np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((np.maximum(v, 0.04045) + 0.055) / 1.055) ** 2.4)


@functools.lru_cache(maxsize=None)
def byte_lut() -> np.ndarray:
    """float32 (2, 256): what an 8-bit image's byte values are read as: row 0 OpenImageIO's conversion to float
    (`read_pixels`), row 1 that sRGB-decoded (`srgb_decode` in float32): bit for bit the values of the float32
    image `read_pixels` and `srgb_decode` give, so that textures can keep their bytes (a quarter of the memory)
    and the kernels look their values up (`kernel/textures._texel`)."""
    import OpenImageIO as oiio
    row = np.asarray(oiio.ImageBuf(np.arange(256, dtype=np.uint8).reshape(1, 256, 1)).get_pixels(oiio.FLOAT),
                     np.float32).reshape(256)
    return np.ascontiguousarray(np.stack([row, srgb_decode(row)]), np.float32)


def read_pixels(path, max_pixels: Optional[int] = None, keep_bytes: bool = False):
    """(float32 pixels (h, w, channels) as stored, the file's OpenImageIO ImageSpec).  Raises OSError
    with OpenImageIO's reason; `max_pixels` refuses a larger image from its header, before
    allocating (a corrupt header can claim 10^10 pixels).  `keep_bytes`: an image stored in 8 bits comes back
    as its uint8 values (`byte_lut` reads them)."""
    import OpenImageIO as oiio
    path = os.fspath(path)
    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise OSError(oiio.geterror() or 'unreadable image')
    try:
        spec = inp.spec()
        if max_pixels is not None and spec.width * spec.height * spec.depth > max_pixels:
            raise OSError(f'{spec.width} x {spec.height} pixels is more than the limit of {max_pixels}')
        as_bytes = keep_bytes and spec.format == oiio.UINT8
        pixels = inp.read_image(0, 0, 0, spec.nchannels, oiio.UINT8 if as_bytes else oiio.FLOAT)
        if pixels is None:
            raise OSError(inp.geterror() or 'no pixel data')
    finally:
        inp.close()
    return np.asarray(pixels, np.uint8 if as_bytes else np.float32).reshape(spec.height, spec.width,
                                                                            spec.nchannels), spec
