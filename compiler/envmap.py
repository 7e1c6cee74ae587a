"""Course cube-map environment (six PNG faces) -> one lat-long image for a UsdLux.DomeLight.

Face orientation follows the OpenGL cube-map convention (the course never specified one; spec
section 2.1).  The lat-long layout is the OpenEXR one that UsdLux.DomeLight documents: +Y is the
top row, longitude +pi at the left edge, longitude 0 (+Z) in the middle, +X at a quarter from the
right.  Faces are decoded from sRGB to linear and the result is written as a float EXR.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import OpenImageIO as oiio

FACES = ("posX", "negX", "posY", "negY", "posZ", "negZ")


class CubeMapError(Exception):
    """A face cannot be read or the faces do not form a cube map."""


def read_faces(faces: dict[str, Path]) -> dict[str, np.ndarray]:
    """Each face as float32 (n, n, 3) linear RGB; all faces must be square and the same size."""
    images = {}
    for name in FACES:
        buf = oiio.ImageBuf(str(faces[name]))
        if buf.has_error:
            raise CubeMapError(f"cannot read cube face {faces[name]}: {buf.geterror()}")
        pixels = buf.get_pixels(oiio.FLOAT)
        if pixels is None or pixels.ndim != 3:
            raise CubeMapError(f"cannot read cube face {faces[name]}")
        rgb = pixels[..., :3] if pixels.shape[2] >= 3 else np.repeat(pixels[..., :1], 3, axis=2)
        images[name] = _srgb_to_linear(rgb.astype(np.float32))
    sizes = {img.shape[:2] for img in images.values()}
    if len(sizes) != 1 or next(iter(sizes))[0] != next(iter(sizes))[1]:
        raise CubeMapError("cube faces must be square and all the same size, got "
                                + ", ".join(f"{k} {v.shape[1]}x{v.shape[0]}" for k, v in images.items()))
    return images


def _srgb_to_linear(c: np.ndarray) -> np.ndarray:
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(np.float32)


def latlong_directions(height: int) -> np.ndarray:
    """Unit direction of each pixel centre of a (height, 2*height) lat-long image."""
    width = 2 * height
    lat = np.pi / 2 - (np.arange(height) + 0.5) / height * np.pi
    lon = np.pi - (np.arange(width) + 0.5) / width * 2 * np.pi
    lat, lon = np.meshgrid(lat, lon, indexing="ij")
    return np.stack([np.cos(lat) * np.sin(lon), np.sin(lat), np.cos(lat) * np.cos(lon)], axis=-1)


def cube_lookup(images: dict[str, np.ndarray], d: np.ndarray) -> np.ndarray:
    """Nearest-texel cube-map lookup for directions d (..., 3), OpenGL face conventions."""
    n = next(iter(images.values())).shape[0]
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    ax, ay, az = np.abs(x), np.abs(y), np.abs(z)
    out = np.zeros(d.shape[:-1] + (3,), np.float32)
    major_x = (ax >= ay) & (ax >= az)
    major_y = ~major_x & (ay >= az)
    major_z = ~major_x & ~major_y
    #           face    mask                 sc     tc     ma
    table = [("posX", major_x & (x > 0), -z, -y, ax), ("negX", major_x & (x <= 0), z, -y, ax),
             ("posY", major_y & (y > 0), x, z, ay), ("negY", major_y & (y <= 0), x, -z, ay),
             ("posZ", major_z & (z > 0), x, -y, az), ("negZ", major_z & (z <= 0), -x, -y, az)]
    for face, mask, sc, tc, ma in table:
        s = (sc[mask] / ma[mask] + 1) / 2
        t = (tc[mask] / ma[mask] + 1) / 2
        col = np.clip((s * n).astype(np.int64), 0, n - 1)
        row = np.clip((t * n).astype(np.int64), 0, n - 1)
        out[mask] = images[face][row, col]
    return out


def write_latlong(faces: dict[str, Path], out: Path) -> None:
    """Convert the cube map to a lat-long EXR of height = 2 x face size (nearest texel, so every
    face texel is kept)."""
    images = read_faces(faces)
    height = 2 * next(iter(images.values())).shape[0]
    pixels = cube_lookup(images, latlong_directions(height))
    spec = oiio.ImageSpec(2 * height, height, 3, oiio.HALF)
    writer = oiio.ImageOutput.create(str(out))
    if writer is None or not writer.open(str(out), spec):
        raise CubeMapError(f"cannot write {out}: {oiio.geterror()}")
    ok = writer.write_image(pixels)
    writer.close()
    if not ok:
        raise CubeMapError(f"cannot write {out}: {writer.geterror()}")
