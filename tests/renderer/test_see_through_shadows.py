"""Shadows through see-through UsdPreviewSurfaces in the cook integrator (`integrator._transmittance`), as the path
integrator casts them (`path.shadow_transmittance`): a card of opacity a between a point light and the floor lets
1 - a of the light through; a cut-out (opacityThreshold) none below the threshold's opacity and all of it at or
above.  Where the floor is in the card's shadow and the camera does not look through the card, the image with the
card over the image without it is that fraction exactly (a point light: the same light sample in both renders).  A
card whose opacity is kept per corner (a varying displayOpacity, `shapes.corner_opacity`) multiplies its material's
opacity by it before the threshold cuts it."""
import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host.render import Renderer
from rtc.renderer.options import RenderOptions
from tests.renderer.handmade import ortho_down, quad, scene

W = 48                        # pixels across the 6 x 6 film


def _render(card, integrator):
    """A floor lit by a point light at (-2, 3, 0), seen from above; `card`: None, or (opacity, threshold[, corner]) of
    a 1 x 1 card at height 1 over the origin, whose shadow falls on x in [0.25, 1.75], |z| < 0.75 (the card covers
    x < 0.5); `corner`: an opacity at each of its triangles' corners that its material multiplies its own by."""
    light = np.eye(4)
    light[:3, 3] = (-2.0, 3.0, 0.0)
    meshes = [quad(12.0, material=0, path='/floor')]
    mats = [D.Material('/floor', diffuse=(0.6, 0.6, 0.6), roughness=0.7)]
    if card is not None:
        meshes.append(quad(1.0, y=1.0, material=1, path='/card'))
        corner = len(card) > 2
        if corner:                                   # RGB white, A the corner's opacity
            meshes[-1].colors = np.concatenate([np.ones((2, 3, 3)), np.full((2, 3, 1), card[2])], 2).astype(np.float32)
        mats.append(D.Material('/card', diffuse=(0.2, 0.4, 0.8), opacity=card[0], opacity_threshold=card[1],
                               vertex_opacity=corner))
    desc = scene([D.Container('/', meshes=meshes)], mats,
                 [D.Light(path='/lamp', type=D.POINT, matrix=light, radiance=(6.0, 6.0, 6.0))],
                 ortho_down(width=6.0, y=5.0), width=W, height=W)
    with Renderer(desc, threads=1) as r:
        return r.render(RenderOptions(spp=4, integrator=integrator, max_depth=1, filter='box', threads=1,
                                      sampler='sobol')).image.astype(np.float64)[..., 0]


def _shadow_pixels():
    """The pixels whose footprint lies in the card's shadow and outside the card seen from above."""
    c = (np.arange(W) + 0.5) / W * 6.0 - 3.0
    x, z = c[None, :], c[:, None]
    return (x > 0.7) & (x < 1.6) & (np.abs(z) < 0.6)


@pytest.mark.parametrize('integrator', ['cook', 'path'])
@pytest.mark.parametrize('card, through', [((0.3, 0.0), 0.7), ((0.3, 0.5), 1.0), ((0.7, 0.5), 0.0),
                                           ((1.0, 0.0), 0.0), ((1.0, 0.0, 0.3), 0.7), ((0.5, 0.0, 0.6), 0.7),
                                           ((0.5, 0.5, 0.6), 1.0), ((1.0, 0.5, 0.7), 0.0)])
def test_a_see_through_card_lets_one_minus_its_opacity_of_the_light_through(integrator, card, through):
    plain, shadowed = _render(None, integrator), _render(card, integrator)
    inside = _shadow_pixels()
    assert plain[inside].min() > 0.0
    np.testing.assert_allclose(shadowed[inside] / plain[inside], through, atol=1e-6)
    lit = ~inside & (np.abs((np.arange(W) + 0.5) / W * 6.0 - 3.0)[None, :] > 2.0)     # (far from card and shadow)
    np.testing.assert_allclose(shadowed[lit], plain[lit], rtol=1e-12)
