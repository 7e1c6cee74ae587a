"""The path integrator's rays leaving surfaces, on hard cases: the white furnace far from the origin, at
extreme scales, inside an instance, and inside a finely tessellated sphere.

A closed diffuse enclosure of albedo rho whose walls emit Le has radiance L = Le (1 - rho^(D+1)) / (1 - rho)
everywhere with D bounces (tests/accuracy/test_path_closed_forms.py).  Two estimates of it:

* BSDF sampling alone at D = 2: every path has exactly that value, so every pixel must equal it to float
  rounding.  A continuation ray that slips out through a crack or an edge, or that starts behind its
  wall (an offset pushed the wrong way) and escapes, ends its path with less: one such path in a pixel's
  samples shows.
* light samples and BSDF samples, MIS-weighted (the default), D = 3: the walls are 12 emissive triangles
  (the box) or 4,096 (the sphere), chosen by the light tree; a shadow ray between two points on walls that
  wrongly finds an occluder (acne at either end) darkens the mean, so the mean must be within 0.5 % of
  the closed form.

The enclosure is moved by up to 1e6, scaled by 1e-4 and 1e4, and placed as an instance (its container
placed twice: the path integrator keeps the instances), so that the rays meet it through an instance
transform.
"""
import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host.render import RenderOptions, Renderer
from tests.renderer.handmade import look_at, scene
from tests.stability.stability_scenes import box_mesh, uv_sphere

RHO, LE = 0.5, 1.0


def _affine(offset, scale):
    g = np.diag([scale, scale, scale, 1.0])
    g[:3, 3] = offset
    return g


def enclosure(shape, offset=(0.0, 0.0, 0.0), scale=1.0, instanced=False):
    """The furnace: a 2 x 2 x 2 box or a radius-1 sphere of 4,096 triangles about the origin, mapped by
    p -> scale p + offset (in its points, or by its placement when `instanced`), with the camera inside
    it (looking at a corner, so that edges and vertices are in view)."""
    wall = D.Material('/wall', model=D.LAMBERTIAN, diffuse=(RHO,) * 3, emission=(LE,) * 3)
    mesh = box_mesh((-1, -1, -1), (1, 1, 1)) if shape == 'box' else uv_sphere(64, 33, 1.0, smooth=False)
    g = _affine(offset, scale)
    if instanced:
        far = _affine(np.asarray(offset) + 10.0 * scale, scale)        # a second placement, outside the first
        inst = D.Instances(container=np.zeros(2, np.int32), matrices=np.stack([g, far])[:, None],
                           material_set=np.zeros(2, np.int32), material_sets=[()])
    else:
        mesh.points = mesh.points * scale + np.asarray(offset, np.float64)
        inst = None
    cam = look_at((0.1, 0.2, 0.3), (1.0, -0.6, -0.8))
    cam = g @ cam @ np.diag([1 / scale, 1 / scale, 1 / scale, 1.0])      # moved and scaled, its frame orthonormal
    return scene([D.Container('/', meshes=[mesh])], [wall], [], D.Camera(path='/cam', matrix=cam,
                                                                          clip_near=0.01 * scale),
                 instances=inst, width=32, height=32)


def closed_form(depth):
    return LE * (1 - RHO ** (depth + 1)) / (1 - RHO)


CASES = {
    'box at the origin': ('box', (0.0, 0.0, 0.0), 1.0, False),
    'box at 1e5': ('box', (1e5, 5e4, -1e5), 1.0, False),
    'box at 1e6': ('box', (1e6, 5e5, -1e6), 1.0, False),
    'box scaled 1e-4': ('box', (0.0, 0.0, 0.0), 1e-4, False),
    'box scaled 1e4': ('box', (0.0, 0.0, 0.0), 1e4, False),
    'box instanced at 1e6': ('box', (1e6, 5e5, -1e6), 1.0, True),
    'box instanced, scaled 1e-4': ('box', (3e-4, 0.0, 0.0), 1e-4, True),
    'sphere at the origin': ('sphere', (0.0, 0.0, 0.0), 1.0, False),
    'sphere at 1e5, scaled 1e-2': ('sphere', (1e5, -1e5, 2e5), 1e-2, False),
    'sphere instanced at 1e5': ('sphere', (1e5, -1e5, 2e5), 1.0, True),
}


@pytest.mark.parametrize('case', list(CASES))
def test_no_path_leaves_the_furnace(case):
    shape, offset, scale, instanced = CASES[case]
    with Renderer(enclosure(shape, offset, scale, instanced)) as r:
        bsdf = r.render(RenderOptions(spp=8, integrator='path', max_depth=2, strategy='bsdf',
                                      sampler='independent', seed=5)).image
        mis = r.render(RenderOptions(spp=64, integrator='path', max_depth=3, sampler='sobol', seed=5)).image
    assert np.isfinite(bsdf).all() and np.isfinite(mis).all()
    # every path of BSDF sampling alone has the closed form's value: none leaked, none started behind its wall
    np.testing.assert_allclose(bsdf, closed_form(2), rtol=1e-5)
    # light and BSDF samples: no shadow ray between two walls of a convex enclosure finds an occluder
    assert mis.mean() == pytest.approx(closed_form(3), rel=0.005), mis.mean()


def test_a_leak_would_show():
    """Guard against a vacuous test: the same box with one face missing (2 of its 12 triangles) loses the
    paths that leave through the hole, in the pixels that see it and in the rest."""
    desc = enclosure('box')
    mesh = desc.containers[0].meshes[0]
    mesh.triangles = mesh.triangles[2:]
    with Renderer(desc) as r:
        bsdf = r.render(RenderOptions(spp=8, integrator='path', max_depth=2, strategy='bsdf',
                                      sampler='independent', seed=5)).image
    low = bsdf < closed_form(2) * (1 - 1e-5)
    assert low.mean() > 0.5                  # (measured: 92 % of the pixels)
