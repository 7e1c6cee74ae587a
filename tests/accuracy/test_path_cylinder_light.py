"""A CylinderLight (UsdLux: along its local X, emitting outwards from its side only) against an
independent numerical quadrature of the irradiance it gives a Lambert plane: path (light sampling alone,
BSDF sampling alone, MIS) and cook (which samples it as an area light) converge to it."""
import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host.render import RenderOptions, Renderer
from tests.renderer import test_integrator as ti
from tests.renderer.handmade import ortho_down, quad, scene, translate

N, WIDTH, H, R, LEN, LR = 24, 4.0, 0.8, 0.15, 1.6, 3.0


def cylinder(center=(0.0, H, 0.0), radius=R, length=LEN, radiance=LR, matrix=None):
    m = translate(*center) if matrix is None else matrix
    return D.Light(path='/cyl', type=D.CYLINDER, matrix=m, radiance=(radiance,) * 3, radius=radius, length=length)


def cylinder_irradiance(x, z, n_a=48, n_phi=192):
    """E at (x, 0, z), normal +Y, from the side of the cylinder along X at height H (radius R, length LEN,
    radiance LR): Gauss-Legendre along the axis, the midpoint rule around it (periodic); only points of the
    side facing the receiver emit towards it (a convex body: nothing else hides them)."""
    ga, gw = np.polynomial.legendre.leggauss(n_a)
    a = 0.5 * LEN * ga
    wa = 0.5 * LEN * gw
    phi = 2 * np.pi * (np.arange(n_phi) + 0.5) / n_phi
    A, P = np.meshgrid(a, phi, indexing='ij')
    W = (wa[:, None] * (2 * np.pi / n_phi) * R) * np.ones_like(P)      # dA = R dphi da
    qx, qy, qz = A.ravel(), (H + R * np.cos(P)).ravel(), (R * np.sin(P)).ravel()
    nx, ny, nz = 0.0, np.cos(P).ravel(), np.sin(P).ravel()
    w = W.ravel()
    out = np.empty(x.size)
    for i, (px, pz) in enumerate(zip(x.ravel(), z.ravel())):
        vx, vy, vz = qx - px, qy, qz - pz
        d2 = vx * vx + vy * vy + vz * vz
        cos_r = vy / np.sqrt(d2)
        cos_l = -(nx * vx + ny * vy + nz * vz) / np.sqrt(d2)
        out[i] = np.sum(w * np.clip(cos_r, 0, None) * np.clip(cos_l, 0, None) / d2)
    return LR * out.reshape(x.shape)


def plane_under_cylinder(width=WIDTH):
    white = D.Material('/white', model=D.LAMBERTIAN, diffuse=(1.0, 1.0, 1.0))
    return scene([D.Container('/', meshes=[quad(40.0)])], [white], [cylinder()], ortho_down(width=width),
                 width=N, height=N)


def _outside_the_light(width=WIDTH):
    """Pixels whose footprint the camera (looking down) does not see the cylinder in."""
    c = ti.pixel_centers(N, width)
    half = 0.5 * width / N
    X, Z = np.meshgrid(c, c)
    return (np.abs(Z) > R + half) | (np.abs(X) > LEN / 2 + half)


@pytest.fixture(scope='module')
def reference():
    return ti.pixel_average(lambda x, z: cylinder_irradiance(x, z) / np.pi, N, WIDTH, sub=4)


def test_the_quadrature_is_converged():
    x, z = np.array([0.0, 0.7, 1.5]), np.array([0.0, 0.3, -1.0])
    np.testing.assert_allclose(cylinder_irradiance(x, z), cylinder_irradiance(x, z, 96, 512), rtol=2e-4)


@pytest.mark.parametrize('strategy', ['mis', 'nee', 'bsdf'])
def test_plane_under_a_cylinder_light_is_the_quadrature(reference, strategy):
    spp = 512 if strategy != 'bsdf' else 4096
    with Renderer(plane_under_cylinder()) as r:
        img = r.render(RenderOptions(spp=spp, integrator='path', strategy=strategy, filter='box',
                                     sampler='sobol')).image[..., 0].astype(np.float64)
    keep = _outside_the_light()
    assert img[keep].mean() == pytest.approx(reference[keep].mean(), rel=0.01), (img[keep].mean(), reference[keep].mean())
    err = img[keep] - reference[keep]
    assert np.sqrt(np.mean(err ** 2)) < 0.03 * reference.max(), np.sqrt(np.mean(err ** 2))


def test_the_camera_sees_the_side_it_faces():
    """Looking down on the cylinder, a pixel well inside its outline shows its radiance over the floor's."""
    width = 1.0
    with Renderer(plane_under_cylinder(width)) as r:
        img = r.render(RenderOptions(spp=64, integrator='path', max_depth=0, filter='box')).image[..., 0]
    c = ti.pixel_centers(N, width)
    inside = (np.abs(c)[:, None] < R - width / N) & (np.abs(c)[None, :] < LEN / 2 - width / N)
    assert inside.sum() >= 4 * N
    np.testing.assert_allclose(img[inside], LR, rtol=1e-6)
    assert np.all(img[_outside_the_light(width)] == 0.0)


def test_cook_samples_it_as_an_area_light(reference):
    """The cook integrator's Lambertian is kd E (course semantics): pi times the path image."""
    with Renderer(plane_under_cylinder()) as r:
        img = r.render(RenderOptions(spp=256, integrator='cook', filter='box', sampler='sobol')).image[..., 0]
    keep = _outside_the_light()
    assert img[keep].mean() == pytest.approx(np.pi * reference[keep].mean(), rel=0.01)
