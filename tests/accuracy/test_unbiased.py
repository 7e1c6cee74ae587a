"""Unbiasedness: the mean of renders with K different seeds converges to the closed-form image at the
Monte Carlo rate K^-1/2 (a biased estimator would flatten the curve at its bias).

Scene: a Lambertian plane under a rectangular area light, whose irradiance is Lambert's polygon
formula (tests/renderer/test_integrator.py), averaged over each pixel by a fine quadrature.
"""
import numpy as np
import pytest

from tests.renderer import test_integrator as ti
from rtc.renderer import description as D
from rtc.renderer.host.converge import fit_slope
from rtc.renderer.host.render import RenderOptions, Renderer

from tests.renderer.handmade import ortho_down, quad, rect_light, scene

N, WIDTH, H, A, B, LR = 24, 4.0, 1.0, 1.2, 0.8, 2.0
SEEDS = 256


def reference():
    corners = [(-A / 2, H, -B / 2), (A / 2, H, -B / 2), (A / 2, H, B / 2), (-A / 2, H, B / 2)]
    return ti.pixel_average(lambda x, z: 0.5 * ti.polygon_irradiance(x, z, corners, LR), N, WIDTH, sub=24)


@pytest.fixture(scope='module')
def renders():
    lam = D.Material('/lambert', model=D.LAMBERTIAN, diffuse=(0.5, 0.5, 0.5))
    desc = scene([D.Container('/', meshes=[quad(40.0)])], [lam], [rect_light((0.0, H, 0.0), A, B, (LR,) * 3)],
                 ortho_down(width=WIDTH), width=N, height=N)
    out = {}
    with Renderer(desc) as r:
        for sampler in ('independent', 'sobol'):
            out[sampler] = np.stack([r.render(RenderOptions(spp=4, sampler=sampler, filter='box', seed=s))
                                     .image[..., 0].astype(np.float64) for s in range(SEEDS)])
    return out


def test_reference_quadrature_is_converged():
    corners = [(-A / 2, H, -B / 2), (A / 2, H, -B / 2), (A / 2, H, B / 2), (-A / 2, H, B / 2)]
    fine = ti.pixel_average(lambda x, z: 0.5 * ti.polygon_irradiance(x, z, corners, LR), N, WIDTH, sub=48)
    assert np.sqrt(np.mean((reference() - fine) ** 2)) < 2e-5


@pytest.mark.parametrize('sampler', ['independent', 'sobol'])
def test_mean_over_seeds_converges_at_the_monte_carlo_rate(renders, sampler):
    imgs, ref = renders[sampler], reference()
    ks = 2 ** np.arange(9)                                   # 1 .. 256 seeds
    err = np.array([np.sqrt(np.mean((imgs[:k].mean(0) - ref) ** 2)) for k in ks])
    slope = fit_slope(ks, err)
    assert slope == pytest.approx(-0.5, abs=0.08), (slope, err)
    # the last point still follows the rate: no bias floor (err(256) ~ err(1)/16)
    assert err[-1] < 2.0 * err[0] / 16
    # and the signed mean error over all pixels is consistent with zero
    per_pixel_sd = imgs.std(0, ddof=1)
    mean_err = (imgs.mean(0) - ref).mean()
    assert abs(mean_err) < 4 * np.sqrt(np.mean(per_pixel_sd ** 2) / SEEDS / ref.size)
