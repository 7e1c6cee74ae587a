"""Every kind of light the path integrator samples with MIS is found by both strategies: light
sampling alone and BSDF sampling alone converge to the same image for sphere, disk, cylinder, distant
(with an angle) and textured dome lights (a sky, and one bright texel on black), and lights of negative
radiance; delta lights are seen by light sampling; images are bit-identical
across thread counts and splits into passes."""
import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host.render import RenderOptions, Renderer
from tests.renderer.handmade import look_at, quad, scene, translate


def _floor_scene(lights, textures=()):
    mats = [D.Material('/floor', diffuse=(0.6, 0.6, 0.6), roughness=0.6),
            D.Material('/ball', diffuse=(0.9, 0.5, 0.2), metallic=1.0, roughness=0.5)]
    ball = D.Sphere(path='/ball', radius=0.5, matrix=translate(0.0, 0.5, 0.0), material=1)
    cam = D.Camera(path='/cam', matrix=look_at((0.0, 2.0, 4.0), (0.0, 0.3, 0.0)))
    return scene([D.Container('/', meshes=[quad(8.0)], spheres=[ball])], mats, lights, cam, width=32, height=24,
                 textures=textures)


def _disk(center, radius, radiance):
    m = np.eye(4)
    m[:3, 1], m[:3, 2] = (0, 0, -1), (0, 1, 0)         # emits along -Y
    m[:3, 3] = center
    return D.Light(path='/disk', type=D.DISK, matrix=m, radiance=radiance, radius=radius)


def _rects():
    """A rect light close above the floor (sampled in its solid angle) and a tiny far one (by area:
    its solid angle is below `light_sampling.SPHERICAL_MIN`)."""
    near = _disk((1.2, 1.3, 0.4), 0.0, (6.0,) * 3)
    near.type, near.path, near.width, near.height = D.RECT, '/rect', 1.6, 1.0
    far = _disk((-1.0, 3.5, -0.5), 0.0, (4000.0,) * 3)
    far.type, far.path, far.width, far.height = D.RECT, '/tiny', 0.04, 0.04
    return [near, far]


def _many_rects():
    """A dominant rect light and 15 faint small ones: the light tree splits at the top levels (the
    dominant light in every light sample, the faint ones in side samples)."""
    rng = np.random.default_rng(11)
    main = _disk((0.0, 2.5, 0.0), 0.0, (10.0,) * 3)
    main.type, main.path, main.width, main.height = D.RECT, '/main', 1.5, 1.5
    out = [main]
    for k in range(15):
        r = _disk(tuple(rng.uniform([-3.5, 0.8, -3.5], [3.5, 2.0, 3.5])), 0.0, (3.0,) * 3)
        r.type, r.path, r.width, r.height = D.RECT, f'/faint{k}', 0.3, 0.3
        out.append(r)
    return out


def _subtractive():
    """The two rect lights, the far one of negative radiance (a subtractive light, as the course integrator
    reads it), and a sphere light negative in red.  Light samples choose lights by the magnitude of their
    luminance; when a negative one had no chance, light sampling alone read 0.200 where MIS read 0.162."""
    near, far = _rects()
    far.radiance = (-4000.0,) * 3
    return [near, far, D.Light(path='/s', type=D.SPHERE, matrix=translate(1.0, 2.0, 1.0), radiance=(-20.0, 20.0, 20.0),
                               radius=0.3)]


def _sky():
    h, w = 16, 32
    px = np.full((h, w, 3), 0.2, np.float32)
    px[3:5, 10:13] = (40.0, 30.0, 20.0)               # a small bright "sun" in the upper rows
    return D.Texture(path='/sky.exr', pixels=px, wrap_s='repeat', wrap_t='clamp')


def _sun_on_black():
    """One bright texel on black: the bilinear lookup spreads 44 % of its light into the black texels around
    it, where the sampling tables must put light samples too (next-event estimation alone reached 0.58 of
    the image when the tables weighed texels by their own luminance)."""
    px = np.zeros((16, 32, 3), np.float32)
    px[3, 11] = (400.0, 300.0, 200.0)
    return D.Texture(path='/sun.exr', pixels=px, wrap_s='repeat', wrap_t='clamp')


LIGHTS = {
    'sphere': ([D.Light(path='/s', type=D.SPHERE, matrix=translate(1.0, 2.0, 1.0), radiance=(20.0,) * 3,
                        radius=0.25)], ()),
    'disk': ([_disk((-1.0, 2.5, 0.5), 0.4, (15.0,) * 3)], ()),
    'rect': (_rects(), ()),
    'many rects': (_many_rects(), ()),
    'cylinder': ([D.Light(path='/c', type=D.CYLINDER, matrix=translate(0.3, 1.6, -0.8), radiance=(8.0,) * 3,
                          radius=0.25, length=1.2)], ()),
    'distant': ([D.Light(path='/d', type=D.DISTANT, matrix=np.linalg.inv(look_at((0, 0, 0), (-1, -2, -1)))
                         @ np.eye(4), radiance=(3.0,) * 3, angle=10.0)], ()),
    'dome': ([D.Light(path='/dome', type=D.DOME, matrix=np.eye(4), radiance=(1.0,) * 3, texture=0)], (_sky(),)),
    'dome, one texel on black': ([D.Light(path='/dome', type=D.DOME, matrix=np.eye(4), radiance=(1.0,) * 3,
                                          texture=0)], (_sun_on_black(),)),
    'subtractive: a negative rect, a sphere negative in red': (_subtractive(), ()),
}


def _distant_matrix():
    # local +Z (towards the light) = normalised (1, 2, 1)
    z = np.array([1.0, 2.0, 1.0]) / np.sqrt(6.0)
    x = np.cross([0.0, 1.0, 0.0], z)
    x /= np.linalg.norm(x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2] = x, np.cross(z, x), z
    return m


LIGHTS['distant'][0][0].matrix = _distant_matrix()


def _mean(r, strategy, spp):
    return np.mean([r.render(RenderOptions(spp=spp, seed=s, integrator='path', max_depth=2, strategy=strategy,
                                           sampler='independent')).image.astype(np.float64) for s in range(2)], 0)


@pytest.mark.parametrize('kind', LIGHTS)
def test_light_sampling_and_bsdf_sampling_find_the_same_light(kind):
    lights, tex = LIGHTS[kind]
    with Renderer(_floor_scene(lights, tex)) as r:
        nee = _mean(r, 'nee', 512)
        bsdf = _mean(r, 'bsdf', 2048)          # BSDF sampling alone: the noisiest of the three
        mis = _mean(r, 'mis', 256)
    assert mis.mean() > 1e-3
    assert nee.mean() == pytest.approx(mis.mean(), rel=0.015), (nee.mean(), mis.mean())
    assert bsdf.mean() == pytest.approx(mis.mean(), rel=0.015), (bsdf.mean(), mis.mean())


def test_point_light_is_found_by_light_sampling_only():
    desc = _floor_scene([D.Light(path='/p', type=D.POINT, matrix=translate(0.0, 3.0, 1.0), radiance=(10.0,) * 3)])
    with Renderer(desc) as r:
        mis = r.render(RenderOptions(spp=16, integrator='path', max_depth=1)).image
        bsdf = r.render(RenderOptions(spp=16, integrator='path', max_depth=1, strategy='bsdf')).image
    assert mis.mean() > 0.01 and bsdf.max() == 0.0
    # the floor straight below the light: E = I / d^2, L = rho / pi E (+ a little specular)


def test_images_are_bit_identical_across_threads_and_passes():
    lights, tex = LIGHTS['dome']
    desc = _floor_scene(lights + LIGHTS['sphere'][0], tex)
    with Renderer(desc, threads=1) as r:
        one = r.render(RenderOptions(spp=8, integrator='path', threads=1, pass_seconds=1e9)).image
    with Renderer(desc, threads=2) as r:
        two = r.render(RenderOptions(spp=8, integrator='path', threads=2, pass_seconds=1e-9)).image
        film = r.render(RenderOptions(spp=3, integrator='path')).film
        resumed = r.render(RenderOptions(spp=8, integrator='path'), film=film).image
    assert np.array_equal(one, two)
    assert np.array_equal(one, resumed)


def test_a_surface_of_negative_emission_is_found_by_both_strategies():
    """An emissive quad of negative emission beside a positive one, over the floor: light samples choose
    emissive surfaces by the magnitude of their luminance, so the negative one is sampled as BSDF samples
    meet it.  Measured: light sampling alone / BSDF sampling alone / MIS 0.02930 / 0.02936 / 0.02930; when
    the negative quad was no light, 0.02979 / 0.02936 / 0.02978 (1.4 % apart)."""
    mats = [D.Material('/floor', diffuse=(0.6, 0.6, 0.6), roughness=0.6),
            D.Material('/negative', diffuse=(0.0, 0.0, 0.0), emission=(-3.0, -3.0, -3.0)),
            D.Material('/positive', diffuse=(0.0, 0.0, 0.0), emission=(5.0, 5.0, 5.0))]
    meshes = [quad(8.0), quad(1.0, y=1.5, material=1, path='/negative', center=(0.8, 0.0)),
              quad(1.0, y=1.8, material=2, path='/positive', center=(-0.8, 0.0))]
    cam = D.Camera(path='/cam', matrix=look_at((0.0, 2.0, 4.0), (0.0, 0.3, 0.0)))
    with Renderer(scene([D.Container('/', meshes=meshes)], mats, [], cam, width=32, height=24)) as r:
        nee, bsdf, mis = (_mean(r, s, spp).mean() for s, spp in (('nee', 256), ('bsdf', 1024), ('mis', 256)))
    assert mis > 0.02
    assert nee == pytest.approx(mis, rel=0.007) and bsdf == pytest.approx(mis, rel=0.007), (nee, bsdf, mis)
