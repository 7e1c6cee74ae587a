"""Image error metrics (numpy), as used in /work/shared/peers-and-sampling.md sec. 4.

All take linear-RGB images of identical shape; ``ref`` is the reference.  Averages run over every
pixel and channel.
"""
from __future__ import annotations

import numpy as np


def _pair(a, ref):
    a = np.asarray(a, dtype=np.float64)
    ref = np.asarray(ref, dtype=np.float64)
    if a.shape != ref.shape:
        raise ValueError('image shapes differ: %s vs %s' % (a.shape, ref.shape))
    return a, ref


def mse(a, ref) -> float:
    """Mean squared error."""
    a, ref = _pair(a, ref)
    return float(np.mean((a - ref) ** 2))


def rmse(a, ref) -> float:
    """Root mean squared error (absolute; dominated by bright pixels).  Equals OpenImageIO's
    ``ImageBufAlgo.compare(a, ref, ...).rms_error``."""
    return float(np.sqrt(mse(a, ref)))


def rel_mse(a, ref, eps: float = 0.01) -> float:
    """Relative MSE, mean((a - ref)^2 / (ref^2 + eps)), the usual HDR metric of the denoising and
    adaptive-sampling literature (eps avoids division by ~0 in dark pixels)."""
    a, ref = _pair(a, ref)
    return float(np.mean((a - ref) ** 2 / (ref * ref + eps)))

