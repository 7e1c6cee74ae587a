"""Filter importance sampling: the offsets are distributed like the filters."""
import math

import numpy as np
import pytest
from numba import njit

from rtc.renderer.kernel import filters as F


@njit
def offsets(fid, n):
    """Offsets for a stratified 1D grid in u and v (v reversed) plus a 2D Halton-like lattice."""
    out = np.empty((n, 2))
    for i in range(n):
        u = (i + 0.5) / n
        v = ((i * 7919) % n + 0.5) / n
        out[i, 0], out[i, 1] = F.filter_offset(fid, u, v)
    return out


def test_names():
    assert F.FILTER_NAMES == {'box': 0, 'tent': 1, 'gaussian': 2}
    assert F.filter_id('Gaussian') == 2
    with pytest.raises(ValueError):
        F.filter_id('mitchell')


def test_box_is_uniform_half_pixel():
    assert F.filter_offset(F.BOX, 0.0, 0.0) == (-0.5, -0.5)
    d = offsets(F.BOX, 100000)
    assert d.min() >= -0.5 and d.max() < 0.5
    h, _ = np.histogram(d[:, 0], bins=10, range=(-0.5, 0.5))
    assert np.all(h == 10000)


@pytest.mark.parametrize('fid', [F.BOX, F.TENT, F.GAUSSIAN])
def test_histogram_matches_density(fid):
    n = 200000
    d = offsets(fid, n)
    r = F.FILTER_RADIUS[fid]
    assert np.all(np.abs(d) <= r)
    edges = np.linspace(-r, r, 31)
    for axis in (0, 1):
        h, _ = np.histogram(d[:, axis], bins=edges)
        # exact bin probabilities from the density (Simpson, fine)
        p = []
        for a, b in zip(edges[:-1], edges[1:]):
            xs = np.linspace(a, b, 201)
            ys = np.array([F.filter_pdf_1d(fid, x) for x in xs])
            p.append((b - a) / 600 * (ys[0] + ys[-1] + 4 * ys[1:-1:2].sum() + 2 * ys[2:-1:2].sum()))
        p = np.array(p)
        assert abs(p.sum() - 1) < 1e-6
        # stratified input: counts are within a couple of samples of the expectation
        assert np.max(np.abs(h - n * p)) <= 3, np.max(np.abs(h - n * p))


def test_tent_support_and_moments():
    d = offsets(F.TENT, 100000)
    assert d.min() >= -1.0 and d.max() <= 1.0
    assert F.filter_offset(F.TENT, 0.0, 0.5)[0] == -1.0
    assert abs(F.filter_offset(F.TENT, 0.5, 0.5)[0]) < 1e-15
    assert abs(d[:, 0].mean()) < 1e-4
    assert abs(d[:, 0].var() - 1.0 / 6.0) < 1e-4          # variance of the unit tent


def test_gaussian_variance_and_cdf_inversion():
    s, r = F.GAUSS_SIGMA, F.GAUSS_RADIUS
    assert (s, r) == (0.5, 1.5)
    # exact variance of a normal truncated at +-a: s^2 (1 - 2 a phi(a) / (2 Phi(a) - 1)), a = r/s
    a = r / s
    phi = math.exp(-a * a / 2) / math.sqrt(2 * math.pi)
    var = s * s * (1 - 2 * a * phi / math.erf(a / math.sqrt(2)))
    d = offsets(F.GAUSSIAN, 200000)
    assert abs(d[:, 0].mean()) < 1e-5 and abs(d[:, 1].mean()) < 1e-5
    assert abs(d[:, 0].var() - var) < 2e-5
    assert abs(d[:, 1].var() - var) < 2e-5
    # the warp is the inverse CDF to 1e-8 (Hermite interpolation of a 4097-entry table)
    for u in np.linspace(0.0, 0.999999, 997):
        x = F.sample_gaussian_1d(u)
        assert abs(F.gaussian_cdf(x) - u) < 1e-8
    assert F.sample_gaussian_1d(0.0) == -1.5
    assert abs(F.sample_gaussian_1d(0.5)) < 1e-12


def test_separable_and_monotone():
    for fid in (F.BOX, F.TENT, F.GAUSSIAN):
        us = np.linspace(0, 0.9999, 513)
        xs = np.array([F.filter_offset(fid, u, 0.3)[0] for u in us])
        assert np.all(np.diff(xs) > 0)
        assert len({F.filter_offset(fid, u, 0.3)[1] for u in us[:20]}) == 1
