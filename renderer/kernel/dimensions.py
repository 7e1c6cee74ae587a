"""The sample-dimension layout: which dimension pair of a camera sample feeds which decision.

A camera sample is one point of the whole integrand domain (Cook, Porter, Carpenter 1984); the
sampler (`samplers.py`) maps (pixel, sample index, pair number) to numbers in [0, 1).  This module
alone decides the pair numbers; the integrator and the tests ask it:

    pair 0                 pixel position (filter importance sample), 2D
    pair 1                 lens position (depth of field), 2D; the Sobol' sampler draws pairs 0 and 1
                           as one 4D point (`samplers.sample_pixel_lens`)
    pair 2                 shutter time (motion blur), 1D
    then per bounce b (0 = the camera ray's hit), a block of n_lights + 2 pairs:
    light_dim(b, k, n)     position on light k (2D; unused by point and distant lights)
    bsdf_dim(b, n)         glossy / GGX direction (2D)
    choice_dim(b, n)       the discrete choices (1D: transparency, Fresnel reflect-or-refract,
                           Russian roulette)

The functions return int64, never a literal: a pair number passed as a compile-time constant would
make numba compile the sampler once per constant (measured: `sample_2d` compiled 4 times, a quarter of
the cold compile).

The path integrator (`path.py`) draws one light per vertex, so its block per path vertex v has a fixed
size, PATH_PAIRS, whatever the number of lights: path_dim(v, P_*) for the light point (2D), the light
choice, the BSDF direction (2D), the lobe choice (also the opacity choice) and Russian roulette.
"""
import numba as nb
import numpy as np

from .jit import INLINE_JIT

DIM_PIXEL = 0
DIM_LENS = 1
DIM_TIME = 2
DIM_BOUNCE0 = 3           # first pair of bounce 0's block


@nb.njit(**INLINE_JIT)
def pixel_dim():
    return np.int64(DIM_PIXEL)


@nb.njit(**INLINE_JIT)
def lens_dim():
    return np.int64(DIM_LENS)


@nb.njit(**INLINE_JIT)
def time_dim():
    return np.int64(DIM_TIME)


@nb.njit(**INLINE_JIT)
def dims_per_bounce(n_lights):
    """Pairs in one bounce's block: one per light, the BSDF pair and the choice."""
    return n_lights + 2


@nb.njit(**INLINE_JIT)
def light_dim(bounce, k, n_lights):
    """Pair of the position on light `k` at bounce `bounce`."""
    return DIM_BOUNCE0 + bounce * dims_per_bounce(n_lights) + k


@nb.njit(**INLINE_JIT)
def bsdf_dim(bounce, n_lights):
    """Pair of the glossy / GGX direction at bounce `bounce`."""
    return DIM_BOUNCE0 + bounce * dims_per_bounce(n_lights) + n_lights


@nb.njit(**INLINE_JIT)
def choice_dim(bounce, n_lights):
    """Pair (used as 1D) of the discrete choices at bounce `bounce`."""
    return DIM_BOUNCE0 + bounce * dims_per_bounce(n_lights) + n_lights + 1


PATH_PAIRS = 5
P_LIGHT, P_CHOICE, P_BSDF, P_LOBE, P_RR = range(PATH_PAIRS)


@nb.njit(**INLINE_JIT)
def path_dim(vertex, offset):
    """Pair of `offset` (P_*) at path vertex `vertex` (0 = the camera ray's hit) of the path integrator."""
    return DIM_BOUNCE0 + PATH_PAIRS * vertex + offset
