"""The path integrator's three estimators of direct light on a glossy scene (GGX gold, roughness 0.08,
and GGX plastic, roughness 0.35, under a small bright and a large dim rect light; the small one a disk in a
second scene, whose light samples the gold draws towards its lobe, `kernel/lobe_sampling.py`): light sampling
alone, BSDF sampling alone and their combination by MIS converge to the same image (image means
within 1 %), and at equal samples MIS has the lowest error against the converged image."""
import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host.render import RenderOptions, Renderer
from tests.renderer.handmade import look_at, quad, rect_light, scene


def glossy_scene(small='rect'):
    gold = D.Material('/gold', diffuse=(1.0, 0.78, 0.34), metallic=1.0, roughness=0.08 ** 0.5)
    plastic = D.Material('/plastic', diffuse=(0.1, 0.2, 0.6), roughness=0.35 ** 0.5)
    left = quad(3.0, material=0, path='/left', center=(-1.5, 0.0))
    right = quad(3.0, material=1, path='/right', center=(1.5, 0.0))
    lights = [rect_light((0.0, 2.0, -1.0), 0.4, 0.4, (40.0,) * 3), rect_light((0.0, 4.0, 0.0), 6.0, 6.0, (0.3,) * 3)]
    if small == 'disk':
        lights[0] = D.Light(path='/disk', type=D.DISK, matrix=lights[0].matrix, radiance=(8.0,) * 3, radius=0.5)
    cam = D.Camera(path='/cam', matrix=look_at((0.0, 1.5, 4.0), (0.0, 0.0, 0.5)))
    return scene([D.Container('/', meshes=[left, right])], [gold, plastic], lights, cam, width=48, height=36)


@pytest.fixture(scope='module', params=['rect', 'disk'])
def renders(request):
    out = {}
    with Renderer(glossy_scene(request.param)) as r:
        for strategy in ('mis', 'nee', 'bsdf'):
            conv = [r.render(RenderOptions(spp=1024 if strategy == 'bsdf' else 256, seed=100 + s, integrator='path', max_depth=1, strategy=strategy,
                                           sampler='independent')).image.astype(np.float64) for s in range(4)]
            low = [r.render(RenderOptions(spp=8, seed=s, integrator='path', max_depth=1, strategy=strategy))
                   .image.astype(np.float64) for s in range(4)]
            out[strategy] = (np.mean(conv, 0), low)
    return out


def test_the_three_estimators_agree_when_converged(renders):
    ref = renders['mis'][0].mean()
    assert ref > 0.01
    for s in ('nee', 'bsdf'):
        assert renders[s][0].mean() == pytest.approx(ref, rel=0.01), (s, renders[s][0].mean(), ref)


def test_mis_has_the_lowest_error_at_equal_samples(renders):
    ref = np.mean([renders[s][0] for s in renders], 0)
    rmse = {s: np.mean([np.sqrt(np.mean((im - ref) ** 2)) for im in renders[s][1]]) for s in renders}
    assert rmse['mis'] < rmse['nee'] and rmse['mis'] < rmse['bsdf'], rmse
