"""Shadow terminator on a low-poly sphere with smooth normals, lit from the side.

A 12 x 6 UV sphere (smooth per-corner normals), orthographic view, a far point light at 90 degrees to
the view.  A convex mesh cannot shadow itself on the side its facets turn to the light, so every
pixel whose facet faces the light (n_facet . l > 0.05) must show kd E (n_shading . l), the smooth
shading: no black faceted acne between the smooth terminator and the geometric one.  Both integrators:
`path` reads the course's Lambertian as a Lambert BRDF of albedo kd (kd / pi E (n_shading . l)), and its
light cannot bounce back to a convex mesh alone in the scene.  The expected
values come from an independent numpy ray/triangle intersection (Moller-Trumbore) of pixel centres.
"""
import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host.render import RenderOptions, render

from tests.renderer.handmade import scene, translate
from tests.stability.stability_scenes import uv_sphere

N, FILM, KD = 64, 2.4, 0.8


def intersect(o, d, tri):
    """Closest hit of parallel rays (origins o (n,3), direction d) with triangles (m,3,3):
    -> (triangle index or -1, barycentrics u, v)."""
    v0, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    p = np.cross(d, e2)
    det = (e1 * p).sum(1)
    s = o[:, None, :] - v0[None]
    u = (s * p[None]).sum(2) / det
    q = np.cross(s, e1[None])
    v = (q * d).sum(2) / det
    t = (q * e2[None]).sum(2) / det
    ok = (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0) & (np.abs(det) > 1e-12)
    t = np.where(ok, t, np.inf)
    k = np.argmin(t, 1)
    hit = np.isfinite(t[np.arange(len(o)), k])
    return np.where(hit, k, -1), u[np.arange(len(o)), k], v[np.arange(len(o)), k]


@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_no_faceted_acne_on_the_lit_side(integrator):
    mesh = uv_sphere(12, 6, 1.0, material=0)
    lam = D.Material('/l', model=D.LAMBERTIAN, diffuse=(KD, KD, KD))
    cam = D.Camera('/cam', matrix=translate(0, 0, 10), projection='orthographic', horizontal_aperture=FILM,
                   vertical_aperture=FILM)
    L = np.array([1.0, 0.25, 0.0])
    L /= np.linalg.norm(L)
    dist, I = 1000.0, 1e6                                # E = I / dist^2 = 1 at the sphere
    light = D.Light('/pt', D.POINT, translate(*(dist * L)), (I, I, I))
    img = render(scene([D.Container('/', meshes=[mesh])], [lam], [light], cam, width=N, height=N),
                 RenderOptions(spp=16, sampler='sobol', filter='box', integrator=integrator)).image[..., 0]
    img = img * (np.pi if integrator == 'path' else 1.0)            # Lambert's 1 / pi
    # pixel-centre rays of the orthographic camera; only pixels whose four corners hit the same
    # triangle, where the shading is smooth and the box-filtered pixel is close to its centre value
    tri = mesh.points[mesh.triangles]
    c = -FILM / 2 + FILM * (np.arange(N) + 0.5) / N
    X, Y = np.meshgrid(c, -c)
    o = np.stack([X.ravel(), Y.ravel(), np.full(X.size, 10.0)], 1)
    d = np.array([0.0, 0.0, -1.0])
    k, u, v = intersect(o, d, tri)
    half = FILM / N / 2
    same = np.ones(len(o), bool)
    for dx, dy in ((-1, -1), (-1, 1), (1, -1), (1, 1)):
        kk, _, _ = intersect(o + 0.999 * half * np.array([dx, dy, 0.0]), d, tri)
        same &= kk == k
    hit = (k >= 0) & same
    nf = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    nf /= np.linalg.norm(nf, axis=1)[:, None]
    nn = mesh.normals.astype(np.float64)
    ns = (1 - u - v)[:, None] * nn[k, 0] + u[:, None] * nn[k, 1] + v[:, None] * nn[k, 2]
    ns /= np.linalg.norm(ns, axis=1)[:, None]
    facet_lit = hit & ((nf[k] @ L) > 0.05)
    expected = KD * np.maximum(ns @ L, 0.0)
    value = img.ravel()
    assert facet_lit.sum() > 300
    dark = (value < 0.5 * expected) & facet_lit & (expected > 0.02)
    assert dark.sum() == 0, f'{dark.sum()} dark pixels on facets facing the light'
    # and the lit side carries the smooth shading (pixel-sample jitter moves the value a little)
    ok = facet_lit & (expected > 0.05)
    rel = np.abs(value[ok] / expected[ok] - 1)
    assert np.median(rel) < 0.01 and np.max(rel) < 0.1, (np.median(rel), np.max(rel))
    # facets turned away from the light are black (the integrator needs wi . n_geometric > 0)
    away = hit & ((nf[k] @ L) < -0.05)
    assert away.sum() > 300 and np.all(value[away] == 0.0)
