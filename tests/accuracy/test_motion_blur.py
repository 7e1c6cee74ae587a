"""Motion blur against the analytic coverage ramp.

A large black quad whose right edge moves linearly from x = e0 to x = e0 + D over the shutter (two
motion samples), white background, orthographic camera looking down.  A film point at x is covered
while the edge is to its right, i.e. for the fraction 1 - clamp((x - e0) / D, 0, 1) of the shutter,
so the box-filtered pixel value is the pixel average of clamp((x - e0) / D, 0, 1): a linear ramp of
slope 1/D across the swept band.  The tolerance follows from the spp: each sample is 0 or 1, so a
pixel of expected value p has standard deviation sqrt(p (1 - p) / spp) with independent samples.
"""
import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host.render import RenderOptions, render

from tests.renderer.handmade import ortho_down, quad, scene, translate

N, WIDTH = 64, 4.0
E0, DIST = -1.0, 1.5


def moving_edge(steps=2):
    black = D.Material('/black', model=D.LAMBERTIAN, diffuse=(0.0, 0.0, 0.0))
    cont = D.Container('/q', meshes=[quad(10.0, y=0.0, material=0, center=(-5.0, 0.0))])  # right edge at x = 0
    mats = np.stack([translate(E0 + DIST * k / (steps - 1), 0, 0) for k in range(steps)])[None]
    inst = D.Instances(container=np.zeros(1, np.int32), matrices=mats, material_set=np.zeros(1, np.int32),
                       material_sets=[()])
    return scene([cont], [black], [], ortho_down(width=WIDTH), instances=inst, width=N, height=N,
                 background=(1, 1, 1))


def analytic(sub=64):
    off = (np.arange(sub) + 0.5) / sub - 0.5
    xs = -WIDTH / 2 + WIDTH * ((np.arange(N) + 0.5)[:, None] + off[None]) / N
    return np.clip((xs - E0) / DIST, 0.0, 1.0).mean(1)


@pytest.mark.parametrize('sampler, spp', [('independent', 64), ('sobol', 64)])
def test_moving_edge_gives_the_linear_coverage_ramp(sampler, spp):
    img = render(moving_edge(), RenderOptions(spp=spp, sampler=sampler, filter='box', seed=5)).image[..., 0]
    r1 = analytic()
    ref = r1[None, :].repeat(N, 0)
    sigma = np.sqrt(ref * (1 - ref) / spp)
    z = (img - ref) / np.maximum(sigma, 1e-9)
    assert np.all(img[:, r1 == 0.0] == 0.0) and np.all(img[:, r1 == 1.0] == 1.0)    # outside the sweep
    band = (r1 > 0) & (r1 < 1)
    assert band.sum() == pytest.approx(N * DIST / WIDTH, abs=1.5)
    zb = z[:, band]
    assert np.max(np.abs(zb)) < 5.0                       # no pixel beyond 5 sigma (~1e-3 of 1600 expected)
    assert np.abs(zb.mean()) < 4.0 / np.sqrt(zb.size)     # no bias: the mean z-score is ~N(0, 1/size)
    if sampler == 'independent':
        assert np.std(zb) == pytest.approx(1.0, abs=0.1)  # binomial noise, as predicted
    else:
        assert np.std(zb) < 0.5                          # stratified time: far below binomial noise
    # the column means form a straight ramp of slope (WIDTH / N) / DIST per pixel
    cols = np.nonzero(band)[0][1:-1]                     # skip the two partially-swept pixels
    slope = np.polyfit(cols, img[:, cols].mean(0), 1)[0]
    assert slope == pytest.approx(WIDTH / N / DIST, rel=0.01)


def test_more_motion_samples_on_a_straight_path_change_nothing():
    """K = 5 collinear motion samples describe the same motion as K = 2."""
    opts = RenderOptions(spp=16, sampler='sobol', filter='box', seed=1)
    a = render(moving_edge(2), opts).image
    b = render(moving_edge(5), opts).image
    assert np.max(np.abs(a - b)) < 1e-6
