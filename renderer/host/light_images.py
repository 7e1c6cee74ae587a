"""Importance-sampling tables of lights' images: a piecewise-constant 2D distribution over each image,
as one marginal CDF over rows and one conditional CDF per row (pbrt's Distribution2D; Pharr et al.,
"Physically Based Rendering", 4th ed., 2023, sec. A.5), flattened into one float64 array.  A textured
dome's lat-long image has its texels weighted by luminance x sin(theta) (the solid angle of a row; sampled
by `kernel/dome_sampling.sample_dome_texture`), a textured rect light's image by luminance alone (every
texel covers the same area of the rect; sampled by `kernel/rect_sampling.sample_image_point`).

A texel's weight is the mean, over the texel, of what the kernels see: the bilinear interpolation of the
image (`kernel/textures.sample_texture`), with the texture's wrap modes.  That is the image filtered by
[1/8, 3/4, 1/8] along each axis (pbrt-v4 builds its distribution from the image's values over each
pixel in the same spirit), so that light the lookup spreads from a bright texel into dark neighbours
is where the distribution puts samples: from the texels' own luminance, a lone hot texel on black had
44 % of its light in texels that light samples reached only through a floor, and next-event estimation
alone converged to 0.58 of the image (`tests/accuracy/test_path_lights.py`).  A small floor (1e-3 of the
mean weight) keeps every direction samplable besides."""
from __future__ import annotations

import numpy as np

from .. import description as D

_LUM = np.array([0.2126, 0.7152, 0.0722])
FLOOR = 1e-3


def _luminance(t: D.Texture) -> np.ndarray:
    px = np.asarray(D.linear_pixels(t.pixels), np.float64)
    if px.ndim == 2:
        px = px[:, :, None]
    scale = np.asarray(t.scale, np.float64)
    bias = np.asarray(t.bias, np.float64)
    c = px.shape[2]
    rgb = np.stack([px[:, :, min(i, c - 1) if c >= 3 else 0] * scale[i] + bias[i] for i in range(3)], -1)
    return np.maximum(rgb @ _LUM, 0.0)


_PAD = {'repeat': 'wrap', 'clamp': 'edge', 'mirror': 'symmetric', 'black': 'constant'}


def texel_means(y: np.ndarray, wrap_s: str, wrap_t: str) -> np.ndarray:
    """The mean of the bilinear interpolation of image y (h, w) over each texel: y filtered by
    [1/8, 3/4, 1/8] along rows and columns, beyond the edges by the wrap modes (as `kernel/textures._wrap`)."""
    p = np.pad(y, ((1, 1), (0, 0)), mode=_PAD.get(wrap_t, 'edge'))
    y = 0.125 * (p[:-2] + p[2:]) + 0.75 * p[1:-1]
    p = np.pad(y, ((0, 0), (1, 1)), mode=_PAD.get(wrap_s, 'wrap'))
    return 0.125 * (p[:, :-2] + p[:, 2:]) + 0.75 * p[:, 1:-1]


def image_tables(desc: D.SceneDescription):
    """(image_i int64 (n_lights, 4) = (marginal offset, conditional offset, width, height) or -1,
    image_cdf float64, {light: mean luminance of its image}) of the textured dome and rect lights."""
    n = max(len(desc.lights), 1)
    image_i = np.full((n, 4), -1, np.int64)
    chunks, off, means = [], 0, {}
    for k, l in enumerate(desc.lights):
        if l.type not in (D.DOME, D.RECT) or l.texture < 0:
            continue
        tex = desc.textures[l.texture]
        y = _luminance(tex)
        h, w = y.shape
        means[k] = float(y.mean())
        wgt = texel_means(y, tex.wrap_s, tex.wrap_t)
        if l.type == D.DOME:
            wgt = wgt * np.cos((0.5 - (np.arange(h) + 0.5) / h) * np.pi)[:, None]
        wgt = wgt + FLOOR * max(float(wgt.mean()), 1e-300)
        rows = wgt.sum(1)
        cond = np.zeros((h, w + 1))
        cond[:, 1:] = np.cumsum(wgt, 1) / rows[:, None]
        cond[:, -1] = 1.0
        marg = np.zeros(h + 1)
        marg[1:] = np.cumsum(rows) / rows.sum()
        marg[-1] = 1.0
        image_i[k] = (off, off + h + 1, w, h)
        chunks += [marg, cond.ravel()]
        off += h + 1 + h * (w + 1)
    return image_i, (np.concatenate(chunks) if chunks else np.zeros(1)), means
