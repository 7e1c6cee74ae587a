"""Image files' pixels and their sRGB encoding: one reader (OpenImageIO) and one transfer function pair,
used by the film (output images, references) and the USD textures.

`srgb_encode` / `srgb_decode` are the exact piecewise sRGB OETF / EOTF (IEC 61966-2-1); `srgb_decode`
computes in the precision of its input (float32 textures stay float32, bit for bit what the texture
loader always produced).  The compiler decodes the course's cube-map faces with its own copy
(compiler/envmap.py): the compiler and the renderer never import each other.
"""
from __future__ import annotations

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


def read_pixels(path, max_pixels: Optional[int] = None):
    """(float32 pixels (h, w, channels) as stored, the file's OpenImageIO ImageSpec).  Raises OSError
    with OpenImageIO's reason; `max_pixels` refuses a larger image from its header, before
    allocating (a corrupt header can claim 10^10 pixels)."""
    import OpenImageIO as oiio
    path = os.fspath(path)
    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise OSError(oiio.geterror() or 'unreadable image')
    try:
        spec = inp.spec()
        if max_pixels is not None and spec.width * spec.height * spec.depth > max_pixels:
            raise OSError(f'{spec.width} x {spec.height} pixels is more than the limit of {max_pixels}')
        pixels = inp.read_image(0, 0, 0, spec.nchannels, oiio.FLOAT)
        if pixels is None:
            raise OSError(inp.geterror() or 'no pixel data')
    finally:
        inp.close()
    return np.asarray(pixels, np.float32).reshape(spec.height, spec.width, spec.nchannels), spec
