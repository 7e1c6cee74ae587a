"""The same scene far from the origin and at extreme scales renders the same image (same seed).

Scene: a plane, an analytic sphere, a box and two placements of an instanced mesh sphere, lit by a
point light (tests/stability/stability_scenes.py).  Moved by (o, o/2, -o) for o = 1e3, 1e5, 1e6, or
scaled by s = 1e-4, 1e4 (point light intensity x s^2).  Measured (64x48, 8 spp): mean |diff| 0 at
1e3 and 1e5, 1e-13 at 1e6, 7e-8 at scale 1e-4 and 4e-8 at 1e4; no pixel differs by > 0.05.
Before the offset-scale fix the 1e-4 scene lost its contact shadows (3.7e-3, 2.3 % of pixels).
The path integrator (D = 8, its bounces leaving every surface with the same offsets): mean |diff| 0 at
1e3, 1e5 and 1e6 (camera-relative: the same numbers), 3e-7 at scale 1e-4 and 8e-7 at 1e4 (max 2.7e-4).
"""
import numpy as np
import pytest

from rtc.renderer.host.render import RenderOptions, render

from tests.stability.stability_scenes import compare, speckles, test_scene as build_scene, transformed


@pytest.fixture(scope='module', params=['cook', 'path'])
def opts(request):
    """Both integrators (path: light bouncing between floor, box and spheres, D = 8, Russian roulette)."""
    return RenderOptions(spp=8, sampler='sobol', seed=3, integrator=request.param)


@pytest.fixture(scope='module')
def reference(opts):
    return render(build_scene(), opts).image


@pytest.mark.parametrize('offset, scale', [(1e3, 1.0), (1e5, 1.0), (1e6, 1.0), (0.0, 1e-4), (0.0, 1e4)])
def test_far_and_scaled_scene_renders_like_the_origin_centred_one(reference, opts, offset, scale):
    img = render(transformed(build_scene(), (offset, offset / 2, -offset), scale), opts).image
    assert np.all(np.isfinite(img))
    mean_diff, frac = compare(img, reference)
    assert mean_diff < 1e-4, mean_diff          # "within noise": same seed, so only precision differs
    assert frac < 1e-3, frac                    # < 0.1 % of pixels off by more than 0.05
    assert speckles(img) <= speckles(reference) + 1e-3     # no acne, no holes


def test_the_reference_image_is_lit_and_shadowed(reference, opts):
    """Guard against a vacuous comparison: the scene has lit, shadowed and background pixels (path: the
    course's Lambertian as a Lambert BRDF, kd / pi, so its direct light is 1 / pi of cook's)."""
    y = reference.mean(axis=2) * (np.pi if opts.integrator == 'path' else 1.0)
    assert (y > 0.3).mean() > 0.2 and ((y > 0) & (y < 0.05)).mean() > 0.01
