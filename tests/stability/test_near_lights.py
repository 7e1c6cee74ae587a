"""Area lights at the edges of float32: almost touching the surface they light, a millionth of a unit wide,
a thousand units away; the path integrator against closed forms.

A Lambert plane (albedo 0.5, `path`: f = 0.5 / pi) seen from 5 units above by an orthographic camera, lit by
* a rect light (1.2 x 0.8, facing down) at heights 1e-2 .. 2e-4, and one standing on the plane (1e-3 above it, and
  touching it), lighting it at every angle down to grazing: Lambert's polygon formula;
* a disk light (radius 0.5) parallel to the plane: E = pi L / 2 (1 - (h^2 + x^2 - R^2) / sqrt((h^2 + x^2 +
  R^2)^2 - 4 R^2 x^2)) at horizontal distance x from its axis;
* a sphere light (radius 0.5) whose surface is h above the plane: E = pi L (r / d)^2 cos theta where the
  sphere is wholly above the horizon (the camera's window is kept to those points);
* a rect light 1e-6 wide (radiance 1e12) and one 1e3 away (radiance 2e6): a point source's L A cos cos /
  d^2; sphere lights of radius 1e-7 and 1e-9 at distance 1 (a unit point source's power); distant lights of
  angular diameter 0.53, 1e-4 and 1e-8 degrees: E cos.
Each by light and BSDF samples with MIS (the default), and by BSDF samples alone (the rays must find the
light's shape: the hit test that confirms Embree's crossing against the exact shape must allow for
Embree's float32 error, which near the light is larger than a relative tolerance: before the fix 2.6-4 %
of the light of a rect 5e-4 .. 2e-4 above the plane was lost), and the solid angle of a narrow cone must
not be computed as 1 - cos (a sphere light of r / d = 1e-7 was 1.4 % too bright, one of 1e-8 stopped the
render with a ZeroDivisionError).
"""
import math

import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host.render import RenderOptions, Renderer
from tests.renderer import test_integrator as ti
from tests.renderer.handmade import ortho_down, quad, rect_light, scene, translate

N, KD = 16, 0.5


def _facing_down(center):
    m = np.eye(4)
    m[:3, 1] = (0, 0, -1)
    m[:3, 2] = (0, 1, 0)                 # local +Z = +Y: emits along -Y
    m[:3, 3] = center
    return m


def render_plane(light, width, strategy, spp):
    lam = D.Material('/lambert', model=D.LAMBERTIAN, diffuse=(KD,) * 3)
    desc = scene([D.Container('/', meshes=[quad(40.0)])], [lam], [light], ortho_down(width=width), width=N, height=N)
    with Renderer(desc) as r:
        img = r.render(RenderOptions(spp=spp, integrator='path', strategy=strategy, filter='box', max_depth=1,
                                     seed=7)).image
    assert np.isfinite(img).all()
    return img[..., 0]


def rect_case(h, a=1.2, b=0.8, L=2.0):
    corners = [(-a / 2, h, -b / 2), (a / 2, h, -b / 2), (a / 2, h, b / 2), (-a / 2, h, b / 2)]
    return rect_light((0.0, h, 0.0), a, b, (L,) * 3), 4.0, lambda x, z: ti.polygon_irradiance(x, z, corners, L)


def small_rect_case(h, a, L):
    def irradiance(x, z):
        d2 = x * x + z * z + h * h
        return L * a * a * h * h / d2 ** 2
    return rect_light((0.0, h, 0.0), a, a, (L,) * 3), 4.0, irradiance


def upright_rect_case(gap, x0=1.0, a=1.0, b=1.5, L=2.0):
    """A rect light standing on the plane (its lower edge `gap` above it, in the plane x = x0), emitting
    towards -x: the points before it see it at every angle down to grazing along its lower edge; those
    behind it see nothing."""
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = (0, 0, -1), (0, 1, 0), (1, 0, 0), (x0, gap + a / 2, 0)
    corners = [(x0, gap, -b / 2), (x0, gap, b / 2), (x0, gap + a, b / 2), (x0, gap + a, -b / 2)]
    return (D.Light('/upright', D.RECT, m, (L,) * 3, width=b, height=a), 4.0,
            lambda x, z: np.where(x < x0, ti.polygon_irradiance(x, z, corners, L), 0.0))


def disk_case(h, R=0.5, L=2.0):
    def irradiance(x, z):
        s2 = x * x + z * z
        return math.pi * L / 2 * (1 - (h * h + s2 - R * R) / np.sqrt((h * h + s2 + R * R) ** 2 - 4 * R * R * s2))
    return D.Light('/disk', D.DISK, _facing_down((0.0, h, 0.0)), (L,) * 3, radius=R), 1.2, irradiance


def sphere_case(gap, r=0.5, L=2.0):
    c = r + gap

    def irradiance(x, z):
        d2 = x * x + z * z + c * c
        return math.pi * L * r * r / d2 * (c / np.sqrt(d2))
    # the window's corner (0.2, 0, 0.2) sees the sphere wholly above its horizon: elevation of the centre
    # atan(c / 0.283) = 60.5 deg > its angular radius asin(r / d) = 59.6 deg (for gap 1e-3; more for less)
    return D.Light('/sphere', D.SPHERE, translate(0.0, c, 0.0), (L,) * 3, radius=r), 0.4, irradiance


def small_sphere_case(r, d=1.0):
    """A sphere light of radius r at distance d whose power stays that of a unit point source (L pi r^2 = 1):
    1 - cos of its cone's half-angle is ~r^2 / 2 d^2, which 1 - sqrt(1 - r^2 / d^2) computes to 1.4 % at
    r / d = 1e-7 and to 0 at 1e-8 (a division by zero, before the fix)."""
    L = 1.0 / (math.pi * r * r)
    c = d + r

    def irradiance(x, z):
        d2 = x * x + z * z + c * c
        return math.pi * L * r * r / d2 * (c / np.sqrt(d2))
    return D.Light('/sphere', D.SPHERE, translate(0.0, c, 0.0), (L,) * 3, radius=r), 4.0, irradiance


def sun_case(angle, elevation=60.0):
    """A distant light of angular diameter `angle` (degrees) and irradiance 1: E = sin(elevation)."""
    e = math.radians(elevation)
    w = np.array([0.0, math.sin(e), math.cos(e)])
    m = np.eye(4)
    m[:3, 0], m[:3, 2] = (1.0, 0.0, 0.0), w
    m[:3, 1] = np.cross(w, m[:3, 0])
    return D.Light('/sun', D.DISTANT, m, (1.0,) * 3, angle=angle), 4.0, lambda x, z: np.full_like(x, math.sin(e))


CASES = {
    'rect 1e-2 above': rect_case(1e-2),
    'rect 1e-3 above': rect_case(1e-3),
    'rect 5e-4 above': rect_case(5e-4),
    'rect 2e-4 above': rect_case(2e-4),
    'rect upright, 1e-3 above': upright_rect_case(1e-3),
    'rect upright, touching': upright_rect_case(0.0),
    'disk 5e-4 above': disk_case(5e-4),
    'sphere 1e-3 above': sphere_case(1e-3),
    'sphere 2e-4 above': sphere_case(2e-4),
    'rect 1e-6 wide': small_rect_case(1.0, 1e-6, 1e12),
    'rect 1e3 away': small_rect_case(1e3, 1.2, 2e6),
    'sphere r/d 1e-7': small_sphere_case(1e-7),
    'sphere r/d 1e-9': small_sphere_case(1e-9),
    'sun 0.53 deg': sun_case(0.53),
    'sun 1e-4 deg': sun_case(1e-4),
    'sun 1e-8 deg': sun_case(1e-8),
}
# lights of 1e-5 of the sky or less (the sun: 6.7e-5 sr): BSDF samples alone find them too rarely to test
TINY = ('rect 1e-6 wide', 'rect 1e3 away', 'sphere r/d 1e-7', 'sphere r/d 1e-9', 'sun 0.53 deg', 'sun 1e-4 deg',
        'sun 1e-8 deg')


@pytest.mark.parametrize('case, strategy', [(c, 'mis') for c in CASES] + [(c, 'bsdf') for c in CASES if c not in TINY])
def test_area_light_at_the_edge_of_float32(case, strategy):
    light, width, irradiance = CASES[case]
    ref = ti.pixel_average(lambda x, z: KD / np.pi * irradiance(x, z), N, width, sub=24)
    img = render_plane(light, width, strategy, 256 if strategy == 'mis' else 1024)
    if light.type == D.SPHERE and light.radius > 0.1:
        # the camera sees the plane through the sphere (a light shape occludes nothing) and the sphere's own
        # radiance in front of it, in every pixel
        img = img - light.radiance[0]
    assert img.mean() == pytest.approx(ref.mean(), rel=0.005), (img.mean() / ref.mean())
    assert np.sqrt(np.mean((img - ref) ** 2)) < 0.02 * ref.max()


@pytest.mark.parametrize('r', [0.1, 1e-4, 1e-7])
def test_a_linear_curves_round_end_far_and_tiny(r):
    """An emissive linear curve of one segment of length 0 is a sphere (Embree's round end), which the path integrator
    samples as its round end's light, in the cone of directions that meet it: of power pi^2 r^2 L = pi (L = 1 / (pi
    r^2), a unit point source), at height 1 beside the camera's window, it lights the plane with
    E = pi L (r / d)^2 cos theta at every point (wholly above their horizon) down to r / d = 2e-8, where the cone's
    1 - cos is 5e-15 (computed as sin^2 / (1 + cos), not 1 - cos)."""
    c, x0, L = 1.0 + r, 2.5, 1.0 / (math.pi * r * r)
    lam = D.Material('/lambert', model=D.LAMBERTIAN, diffuse=(KD,) * 3)
    glow = D.Material('/glow', diffuse=(0.0, 0.0, 0.0), emission=(L, L, L))
    dot = D.Curves('/dot', vertices=np.array([[x0, c, 0.0, r], [x0, c, 0.0, r]]), segments=np.array([0]), linear=True,
                   material=1, flags=np.zeros(1, np.uint8))
    desc = scene([D.Container('/', meshes=[quad(40.0)], curves=[dot])], [lam, glow], [], ortho_down(width=4.0),
                 width=N, height=N)
    with Renderer(desc) as rr:
        img = rr.render(RenderOptions(spp=256, integrator='path', filter='box', max_depth=1, seed=7)).image[..., 0]

    def irradiance(x, z):
        d2 = (x - x0) ** 2 + z * z + c * c
        return math.pi * L * r * r / d2 * (c / np.sqrt(d2))
    ref = ti.pixel_average(lambda x, z: KD / np.pi * irradiance(x, z), N, 4.0, sub=24)
    assert np.isfinite(img).all()
    assert img.mean() == pytest.approx(ref.mean(), rel=0.005), (img.mean() / ref.mean())
    assert np.sqrt(np.mean((img - ref) ** 2)) < 0.02 * ref.max()
