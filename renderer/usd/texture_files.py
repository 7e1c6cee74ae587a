"""Texture files decoded into the pixels a `Texture` holds: float32 linear values, or an 8-bit file's bytes."""
from __future__ import annotations

import os
import tempfile

import numpy as np
from pxr import Ar

from ..description import BytePixels
from ..images import read_pixels, srgb_decode

MAX_TEXTURE_PIXELS = 1 << 28      # 16k x 16k; decoded as float32 (a corrupt header can claim 10^10)


def read_texture(resolved: str, colour_space: str = 'auto'):
    """Decode an image to float32 (h, w, c) linear values, or an 8-bit one to its bytes (`BytePixels`, which the
    kernels read as those values).

    `colour_space` follows UsdUVTexture.sourceColorSpace: 'sRGB' decodes the colour channels,
    'raw' does not, 'auto' decodes when the file says it is sRGB or, lacking metadata, when it
    stores 8-bit values.  Files inside a package (``scene.usdz[tex.png]``) are read through Ar."""
    import OpenImageIO as oiio
    if resolved.endswith(']') and '[' in resolved:
        data = Ar.GetResolver().OpenAsset(Ar.ResolvedPath(resolved))
        if data is None:
            raise OSError('cannot open packaged asset')
        suffix = os.path.splitext(resolved[:-1])[1]
        with tempfile.NamedTemporaryFile(suffix=suffix) as tmp:
            tmp.write(bytes(data.GetBuffer()))
            tmp.flush()
            return read_texture(tmp.name, colour_space)
    pixels, spec = read_pixels(resolved, MAX_TEXTURE_PIXELS, keep_bytes=True)
    tagged = str(spec.getattribute('oiio:ColorSpace') or '').lower()
    colour = 0
    if colour_space == 'sRGB' or (colour_space == 'auto' and (
            tagged.startswith('srgb') or (not tagged and spec.format == oiio.UINT8))):
        colour = min(3, spec.nchannels if spec.nchannels != 2 else 1)
    if pixels.dtype == np.uint8:
        return BytePixels(np.ascontiguousarray(pixels), colour)
    pixels[..., :colour] = srgb_decode(pixels[..., :colour])
    return np.ascontiguousarray(pixels)
