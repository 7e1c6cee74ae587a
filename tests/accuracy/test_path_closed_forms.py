"""The path integrator against closed forms: the white furnace (a closed diffuse enclosure of albedo
rho and emission Le - its walls are lights, found by light samples and BSDF samples, MIS-weighted:
L = Le (1 - rho^(D+1)) / (1 - rho) with D bounces, Le / (1 - rho) with roulette), and a Lambert plane
under a rect light (Lambert's polygon formula: L = rho / pi E)."""
import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host.render import RenderOptions, Renderer
from tests.renderer import test_integrator as ti
from tests.renderer.handmade import look_at, ortho_down, quad, rect_light, scene

N, WIDTH, H, A, B, LR = 24, 4.0, 1.0, 1.2, 0.8, 2.0


def box(size=2.0):
    """The six faces of a cube about the origin (two triangles each, facing outwards)."""
    h = size / 2
    pts = np.array([[x, y, z] for x in (-h, h) for y in (-h, h) for z in (-h, h)], np.float64)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))], np.int32)
    return D.Mesh(path='/box', points=pts, triangles=tris, material=0)


def furnace(rho, le, model=D.LAMBERTIAN):
    mat = D.Material('/wall', model=model, diffuse=(rho,) * 3, emission=(le,) * 3)
    cam = D.Camera(path='/cam', matrix=look_at((0.1, 0.2, 0.3), (1.0, -0.3, -0.8)))
    return scene([D.Container('/', meshes=[box()])], [mat], [], cam, width=32, height=32)


@pytest.mark.parametrize('rho,depth', [(0.5, 1), (0.5, 8), (0.8, 3)])
def test_white_furnace_with_d_bounces(rho, depth):
    with Renderer(furnace(rho, 1.0)) as r:
        img = r.render(RenderOptions(spp=128, integrator='path', max_depth=depth, sampler='independent')).image
        bsdf = r.render(RenderOptions(spp=4, integrator='path', max_depth=depth, strategy='bsdf')).image
    expected = (1 - rho ** (depth + 1)) / (1 - rho)
    assert img.mean() == pytest.approx(expected, rel=0.005), (img.mean(), expected)
    if depth < 3:             # BSDF sampling alone (the walls are lights: MIS mixes in light samples), no roulette
        np.testing.assert_allclose(bsdf, expected, rtol=1e-5)      # yet: every path has the same value


@pytest.mark.parametrize('rho', [0.5, 0.8])
def test_white_furnace_with_roulette_converges_to_the_infinite_sum(rho):
    with Renderer(furnace(rho, 1.0)) as r:
        img = r.render(RenderOptions(spp=256, integrator='path', max_depth=64, sampler='sobol')).image
    assert img.mean() == pytest.approx(1 / (1 - rho), rel=0.005), img.mean()


def lambert_plane_under_rect(model=D.LAMBERTIAN):
    lam = D.Material('/lambert', model=model, diffuse=(0.5, 0.5, 0.5))
    return scene([D.Container('/', meshes=[quad(40.0)])], [lam], [rect_light((0.0, H, 0.0), A, B, (LR,) * 3)],
                 ortho_down(width=WIDTH), width=N, height=N)


@pytest.mark.parametrize('strategy', ['mis', 'nee', 'bsdf'])
def test_lambert_plane_under_a_rect_light_is_the_form_factor(strategy):
    corners = [(-A / 2, H, -B / 2), (A / 2, H, -B / 2), (A / 2, H, B / 2), (-A / 2, H, B / 2)]
    ref = ti.pixel_average(lambda x, z: 0.5 / np.pi * ti.polygon_irradiance(x, z, corners, LR), N, WIDTH, sub=24)
    spp = 256 if strategy != 'bsdf' else 2048
    with Renderer(lambert_plane_under_rect()) as r:
        img = r.render(RenderOptions(spp=spp, integrator='path', strategy=strategy, filter='box')).image[..., 0]
    # per pixel within 4 standard errors, the image mean within 0.5 %
    assert img.mean() == pytest.approx(ref.mean(), rel=0.005)
    err = np.abs(img - ref)
    assert np.sqrt(np.mean(err ** 2)) < 0.02 * ref.max(), np.sqrt(np.mean(err ** 2))


@pytest.mark.parametrize('strategy', ['mis', 'nee', 'bsdf'])
def test_a_partly_transparent_sheet_passes_one_minus_opacity_of_the_light(strategy):
    """A black sheet of opacity a between the rect light and the Lambert plane (and between the plane
    and the camera): the plane receives (1 - a) of the form-factor irradiance and the camera sees it
    through the sheet with probability 1 - a, so the image is (1 - a)^2 times the bare plane's.  Light
    sampling crosses the sheet by its shadow rays' transmittance, BSDF sampling by passing through it:
    each strategy alone must give the same image."""
    a = 0.4
    lam = D.Material('/lambert', model=D.LAMBERTIAN, diffuse=(0.5, 0.5, 0.5))
    sheet = D.Material('/sheet', diffuse=(0.0, 0.0, 0.0), ior=1.0, roughness=1.0, opacity=a)
    desc = scene([D.Container('/', meshes=[quad(40.0), quad(40.0, y=0.5 * H, material=1, path='/sheet')])],
                 [lam, sheet], [rect_light((0.0, H, 0.0), A, B, (LR,) * 3)], ortho_down(width=WIDTH), width=N, height=N)
    corners = [(-A / 2, H, -B / 2), (A / 2, H, -B / 2), (A / 2, H, B / 2), (-A / 2, H, B / 2)]
    ref = (1 - a) ** 2 * ti.pixel_average(lambda x, z: 0.5 / np.pi * ti.polygon_irradiance(x, z, corners, LR), N, WIDTH,
                                          sub=24)
    spp = 512 if strategy != 'bsdf' else 4096
    with Renderer(desc) as r:
        img = r.render(RenderOptions(spp=spp, integrator='path', strategy=strategy, filter='box', max_depth=1)).image[..., 0]
    assert img.mean() == pytest.approx(ref.mean(), rel=0.01), (img.mean(), ref.mean())
    assert np.sqrt(np.mean((img - ref) ** 2)) < 0.03 * ref.max()


FURNACE_SPHERES = {
    'white Lambert (course)': D.Material('/m', model=D.LAMBERTIAN, diffuse=(1.0,) * 3),
    'glass, ior 1.5': D.Material('/m', model=D.DIELECTRIC, ior=1.5),
    'index-matched glass, ior 1.0001': D.Material('/m', model=D.DIELECTRIC, ior=1.0001),
    'diamond, ior 2.4': D.Material('/m', model=D.DIELECTRIC, ior=2.4),
    'ior 20': D.Material('/m', model=D.DIELECTRIC, ior=20.0),
    'ior 0.5 (a bubble)': D.Material('/m', model=D.DIELECTRIC, ior=0.5),
    'perfect mirror': D.Material('/m', model=D.MIRROR, mirror_coef=1.0, diffuse=(0.0, 0.0, 0.0)),
}


@pytest.mark.parametrize('name', list(FURNACE_SPHERES))
def test_what_conserves_energy_vanishes_in_a_white_furnace(name):
    """A sphere under a constant dome of radiance 1 (nothing else in the scene): if its surface reflects and
    transmits all the light it receives (albedo 1; a clear dielectric, Fresnel reflection and refraction,
    total internal reflection included; a perfect mirror), every path carries exactly 1, so every pixel is 1
    whatever the samples: the sphere is invisible.  Depth 64 with Russian roulette (which a path of
    throughput 1 always survives): light trapped by total internal reflection for longer is the only loss."""
    cam = D.Camera('/cam', matrix=look_at((0.0, 0.0, 4.0), (0.0, 0.0, 0.0)), focal_length=1.0,
                   horizontal_aperture=0.7, vertical_aperture=0.7)        # the sphere fills the view
    desc = scene([D.Container('/', spheres=[D.Sphere('/s', 1.0, np.eye(4), material=0)])], [FURNACE_SPHERES[name]],
                 [D.Light('/dome', D.DOME, np.eye(4), (1.0,) * 3)], cam, width=32, height=32)
    with Renderer(desc) as r:
        img = r.render(RenderOptions(spp=16, integrator='path', max_depth=64, sampler='sobol')).image
    np.testing.assert_allclose(img, 1.0, rtol=1e-5)
