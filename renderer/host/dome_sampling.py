"""Importance-sampling tables of textured dome lights: a piecewise-constant 2D distribution over the
lat-long image, texels weighted by luminance x sin(theta) (the solid angle of a row), as one
marginal CDF over rows and one conditional CDF per row (pbrt's Distribution2D; Pharr et al.,
"Physically Based Rendering", 4th ed., 2023, sec. A.5), flattened into one float64 array.
Sampled by `kernel/light_sampling.sample_dome_texture`.  A small floor (1e-3 of the mean weight)
keeps every direction samplable, so that next-event estimation alone stays unbiased where the
bilinear lookup spreads light into dark texels."""
from __future__ import annotations

import numpy as np

from .. import description as D

_LUM = np.array([0.2126, 0.7152, 0.0722])
FLOOR = 1e-3


def _luminance(t: D.Texture) -> np.ndarray:
    px = np.asarray(t.pixels, np.float64)
    if px.ndim == 2:
        px = px[:, :, None]
    scale = np.asarray(t.scale, np.float64)
    bias = np.asarray(t.bias, np.float64)
    c = px.shape[2]
    rgb = np.stack([px[:, :, min(i, c - 1) if c >= 3 else 0] * scale[i] + bias[i] for i in range(3)], -1)
    return np.maximum(rgb @ _LUM, 0.0)


def dome_tables(desc: D.SceneDescription):
    """(dome_i int64 (n_lights, 4) = (marginal offset, conditional offset, width, height) or -1,
    dome_cdf float64, {light: mean luminance of its texture})."""
    n = max(len(desc.lights), 1)
    dome_i = np.full((n, 4), -1, np.int64)
    chunks, off, means = [], 0, {}
    for k, l in enumerate(desc.lights):
        if l.type != D.DOME or l.texture < 0:
            continue
        y = _luminance(desc.textures[l.texture])
        h, w = y.shape
        means[k] = float(y.mean())
        lat = (0.5 - (np.arange(h) + 0.5) / h) * np.pi
        wgt = y * np.cos(lat)[:, None]
        wgt = wgt + FLOOR * max(float(wgt.mean()), 1e-300)
        rows = wgt.sum(1)
        cond = np.zeros((h, w + 1))
        cond[:, 1:] = np.cumsum(wgt, 1) / rows[:, None]
        cond[:, -1] = 1.0
        marg = np.zeros(h + 1)
        marg[1:] = np.cumsum(rows) / rows.sum()
        marg[-1] = 1.0
        dome_i[k] = (off, off + h + 1, w, h)
        chunks += [marg, cond.ravel()]
        off += h + 1 + h * (w + 1)
    return dome_i, (np.concatenate(chunks) if chunks else np.zeros(1)), means
