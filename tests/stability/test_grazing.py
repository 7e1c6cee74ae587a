"""Grazing rays: an orthographic camera and a distant light almost parallel to a plane.

With parallel camera rays and a parallel light every visible point of a Lambertian plane has the same
value kd E sin(elevation of the light) (the course's Lambertian, `cook`; kd / pi E sin(elevation) in `path`,
which reads it as a Lambert BRDF of albedo kd: the plane is all there is, so no light bounces back), so any
black speckle (self-intersection of the camera or
shadow ray, a crack between the grid's triangles) shows as a deviation.  Both a 2-triangle quad and
a 100 x 100-cell grid (20 000 triangles, shared edges) are tested.
"""
import math

import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host.render import RenderOptions, render

from tests.renderer.handmade import scene

KD, E = 0.5, 1.0
W_PX, H_PX = 96, 24


def grid(cells, half):
    xs = np.linspace(-half, half, cells + 1)
    X, Z = np.meshgrid(xs, xs)
    pts = np.stack([X.ravel(), np.zeros(X.size), Z.ravel()], 1)
    i = np.arange(cells)[:, None] * (cells + 1) + np.arange(cells)[None, :]
    a, b, c, d = i, i + 1, i + cells + 1, i + cells + 2
    tris = np.concatenate([np.stack([a, c, d], -1).reshape(-1, 3), np.stack([a, d, b], -1).reshape(-1, 3)])
    return D.Mesh('/grid', points=pts, triangles=tris.astype(np.int32), material=0)


def grazing_scene(cam_deg, light_deg, cells):
    a = math.radians(cam_deg)
    dist = 100.0
    h = dist * math.sin(a)                         # film height: rays start between h/2 and 3h/2 above
    m = np.eye(4)
    m[:3, 0] = (0, 0, 1)
    m[:3, 1] = (math.sin(a), math.cos(a), 0)
    m[:3, 2] = (-math.cos(a), math.sin(a), 0)
    m[:3, 3] = (-dist * math.cos(a), dist * math.sin(a), 0)
    cam = D.Camera('/cam', matrix=m, projection='orthographic', horizontal_aperture=4 * h, vertical_aperture=h)
    e = math.radians(light_deg)
    w = np.array([0.6 * math.cos(e), math.sin(e), 0.8 * math.cos(e)])     # towards the light
    lm = np.eye(4)
    lm[:3, 2] = w
    lm[:3, 0] = np.cross((0, 1, 0), w) / np.linalg.norm(np.cross((0, 1, 0), w))
    lm[:3, 1] = np.cross(w, lm[:3, 0])
    light = D.Light('/sun', D.DISTANT, lm, (E, E, E))
    lam = D.Material('/l', model=D.LAMBERTIAN, diffuse=(KD, KD, KD))
    return scene([D.Container('/', meshes=[grid(cells, 400.0)])], [lam], [light], cam, width=W_PX, height=H_PX)


@pytest.mark.parametrize('integrator', ['cook', 'path'])
@pytest.mark.parametrize('cells', [1, 100])
@pytest.mark.parametrize('cam_deg, light_deg', [(1.0, 10.0), (0.1, 1.0), (0.01, 0.1), (0.01, 0.01)])
def test_grazing_plane_is_uniform(cells, cam_deg, light_deg, integrator):
    img = render(grazing_scene(cam_deg, light_deg, cells),
                 RenderOptions(spp=4, sampler='sobol', integrator=integrator)).image[..., 0]
    expected = KD * E * math.sin(math.radians(light_deg)) / (math.pi if integrator == 'path' else 1.0)
    dark = float((img < 0.5 * expected).mean())
    assert dark == 0.0, f'{dark:.2%} dark pixels'
    assert np.max(np.abs(img / expected - 1)) < 1e-5
