"""Thin-lens depth of field against the circle of confusion (Cook et al. 1984; pbrt-v4 sec. 5.2.3).

A small emissive sphere on the optical axis, off the plane of focus, black background, no lights.
Through a thin lens of radius R focused at distance F, a point at distance z images to a uniform disk
whose radius on the film (in units of the film-plane-at-distance-1 coordinate the camera uses) is

    rho = R |z - F| / (z F).

The sphere itself images (pinhole) to a uniform disk of radius s = a / sqrt(z^2 - a^2), so the
rendered spot is the convolution of two uniform disks with the pixel box: its second moment about
the centroid is  rho^2/2 + s^2/2 + 1/6 px^2  (moments add under convolution).  We also check the
plateau value L (s/rho)^2 inside r < rho - s and that the lens conserves the total flux L pi s^2.
"""
import math

import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host.render import RenderOptions, render

from tests.renderer.handmade import look_at, scene, static_instances, translate

N = 96                   # image side, pixels
HALF_W = 0.5             # film half width at distance 1 (focal length 1, aperture 1)
L_EMIT = 4.0


def spot(z, radius, lens_radius, focus, spp=256, sampler='sobol'):
    glow = D.Material('/glow', model=D.PREVIEW_SURFACE, diffuse=(0, 0, 0), emission=(L_EMIT,) * 3)
    cont = D.Container('/p', spheres=[D.Sphere('/p/s', radius, np.eye(4), material=0)])
    cam = D.Camera('/cam', matrix=look_at((0, 0, 0), (0, 0, -1)), focal_length=1.0, horizontal_aperture=1.0,
                   vertical_aperture=1.0, lens_radius=lens_radius, focus_distance=focus)
    desc = scene([cont], [glow], [], cam, instances=static_instances(matrices=[translate(0, 0, -z)]),
                 width=N, height=N)
    return render(desc, RenderOptions(spp=spp, sampler=sampler, filter='box', max_depth=0)).image[..., 0]


def moments(img):
    c = np.arange(N) + 0.5
    X, Y = np.meshgrid(c, c)
    w = img.sum()
    cx, cy = (img * X).sum() / w, (img * Y).sum() / w
    return w, cx, cy, (img * ((X - cx) ** 2 + (Y - cy) ** 2)).sum() / w


@pytest.mark.parametrize('z, focus, lens', [(10.0, 2.0, 0.5),      # far behind the plane of focus
                                            (2.0, 10.0, 0.5)])     # in front of it
def test_blur_disk_is_the_thin_lens_circle_of_confusion(z, focus, lens):
    a = 0.04 * z                                   # source disk ~4 px in radius
    img = spot(z, a, lens, focus)
    px = N / (2 * HALF_W)                          # pixels per film unit
    rho = lens * abs(z - focus) / (z * focus) * px
    s = a / math.sqrt(z * z - a * a) * px
    assert rho > 16 and s < rho / 4           # a real blur, much wider than the source
    w, cx, cy, m2 = moments(img)
    assert (cx, cy) == pytest.approx((N / 2, N / 2), abs=0.3)    # noise ~0.12 px
    rho_measured = math.sqrt(2 * (m2 - s * s / 2 - 1 / 6))
    assert rho_measured == pytest.approx(rho, rel=0.02)              # measured within 0.8 %
    # the lens conserves flux: total = L * area of the pinhole image (pixels)
    assert w == pytest.approx(L_EMIT * math.pi * s * s, rel=0.02)      # measured within 0.6 %
    # a flat top of height L (s / rho)^2 inside r < rho - s, nothing beyond rho + s + 1 px
    c = np.arange(N) + 0.5
    R = np.hypot(*np.meshgrid(c - N / 2, c - N / 2))
    plateau = img[R < 0.8 * (rho - s)].mean()
    assert plateau == pytest.approx(L_EMIT * (s / rho) ** 2, rel=0.04)  # measured within 1.5 %
    assert img[R > rho + s + 1.5].max() == 0.0


def test_in_focus_point_stays_sharp():
    """The same source on the plane of focus: the spot is the pinhole image (no blur)."""
    z = 4.0
    a = 0.04 * z
    img = spot(z, a, 0.5, z, spp=64)
    px = N / (2 * HALF_W)
    s = a / math.sqrt(z * z - a * a) * px
    _, _, _, m2 = moments(img)
    assert math.sqrt(2 * (m2 - 1 / 6)) == pytest.approx(s, rel=0.02)
