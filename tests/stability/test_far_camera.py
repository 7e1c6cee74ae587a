"""A camera far from its subject (a telephoto shot) renders what a near one renders.

The stability scene (a plane, an analytic sphere, a box, two placements of an instanced mesh sphere, a
point light) seen by an orthographic camera 10 units away and by the same camera moved back along its axis to
10^3, 10^4 and 10^5 units: in exact arithmetic the same image.  The float32 numbers Embree sees are relative
to a float origin; at the camera (as for a near shot) a surface 10^4 away sits at float32 steps of 10^-3 and
the rays leaving it (shadow, bounce) start from such numbers.  Measured (64 x 48, 8 spp), pixels off by more
than 0.05 at 10^3 / 10^4 / 10^5: with the origin at the camera 0.16 % / 1.2 % / 6.7 % (cook), 0 / 0.55 % /
6.7 % (path); with `float_origin` (the point of the scene's bounds nearest a far camera) 0.065 % / 0.098 % /
0.46 % (cook), 0 / 0.033 % / 0.13 % (path), mean |diff| <= 8.5e-4.
"""
import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host.build import FAR_OUTSIDE, float_origin
from rtc.renderer.host.render import RenderOptions, render

from tests.renderer.handmade import look_at
from tests.stability.stability_scenes import compare, speckles, test_scene as build_scene

TARGET = np.array([0.0, 0.6, 0.0])
AXIS = np.array([0.5, 3.5, 8.0]) - TARGET
AXIS /= np.linalg.norm(AXIS)


def seen_from(distance: float) -> D.SceneDescription:
    desc = build_scene()
    desc.camera = D.Camera('/cam', matrix=look_at(TARGET + distance * AXIS, TARGET), projection='orthographic',
                           horizontal_aperture=8.0, vertical_aperture=6.0, clip_near=1e-3)
    return desc


@pytest.fixture(scope='module', params=['cook', 'path'])
def opts(request):
    return RenderOptions(spp=8, sampler='sobol', seed=3, integrator=request.param)


@pytest.fixture(scope='module')
def reference(opts):
    return render(seen_from(10.0), opts).image


@pytest.mark.parametrize('distance, max_frac', [(1e3, 2.5e-3), (1e4, 2.5e-3), (1e5, 1e-2)])
def test_a_far_orthographic_camera_renders_what_a_near_one_renders(reference, opts, distance, max_frac):
    img = render(seen_from(distance), opts).image
    assert np.all(np.isfinite(img))
    mean_diff, frac = compare(img, reference)
    assert frac < max_frac, frac                # origin at the camera: 1.2 % (cook) / 0.55 % (path) at 1e4
    assert mean_diff < 2e-3, mean_diff
    assert speckles(img) <= speckles(reference) + 2e-3


def test_the_reference_is_lit_and_shadowed(reference, opts):
    y = reference.mean(axis=2) * (np.pi if opts.integrator == 'path' else 1.0)
    assert (y > 0.3).mean() > 0.2 and ((y > 0) & (y < 0.05)).mean() > 0.01


def _one_box(center, half):
    """world (1 instance, 1 motion key), in_proto, centers, radii of one object of bounding radius `half`."""
    world = np.eye(4)[None, None].copy()
    world[0, 0, :3, 3] = center
    return world, np.array([0]), np.zeros((1, 3)), np.array([half])


def test_the_float_origin_is_the_camera_unless_the_camera_is_far_outside():
    world, in_proto, centers, radii = _one_box([100.0, 0.0, 0.0], 1.0)     # bounds [99, 101] x [-1, 1]^2
    diag = 2 * np.sqrt(3.0)
    near = np.array([100.0, 0.0, 1.0 + 0.99 * FAR_OUTSIDE * diag])
    assert np.array_equal(float_origin(near, world, in_proto, centers, radii), near)
    inside = np.array([100.5, 0.2, -0.3])
    assert np.array_equal(float_origin(inside, world, in_proto, centers, radii), inside)
    far = np.array([1e5, 0.5, -1e4])
    assert np.array_equal(float_origin(far, world, in_proto, centers, radii), [101.0, 0.5, -1.0])
    # a scene with nothing placed, or only non-finite placements, keeps the camera
    assert np.array_equal(float_origin(far, world[:0], in_proto[:0], centers, radii), far)
    bad = world.copy()
    bad[0, 0, 0, 3] = np.inf
    assert np.array_equal(float_origin(far, bad, in_proto, centers, radii), far)
