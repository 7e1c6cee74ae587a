"""Perfect mirror and dielectric: the kernel functions against independent float64 formulas, and the
refracted position of a feature seen through a glass slab against Snell's law."""
import math

import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.kernel.materials import fresnel_dielectric, refract
from rtc.renderer.host.render import RenderOptions, render
from rtc.renderer.kernel.vecmath import reflect

from tests.renderer.handmade import scene


def fresnel_angles(theta_i, n1, n2):
    """Textbook unpolarised Fresnel reflectance from the angles (Hecht, Optics, eq. 4.42-4.43)."""
    s = n1 / n2 * math.sin(theta_i)
    if s >= 1.0:
        return 1.0
    theta_t = math.asin(s)
    if theta_i == 0.0:
        return ((n1 - n2) / (n1 + n2)) ** 2
    rs = math.sin(theta_i - theta_t) / math.sin(theta_i + theta_t)
    rp = math.tan(theta_i - theta_t) / math.tan(theta_i + theta_t)
    return 0.5 * (rs * rs + rp * rp)


def random_frames(rng, n):
    """n random unit normals and unit incident directions with d.n < 0."""
    nrm = rng.normal(size=(n, 3))
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    d[(d * nrm).sum(1) > 0] *= -1
    return nrm, d


@pytest.mark.parametrize('eta', [1.5, 1.33, 2.4, 1 / 1.5, 1 / 1.33])
def test_fresnel_matches_the_angle_form(eta):
    for theta in np.linspace(0.0, math.pi / 2 - 1e-6, 181):
        F, cos_t = fresnel_dielectric(math.cos(theta), eta)
        assert F == pytest.approx(fresnel_angles(theta, 1.0, eta), abs=1e-10)
        s_t = math.sin(theta) / eta
        if s_t < 1.0:
            assert cos_t == pytest.approx(math.sqrt(1 - s_t * s_t), abs=1e-12)
            # energy: R + T = 1 with T = (eta cos_t / cos_i) |t|^2 ... equivalently R <= 1 and T >= 0
            assert 0.0 <= F <= 1.0
        else:
            assert F == 1.0                                  # total internal reflection


def test_fresnel_normal_incidence_and_reciprocity():
    assert fresnel_dielectric(1.0, 1.5)[0] == pytest.approx(0.04, abs=1e-12)
    # Stokes: R seen from inside at the refracted angle equals R from outside
    for theta in np.linspace(0.0, 1.5, 31):
        F, cos_t = fresnel_dielectric(math.cos(theta), 1.5)
        F_back, cos_back = fresnel_dielectric(cos_t, 1 / 1.5)
        assert F_back == pytest.approx(F, abs=1e-12) and cos_back == pytest.approx(math.cos(theta), abs=1e-12)


@pytest.mark.parametrize('eta', [1.5, 1 / 1.5])
def test_refract_obeys_snell_and_stays_in_the_plane_of_incidence(eta):
    rng = np.random.default_rng(3)
    nrm, d = random_frames(rng, 2000)
    done = 0
    for n, v in zip(nrm, d):
        cos_i = -float(v @ n)
        F, cos_t = fresnel_dielectric(cos_i, eta)
        if F == 1.0:
            continue
        t = np.array(refract(tuple(v), tuple(n), eta, cos_i, cos_t))
        sin_i = np.linalg.norm(np.cross(v, n))
        sin_t = np.linalg.norm(np.cross(t, n))
        assert np.linalg.norm(t) == pytest.approx(1.0, abs=1e-12)
        assert 1.0 * sin_i == pytest.approx(eta * sin_t, abs=1e-10)          # Snell: n1 sin i = n2 sin t
        assert float(t @ n) == pytest.approx(-cos_t, abs=1e-10)              # goes through, at angle t
        assert float(np.cross(v, n) @ t) == pytest.approx(0.0, abs=1e-10)    # coplanar with v and n
        # tangential components are parallel and scaled by 1/eta
        tan_v = v - (v @ n) * n
        tan_t = t - (t @ n) * n
        assert np.allclose(tan_t, tan_v / eta, atol=1e-10)
        done += 1
    assert done > 500


def test_reflect_is_the_mirror_image():
    rng = np.random.default_rng(4)
    nrm, d = random_frames(rng, 1000)
    for n, v in zip(nrm, d):
        r = np.array(reflect(tuple(v), tuple(n)))
        ref = v - 2 * (v @ n) * n                    # Householder reflection, float64
        H = np.eye(3) - 2 * np.outer(n, n)
        assert np.allclose(r, ref, atol=1e-14) and np.allclose(r, H @ v, atol=1e-12)
        assert float(r @ n) == pytest.approx(-float(v @ n), abs=1e-12)   # angle in = angle out


# ----------------------------------------------------------------------------- image level
THETA = math.radians(40.0)
IOR, THICK = 1.5, 1.0
N, FILM = 128, 2.0


def slab_scene(with_slab=True):
    """Emissive half-plane x < 0 on y = 0; glass slab 1 <= y <= 2; orthographic camera looking along
    d = (sin t, -cos t, 0), film x axis u = (cos t, sin t, 0), centred on the floor point x = 0."""
    glow = D.Material('/glow', model=D.PREVIEW_SURFACE, diffuse=(0, 0, 0), emission=(1.0, 1.0, 1.0))
    glass = D.Material('/glass', model=D.DIELECTRIC, ior=IOR)
    half = D.Mesh('/half', points=np.array([[-30, 0, -30], [0, 0, -30], [0, 0, 30], [-30, 0, 30]], float),
                  triangles=np.array([[0, 2, 1], [0, 3, 2]], np.int32), material=0)
    lo, hi = np.array([-30, 1.0, -30]), np.array([30, 1.0 + THICK, 30])
    p = np.array([[(hi if i & 4 else lo)[0], (hi if i & 2 else lo)[1], (hi if i & 1 else lo)[2]] for i in range(8)])
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = np.array([t for f in faces for t in ((f[0], f[1], f[2]), (f[0], f[2], f[3]))], np.int32)
    slab = D.Mesh('/slab', points=p.astype(float), triangles=tris, material=1)
    s, c = math.sin(THETA), math.cos(THETA)
    m = np.eye(4)
    m[:3, 0] = (c, s, 0)
    m[:3, 1] = (0, 0, -1)
    m[:3, 2] = (-s, c, 0)
    m[:3, 3] = (-5 * s, 5 * c, 0)
    cam = D.Camera('/cam', matrix=m, projection='orthographic', horizontal_aperture=FILM, vertical_aperture=FILM / 4)
    meshes = [half, slab] if with_slab else [half]
    return scene([D.Container('/', meshes=meshes)], [glow, glass], [], cam, width=N, height=N // 4)


def edge_position(img):
    """Film x of the bright/dark edge: bright left part, box filter -> sum of coverage x pixel width."""
    prof = img[..., 0].mean(0)
    plateau = prof[: N // 8].mean()
    return -FILM / 2 + prof.sum() / plateau * FILM / N, plateau


def test_edge_seen_through_a_glass_slab_is_displaced_by_snell():
    opts = RenderOptions(spp=64, sampler='sobol', filter='box', max_depth=2)
    x_free, p_free = edge_position(render(slab_scene(False), opts).image)
    x_slab, p_slab = edge_position(render(slab_scene(True), opts).image)
    theta_t = math.asin(math.sin(THETA) / IOR)
    shift = math.cos(THETA) * THICK * (math.tan(THETA) - math.tan(theta_t))   # film units
    px = FILM / N
    assert abs(x_free - 0.0) < 0.05 * px
    assert abs(x_slab - shift) < 0.1 * px, (x_slab / px, shift / px)
    # through two interfaces the transmitted radiance is (1 - F)^2 (max_depth 2: no internal echoes)
    F = fresnel_angles(THETA, 1.0, IOR)
    assert p_free == pytest.approx(1.0, abs=1e-6)
    assert p_slab == pytest.approx((1 - F) ** 2, rel=5e-3)
