"""A DomeLight image in another layout than lat-long (`inputs:texture:format` = mirroredBall, angular,
cubeMapVerticalCross), resampled once, when the stage is read, into the lat-long image the renderer samples
and looks up (so the dome's importance sampling by luminance applies to it unchanged).

Every layout is read in the dome's own frame, the frame of its lat-long image (OpenEXR's convention, which
UsdLux names: +Y up, latitude 0 / longitude 0 along +Z, longitude pi/2 along +X, the image's centre at +Z):

* **mirroredBall**: an orthographic photograph of a mirror ball taken from +Z looking down -Z, +Y up and +X
  to the right (Debevec's light-probe frame).  Image point (a, b) in [-1, 1]^2 (a to the right, b up) is the
  ball's normal n = (a, b, sqrt(1 - a^2 - b^2)) and shows the direction the ball reflects a view ray down -Z
  into: (2 n_z a, 2 n_z b, 2 n_z^2 - 1).  Its centre shows +Z (behind the photographer), its rim -Z.
* **angular**: the same frame and picture with the radius linear in the angle from +Z (Debevec's angular
  map): direction D lies at (a, b) = (D_x, D_y) acos(D_z) / (pi sqrt(D_x^2 + D_y^2)).
* **cubeMapVerticalCross**: the six faces of a cube around the dome, unfolded into a cross three faces wide
  and four tall as seen from inside it: the +Z face in the middle of the second row, +Y above it, -Y below
  it and -Z below that (turned upside down, as folding the cross into the cube turns it), -Z's face read
  with +Y down; on the +Z row, +X to the left of the middle and -X to its right, as the lat-long image
  has them.

A dome whose format is `automatic` (the default) is read as its file names it: an OpenEXR file whose header says
it is a cube-face environment (`envmap`, OpenImageIO's `textureformat` "CubeFace Environment") as OpenEXR's own cube
map (`Imf::CubeMap`: six faces +X, -X, +Y, -Y, +Z, -Z stacked top to bottom, in its frame, which is this one),
every other file as lat-long.

An image is read with its texels at their centres and interpolated bilinearly (a ball or angular image no
nearer the rim of its disc than 1.5 texels, a cube's face within the face); each lat-long texel is the mean of
2 x 2 lookups across it.  The lat-long image is 2N x N texels for a ball or angular image N texels
across, 4F x 2F for a cube of faces F texels wide, at most `MAX_WIDTH` wide.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..description import linear_pixels

FORMATS = ('mirroredBall', 'angular', 'cubeMapVerticalCross')
EXR_CUBE = 'openexrCube'                 # what an `automatic` image's own header can name (`file_layout`)
LAYOUTS = FORMATS + (EXR_CUBE,)
MAX_WIDTH = 8192
BALL, ANGULAR, CROSS, STRIP = range(4)
# The cross's faces: (column, row) of the face, the dome-frame axis it faces, and the axes along its image's
# right and down, as seen from inside the cube (the +Z face reads as the lat-long image's middle: +X to its left).
_FACES = (
    ((1, 1), (0, 0, 1), (-1, 0, 0), (0, -1, 0)),     # +Z
    ((0, 1), (1, 0, 0), (0, 0, 1), (0, -1, 0)),      # +X, left of +Z
    ((2, 1), (-1, 0, 0), (0, 0, -1), (0, -1, 0)),    # -X, right of +Z
    ((1, 0), (0, 1, 0), (-1, 0, 0), (0, 0, 1)),      # +Y, above +Z
    ((1, 2), (0, -1, 0), (-1, 0, 0), (0, 0, -1)),    # -Y, below +Z
    ((1, 3), (0, 0, -1), (-1, 0, 0), (0, 1, 0)),     # -Z, below -Y: +Y down
)
# per face (rows as _FACES): column, row, then the axis, right and down vectors, 11 numbers
_FACE_TABLE = np.array([[c, r, *a, *rt, *dn] for (c, r), a, rt, dn in _FACES], np.float64)


@nb.njit(cache=True, nogil=True, inline='always')
def _bilinear(img, x, y, box, out, weight):
    """Add weight x img at continuous pixel coordinates (x, y) (texel centres at integers + 0.5) to out,
    interpolated bilinearly and clamped to the texels box = (x0, y0, x1, y1) (x1, y1 excluded)."""
    fx = min(max(x - 0.5, box[0]), box[2] - 1.0)
    fy = min(max(y - 0.5, box[1]), box[3] - 1.0)
    x0 = min(int(fx), box[2] - 1)
    y0 = min(int(fy), box[3] - 1)
    x1 = min(x0 + 1, box[2] - 1)
    y1 = min(y0 + 1, box[3] - 1)
    tx = fx - x0
    ty = fy - y0
    for k in range(out.shape[0]):
        top = img[y0, x0, k] * (1.0 - tx) + img[y0, x1, k] * tx
        bottom = img[y1, x0, k] * (1.0 - tx) + img[y1, x1, k] * tx
        out[k] += weight * (top * (1.0 - ty) + bottom * ty)


@nb.njit(cache=True, nogil=True, inline='always')
def _disc_point(dx, dy, dz, fmt):
    """(a, b): the point of the unit disc (a to the right, b up) where a ball or angular image shows direction d."""
    if fmt == BALL:                          # the ball's normal: halfway between d and the view ray back, +Z
        n = math.sqrt(dx * dx + dy * dy + (dz + 1.0) * (dz + 1.0))
        if n < 1e-12:
            return 1.0, 0.0                  # -Z itself: a point of the rim
        return dx / n, dy / n
    s = math.sqrt(dx * dx + dy * dy)
    if s < 1e-12:
        return (0.0, 0.0) if dz > 0.0 else (1.0, 0.0)
    r = math.acos(min(max(dz, -1.0), 1.0)) / math.pi / s
    return dx * r, dy * r


@nb.njit(cache=True, nogil=True, inline='always')
def _lookup(img, fmt, faces, d, out, weight):
    """Add weight x the image's value towards dome-frame direction d to out."""
    h, w = img.shape[0], img.shape[1]
    if fmt == STRIP:
        _strip_lookup(img, d, out, weight)
        return
    if fmt != CROSS:
        a, b = _disc_point(d[0], d[1], d[2], fmt)
        limit = max(1.0 - 3.0 / min(h, w), 0.0)     # no nearer the rim than 1.5 texels: all four inside the disc
        r = math.sqrt(a * a + b * b)
        if r > limit:
            a *= limit / r
            b *= limit / r
        _bilinear(img, (a + 1.0) * 0.5 * w, (1.0 - b) * 0.5 * h, (0, 0, w, h), out, weight)
        return
    k = 0
    best = -1.0
    for f in range(6):                     # the face whose axis is nearest d
        c = d[0] * faces[f, 2] + d[1] * faces[f, 3] + d[2] * faces[f, 4]
        if c > best:
            best, k = c, f
    s = (d[0] * faces[k, 5] + d[1] * faces[k, 6] + d[2] * faces[k, 7]) / best      # in [-1, 1] across the face
    t = (d[0] * faces[k, 8] + d[1] * faces[k, 9] + d[2] * faces[k, 10]) / best
    fw, fh = w / 3.0, h / 4.0
    x0, y0 = int(round(faces[k, 0] * fw)), int(round(faces[k, 1] * fh))
    x1, y1 = int(round((faces[k, 0] + 1.0) * fw)), int(round((faces[k, 1] + 1.0) * fh))
    _bilinear(img, x0 + (s + 1.0) * 0.5 * (x1 - x0), y0 + (t + 1.0) * 0.5 * (y1 - y0), (x0, y0, x1, y1), out, weight)


@nb.njit(cache=True, nogil=True, inline='always')
def _strip_lookup(img, d, out, weight):
    """Add weight x the value towards d of an OpenEXR cube map (`Imf::CubeMap`: faces +X, -X, +Y, -Y, +Z, -Z
    stacked top to bottom, each F x F; a texel's centre at an integer position, the outer ones on the face's
    edges)."""
    f = img.shape[1]
    ax, ay, az = abs(d[0]), abs(d[1]), abs(d[2])
    if ax >= ay and ax >= az:              # the face and the position in it (`faceAndPixelPosition`)
        face, m, p, q = (0 if d[0] > 0.0 else 1), ax, d[1], d[2]
    elif ay >= az:
        face, m, p, q = (2 if d[1] > 0.0 else 3), ay, d[0], d[2]
    else:
        face, m, p, q = (4 if d[2] > 0.0 else 5), az, d[0], d[1]
    p = (p / m + 1.0) * 0.5 * (f - 1)
    q = (q / m + 1.0) * 0.5 * (f - 1)
    top, bottom = face * f, face * f + f - 1
    if face == 0:                          # the position in the image (`pixelPosition`)
        x, y = q, bottom - p
    elif face == 1:
        x, y = f - 1 - q, bottom - p
    elif face == 3:
        x, y = p, top + q
    elif face == 4:
        x, y = f - 1 - p, bottom - q
    else:
        x, y = p, bottom - q
    _bilinear(img, x + 0.5, y + 0.5, (0, top, f, top + f), out, weight)


@nb.njit(cache=True, nogil=True)
def _resample(img, fmt, faces, out):
    """out (h, w, c): each texel the mean of 2 x 2 lookups of img (layout fmt) across it."""
    h, w, nc = out.shape
    acc = np.zeros(nc)
    d = np.zeros(3)
    sin_lon = np.empty((2, w))
    cos_lon = np.empty((2, w))
    for j in range(2):
        for x in range(w):
            lon = (0.5 - (x + 0.25 + 0.5 * j) / w) * 2.0 * math.pi
            sin_lon[j, x] = math.sin(lon)
            cos_lon[j, x] = math.cos(lon)
    for y in range(h):
        trig = [(math.cos(lat), math.sin(lat)) for lat in ((0.5 - (y + 0.25) / h) * math.pi,
                                                            (0.5 - (y + 0.75) / h) * math.pi)]
        for x in range(w):
            acc[:] = 0.0
            for i in range(2):
                cl, sl = trig[i]
                for j in range(2):
                    d[0] = cl * sin_lon[j, x]
                    d[1] = sl
                    d[2] = cl * cos_lon[j, x]
                    _lookup(img, fmt, faces, d, acc, 0.25)
            for k in range(nc):
                out[y, x, k] = acc[k]


def file_layout(resolved: str) -> str:
    """The layout a dome image's own file names, for `inputs:texture:format` = automatic: `EXR_CUBE` where its
    header says it is a cube-face environment (OpenEXR's `envmap` attribute, which OpenImageIO reads as
    `textureformat`), else 'latlong'."""
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(resolved)
    if inp is None:
        oiio.geterror()                    # (a packaged or unreadable file: read as its pixels say)
        return 'latlong'
    kind = str(inp.spec().getattribute('textureformat') or '')
    inp.close()
    return EXR_CUBE if kind == 'CubeFace Environment' else 'latlong'


def layout_problem(shape: tuple, fmt: str) -> str | None:
    """Why an image of `shape` (h, w, ...) cannot be read in layout `fmt`, or None."""
    h, w = shape[:2]
    if fmt == 'cubeMapVerticalCross' and w * 4 != h * 3:
        return f'a vertical cross is 3 faces wide and 4 tall; the image is {w} x {h}'
    if fmt == EXR_CUBE and h != 6 * w:
        return f'an OpenEXR cube map is 6 faces tall; the image is {w} x {h}'
    if min(h, w) < 2:
        return f'the image is {w} x {h}'
    return None


def latlong_size(shape: tuple, fmt: str) -> tuple:
    """(height, width) of the lat-long image resampled from an image of `shape` in layout `fmt`."""
    h, w = shape[:2]
    face = {'cubeMapVerticalCross': round(w / 3), EXR_CUBE: w}.get(fmt)
    width = 4 * max(1, face) if face is not None else 2 * max(h, w)
    width = min(width, MAX_WIDTH)
    width += width % 2
    return width // 2, width


def relayout(pixels, fmt: str, where: str, warn) -> np.ndarray:
    """A dome image's pixels (float32 or `BytePixels`) in layout `fmt` as the float32 lat-long image resampled from
    them; the pixels as they are, read as lat-long with a warning naming `where`, if their size does not fit it."""
    problem = layout_problem(pixels.shape, fmt)
    if problem is not None:
        said = 'automatic, and the file says it is a cube map' if fmt == EXR_CUBE else fmt
        warn(f'{where}: {said}, but {problem}; read as lat-long')
        return pixels
    return to_latlong(linear_pixels(pixels), fmt)


def to_latlong(pixels: np.ndarray, fmt: str) -> np.ndarray:
    """The float32 lat-long image (h, w, c) of `pixels` (float32 (h, w, c), linear), an image in layout `fmt`
    (one of LAYOUTS): see the module docstring."""
    img = np.ascontiguousarray(pixels, np.float32)
    height, width = latlong_size(img.shape, fmt)
    out = np.empty((height, width, img.shape[2]), np.float32)
    _resample(img, LAYOUTS.index(fmt), _FACE_TABLE, out)
    return out
