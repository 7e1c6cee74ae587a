"""Film: progressive sample accumulation, checkpoints, and atomic image output via OpenImageIO.

Accumulation
    With filter importance sampling (``rtc.renderer.kernel.filters``) every sample has weight 1 and lands in
    its own pixel only, so a pixel's estimate is (sum of its sample radiances) / (its sample
    count).  ``Film`` keeps float64 sums (h, w, 3) and int64 counts (h, w); the integrator renders
    passes (whole image or tiles) and adds each pass's per-pixel sums with ``add_pass``.  Inside
    numba kernels, ``add_sample`` accumulates one sample into the same arrays.

Output
    ``write_image`` picks the format from the extension: ``.exr`` is linear float (32-bit by
    default, half on request) with typed metadata attributes; ``.png``, ``.jpg``/``.jpeg`` (8-bit)
    and ``.tif``/``.tiff`` (16-bit) are sRGB-encoded with the exact piecewise sRGB OETF
    (IEC 61966-2-1), clamped to [0, 1], with the metadata as string attributes where the format
    keeps them (plus a summary in ``ImageDescription``).  Writes are atomic: the image goes to a
    hidden temporary file in the target directory (``.name.tmp-XXXX.ext``, real extension kept so
    that OpenImageIO picks the format) and is then renamed over the target with ``os.replace``;
    on any failure the temporary file is removed and ``FilmError`` is raised, and the target is
    never left partially written.

Non-finite pixels
    NaN and +-Inf values are replaced by 0 before writing (they would poison every viewer and
    metric); ``write_image`` returns the number of replaced values, records it as the
    ``rtc:nonfinite`` attribute and emits a ``RuntimeWarning`` when it is non-zero.
"""
from __future__ import annotations

import json
import os
import tempfile
import warnings

import numpy as np
from numba import njit

import OpenImageIO as oiio

from ..images import read_pixels, srgb_decode, srgb_encode       # srgb_*: re-exported for the tests

LINEAR_FORMATS = {'.exr': 'openexr'}
SRGB_FORMATS = {'.png': 'uint8', '.jpg': 'uint8', '.jpeg': 'uint8', '.tif': 'uint16', '.tiff': 'uint16'}
CHECKPOINT_VERSION = 1


class FilmError(RuntimeError):
    """Image or checkpoint I/O failed (unknown format, unwritable directory, bad file...)."""


def quantize(encoded: np.ndarray, dtype) -> np.ndarray:
    """Round [0, 1] values to the nearest code of an unsigned integer type."""
    top = np.iinfo(dtype).max
    return np.rint(np.clip(encoded, 0.0, 1.0) * top).astype(dtype)


# --------------------------------------------------------------------------- Film
@njit(cache=True, nogil=True)
def add_sample(rgb_sum, count, y, x, r, g, b):
    """Accumulate one weight-1 sample into pixel (y, x) of a film's arrays (inside kernels)."""
    rgb_sum[y, x, 0] += r
    rgb_sum[y, x, 1] += g
    rgb_sum[y, x, 2] += b
    count[y, x] += 1


class Film:
    """Per-pixel float64 radiance sums and int64 sample counts, for progressive rendering.

    ``meta`` is a free-form JSON-serialisable dict saved with checkpoints (e.g. sampler, seed,
    next sample index), so that a render can resume where it stopped."""

    def __init__(self, width: int, height: int, meta: dict | None = None):
        if width <= 0 or height <= 0:
            raise ValueError('film size must be positive, got %dx%d' % (width, height))
        self.width, self.height = int(width), int(height)
        self.sum = np.zeros((self.height, self.width, 3), dtype=np.float64)
        self.count = np.zeros((self.height, self.width), dtype=np.int64)
        self.meta = dict(meta or {})

    @property
    def shape(self) -> tuple[int, int]:
        return self.height, self.width

    @property
    def spp(self) -> int:
        """Samples per pixel completed everywhere (the minimum count)."""
        return int(self.count.min())

    @property
    def total_samples(self) -> int:
        return int(self.count.sum())

    def add_pass(self, rgb_sum: np.ndarray, samples, y0: int = 0, x0: int = 0) -> None:
        """Add a pass: ``rgb_sum`` (h, w, 3) holds the per-pixel sums of ``samples`` weight-1
        samples (an int, or an (h, w) int array), for the tile whose top-left pixel is (y0, x0)."""
        rgb_sum = np.asarray(rgb_sum)
        if rgb_sum.ndim != 3 or rgb_sum.shape[2] != 3:
            raise ValueError('pass must be (h, w, 3), got %s' % (rgb_sum.shape,))
        h, w = rgb_sum.shape[:2]
        if y0 < 0 or x0 < 0 or y0 + h > self.height or x0 + w > self.width:
            raise ValueError('tile %dx%d at (%d, %d) outside the %dx%d film'
                             % (w, h, x0, y0, self.width, self.height))
        self.sum[y0:y0 + h, x0:x0 + w] += rgb_sum
        self.count[y0:y0 + h, x0:x0 + w] += np.asarray(samples, dtype=np.int64)

    def merge(self, other: 'Film') -> None:
        """Add another film of the same size (e.g. rendered with another seed)."""
        if other.shape != self.shape:
            raise ValueError('film sizes differ')
        self.sum += other.sum
        self.count += other.count

    def image(self) -> np.ndarray:
        """Float32 (h, w, 3) per-pixel mean; pixels without samples are 0."""
        n = np.maximum(self.count, 1)[..., None]
        with np.errstate(over='ignore'):                  # past float32's range: inf (`write_image` reports it)
            return (self.sum / n).astype(np.float32)

    def clear(self) -> None:
        self.sum[...] = 0.0
        self.count[...] = 0

    # ---------------------------------------------------------------- checkpoints
    def to_checkpoint(self, path) -> None:
        """Save the accumulators and ``meta`` to an ``.npz`` file, atomically."""
        path = os.fspath(path)
        meta = json.dumps(self.meta, sort_keys=True)

        def write(tmp):
            with open(tmp, 'wb') as f:
                np.savez(f, version=np.int64(CHECKPOINT_VERSION), sum=self.sum,
                         count=self.count, meta=np.array(meta))

        _atomic_write(path, write)

    @classmethod
    def from_checkpoint(cls, path) -> 'Film':
        """Load a film saved by ``to_checkpoint``; ``FilmError`` if missing or invalid."""
        path = os.fspath(path)
        try:
            with np.load(path, allow_pickle=False) as z:
                version = int(z['version'])
                rgb_sum, count, meta = z['sum'], z['count'], json.loads(str(z['meta']))
        except (OSError, KeyError, ValueError) as e:
            raise FilmError('cannot read checkpoint %s: %s' % (path, e)) from e
        if version != CHECKPOINT_VERSION:
            raise FilmError('checkpoint %s has version %d, expected %d' % (path, version, CHECKPOINT_VERSION))
        if rgb_sum.ndim != 3 or rgb_sum.shape[2] != 3 or count.shape != rgb_sum.shape[:2]:
            raise FilmError('checkpoint %s has inconsistent arrays %s / %s' % (path, rgb_sum.shape, count.shape))
        film = cls(rgb_sum.shape[1], rgb_sum.shape[0], meta)
        film.sum[...] = rgb_sum
        film.count[...] = count
        return film


# --------------------------------------------------------------------------- atomic files
def _atomic_write(path: str, write) -> None:
    """Call ``write(tmp)`` on a hidden temp file next to ``path`` then rename it to ``path``."""
    directory = os.path.dirname(os.path.abspath(path))
    base = os.path.basename(path)
    stem, ext = os.path.splitext(base)
    if not os.path.isdir(directory):
        raise FilmError('cannot write %s: directory %s does not exist' % (path, directory))
    try:
        fd, tmp = tempfile.mkstemp(prefix='.%s.tmp-' % stem, suffix=ext, dir=directory)
    except OSError as e:
        raise FilmError('cannot write %s: %s' % (path, e)) from e
    os.close(fd)
    try:
        write(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)        # mkstemp creates 0600; give the usual permissions
        os.replace(tmp, path)
    except BaseException as e:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(e, FilmError):
            raise
        if isinstance(e, Exception):
            raise FilmError('cannot write %s: %s' % (path, e)) from e
        raise


# --------------------------------------------------------------------------- images
def _sanitize(rgb) -> tuple[np.ndarray, int]:
    with np.errstate(over='ignore'):                      # (float64 past float32's range: inf, counted below)
        a = np.asarray(rgb, dtype=np.float32)
    if a.ndim == 2:
        a = np.repeat(a[..., None], 3, axis=2)
    if a.ndim != 3 or a.shape[2] not in (3, 4) or a.shape[0] == 0 or a.shape[1] == 0:
        raise FilmError('image must be (h, w, 3) (or 4), got shape %s' % (a.shape,))
    bad = ~np.isfinite(a)
    n_bad = int(bad.sum())
    if n_bad:
        a = np.where(bad, np.float32(0.0), a)
    return np.ascontiguousarray(a), n_bad


def write_image(path, rgb, metadata: dict | None = None, *, exr_half: bool = False,
                jpeg_quality: int = 95, encoding: str = 'srgb', warn=None) -> int:
    """Write a linear float image (h, w, 3) to ``path`` atomically; format from the extension.

    ``metadata`` keys become image attributes (e.g. ``rtc:spp``, ``rtc:sampler``,
    ``rtc:seconds``, ``rtc:rays``, ``rtc:seed``, ``Software``): typed in EXR, strings elsewhere.
    ``encoding`` applies to the 8/16-bit formats: ``srgb`` (the standard) or ``linear`` (values
    written straight into the integers, as the course's renderers do; tagged linear).
    Returns the number of non-finite values (NaN, or past float32's range) that were replaced by 0, which are
    also reported: to ``warn(message)`` when given (the CLI's own warnings), else as a RuntimeWarning.  Raises
    ``FilmError``."""
    path = os.fspath(path)
    if encoding not in ('srgb', 'linear'):
        raise FilmError(f'cannot write {path}: unknown encoding {encoding!r} (use srgb or linear)')
    ext = os.path.splitext(path)[1].lower()
    if ext not in LINEAR_FORMATS and ext not in SRGB_FORMATS:
        raise FilmError('cannot write %s: unknown image extension %r (use %s)'
                        % (path, ext, ', '.join(sorted({*LINEAR_FORMATS, *SRGB_FORMATS}))))
    data, n_bad = _sanitize(rgb)
    meta = dict(metadata or {})
    meta.setdefault('Software', 'rtc')
    if n_bad:
        meta['rtc:nonfinite'] = n_bad
        message = f"{path}: replaced {n_bad} non-finite values by 0 (past float32's range, or NaN)"
        if warn is None:
            warnings.warn(message, RuntimeWarning, stacklevel=2)
        else:
            warn(message)
    h, w, c = data.shape

    if ext in LINEAR_FORMATS:
        spec = oiio.ImageSpec(w, h, c, 'half' if exr_half else 'float')
        spec.attribute('compression', 'zip')
        for k, v in meta.items():
            _set_typed_attribute(spec, k, v)
        pixels = data
    else:
        fmt = SRGB_FORMATS[ext]
        spec = oiio.ImageSpec(w, h, c, fmt)
        encoded = srgb_encode(data) if encoding == 'srgb' else np.clip(data, 0.0, 1.0)
        pixels = quantize(encoded, np.dtype(fmt))
        if c == 4:                        # alpha is linear coverage, not sRGB-encoded
            pixels[..., 3] = quantize(np.clip(data[..., 3], 0, 1), np.dtype(fmt))
        spec.attribute('oiio:ColorSpace', 'sRGB' if encoding == 'srgb' else 'lin_rec709')
        if ext in ('.jpg', '.jpeg'):
            spec.attribute('Compression', 'jpeg:%d' % jpeg_quality)
            spec.attribute('jpeg:subsampling', '4:4:4')
        for k, v in meta.items():
            spec.attribute(k, _to_string(v))
        if 'ImageDescription' not in meta:
            spec.attribute('ImageDescription', '; '.join('%s=%s' % (k, _to_string(v))
                                                         for k, v in meta.items() if k != 'Software'))

    def write(tmp):
        out = oiio.ImageOutput.create(tmp)
        if out is None:
            raise FilmError('cannot write %s: %s' % (path, oiio.geterror() or 'no writer'))
        if not out.open(tmp, spec):
            raise FilmError('cannot write %s: %s' % (path, out.geterror()))
        ok = out.write_image(pixels)
        err = out.geterror()
        ok = out.close() and ok
        if not ok:
            raise FilmError('cannot write %s: %s' % (path, err or out.geterror()))

    _atomic_write(path, write)
    return n_bad


def _to_string(v) -> str:
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, (list, tuple, dict)):
        return json.dumps(v)
    return str(v)


def _set_typed_attribute(spec, key, value) -> None:
    if isinstance(value, (bool, np.bool_)):
        spec.attribute(key, int(value))
    elif isinstance(value, (int, np.integer)):
        v = int(value)
        if -2**31 <= v < 2**31:
            spec.attribute(key, v)
        else:
            spec.attribute(key, float(v))          # e.g. ray counts above 2^31
    elif isinstance(value, (float, np.floating)):
        spec.attribute(key, float(value))
    else:
        spec.attribute(key, _to_string(value))


def read_image(path) -> np.ndarray:
    """Read an image as linear float32 (h, w, 3): EXR/HDR as stored, 8/16-bit integer formats
    (PNG, JPEG, TIFF) decoded from sRGB.  Grey images are replicated, alpha is dropped."""
    import OpenImageIO as oiio
    try:
        a, spec = read_pixels(path)
    except OSError as e:
        raise FilmError(f'cannot read {os.fspath(path)}: {e}') from None
    if spec.nchannels == 1:
        a = np.repeat(a, 3, axis=2)
    elif spec.nchannels == 2:
        a = np.repeat(a[..., :1], 3, axis=2)
    a = a[..., :3]
    if spec.format.basetype in (oiio.UINT8, oiio.UINT16, oiio.INT8, oiio.INT16):
        a = srgb_decode(a.astype(np.float64)).astype(np.float32)
    return np.ascontiguousarray(a)
