"""Degenerate and sliver triangles, zero-area faces and duplicated vertices render like the clean mesh.

The dirty mesh is the clean one (a flat-shaded UV sphere) with: every vertex duplicated and half the
triangles re-indexed to the copies (cracks if the copies were not bit-identical); one triangle split at
a point 1e-7 of the way along an edge (a sliver and a near-copy); zero-area faces (a repeated index,
three collinear points, three identical points).  No pixel may be NaN/Inf, and the image must equal
the clean one: mean |diff| < 1e-5 and no pixel off by more than 0.05.
"""
import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host.render import RenderOptions, render

from tests.renderer.handmade import look_at, point_light, quad, scene
from tests.stability.stability_scenes import compare, uv_sphere


def dirty(mesh):
    p = mesh.points
    n = len(p)
    pts = np.concatenate([p, p])                                  # duplicated vertices
    tris = mesh.triangles.copy()
    tris[::2] += n                                                # half the triangles use the copies
    a, b, c = mesh.triangles[5]
    q = p[b] + 1e-7 * (p[c] - p[b])                               # split triangle 5 at a point near b
    pts = np.concatenate([pts, q[None], (0.5 * (p[a] + p[b]))[None]])
    iq, imid = len(pts) - 2, len(pts) - 1
    extra = [(a, b, iq), (a, iq, c),                              # sliver + the rest of triangle 5
             (a, a, b), (a, imid, b), (c, c, c)]                  # zero-area faces
    keep = np.ones(len(tris), bool)
    keep[5] = False
    tris = np.concatenate([tris[keep], np.array(extra, np.int32)])
    return D.Mesh(mesh.path, points=pts, triangles=tris.astype(np.int32), material=mesh.material)


@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_dirty_mesh_renders_like_the_clean_one(integrator):
    clean = uv_sphere(16, 8, 1.0, material=0, smooth=False)
    floor = quad(20.0, y=-1.0, material=0, path='/floor')
    lam = D.Material('/l', model=D.LAMBERTIAN, diffuse=(0.7, 0.7, 0.7))
    cam = D.Camera('/cam', matrix=look_at((0.3, 1.5, 4.0), (0, 0, 0)), focal_length=1.0, horizontal_aperture=1.0,
                   vertical_aperture=0.75)
    lights = [point_light((2, 4, 3), (30, 30, 30))]
    opts = RenderOptions(spp=8, sampler='sobol', seed=1, integrator=integrator)
    imgs = [render(scene([D.Container('/', meshes=[floor, m])], [lam], lights, cam, width=64, height=48), opts).image
            for m in (clean, dirty(clean))]
    assert all(np.all(np.isfinite(i)) for i in imgs)
    mean_diff, frac = compare(imgs[1], imgs[0])
    assert mean_diff < 1e-5 and np.abs(imgs[1] - imgs[0]).max() < 0.05, (mean_diff, np.abs(imgs[1] - imgs[0]).max())
