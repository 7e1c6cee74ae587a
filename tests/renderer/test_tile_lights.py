"""The light choice of a tile's first path vertices (kernel/tile_lights.py): `choose_tile_lights` takes each
light as many times per vertex on average as `tile_pmf` reports, every light keeps a probability (the
uniform floor), a light that outshines the rest is sampled at every first vertex; and renders of a scene of
many lights estimate what the light tree's renders estimate (light sampling, BSDF sampling and MIS agree),
bit-identical across thread counts, passes and windows."""
from collections import namedtuple

import numpy as np
import pytest

from rtc.renderer import description as D
from rtc.renderer.host import light_selection
from rtc.renderer.host.render import Renderer
from rtc.renderer.kernel.integrator import new_tile_lights
from rtc.renderer.kernel.light_tree import NO_SAMPLE, SPLIT_BELOW
from rtc.renderer.kernel.tile_lights import (FLOOR, REST, TILE_LIGHTS_MIN, TOP, choose_tile_lights, tabulate,
                                             tile_pmf)
from rtc.renderer.options import RenderOptions
from tests.renderer.handmade import estimator_means, look_at, quad, scene, translate


_Lights = namedtuple('_Lights', ['leaf_k', 'leaf_col', 'unbounded', 'n_bounded'])


def _lights(n, unbounded=0):
    """The PathLights fields the tile's choice reads: n lights with a position (light k in column n - 1 - k),
    then `unbounded` lights without one."""
    return _Lights(np.arange(n)[::-1].copy(), np.concatenate([np.arange(n)[::-1], np.full(unbounded, -1)]).astype(np.int64),
                   np.arange(n, n + unbounded, dtype=np.int64), n)


def _table(weights, hits, unbounded=0):
    """(lights, TileLights) with the summed normalised pilot weights `weights` of `hits` pilots tabulated."""
    L = _lights(len(weights), unbounded)
    tl = new_tile_lights(len(weights))
    tl.pmf[:] = weights
    tabulate(tl, hits)
    return L, tl


def _draw_counts(L, tl, draws=20000):
    """The number of samples of each light over `draws` stratified draws of the choice's 1D sample."""
    counts = np.zeros(L.leaf_col.shape[0])
    for i in range(draws):
        chosen = choose_tile_lights(L, tl, (i + 0.5) / draws)
        assert chosen[2] == NO_SAMPLE
        for k, pk in chosen:
            if k >= 0:
                counts[k] += 1
                assert pk == pytest.approx(tile_pmf(L, tl, k), rel=1e-12)
    return counts / draws


@pytest.mark.parametrize('unbounded', [0, 2])
def test_draws_take_each_light_as_often_as_its_pmf(unbounded):
    """Two pilots' weights over 80 lights, a dome beside them or not: each light is drawn, per vertex, its
    pmf's number of times (the mixture of the pilots' shares with the floor, times the tree's share), and
    the pmfs sum to one sample a vertex (no split here)."""
    rng = np.random.default_rng(4)
    a, b = rng.random(80) ** 4, rng.random(80) ** 4
    a[:10] = 0.0                                                   # lights neither pilot sees
    b[:10] = 0.0
    L, tl = _table(a / a.sum() + b / b.sum(), 2, unbounded)
    pmf = np.array([tile_pmf(L, tl, k) for k in range(80 + unbounded)])
    share = 1.0 - unbounded / (unbounded + 1)
    mix = (1.0 - FLOOR) * 0.5 * (a / a.sum() + b / b.sum()) + FLOOR / 80
    np.testing.assert_allclose(pmf[:80], share * mix[L.leaf_col[:80]], rtol=1e-12)
    assert pmf.sum() == pytest.approx(1.0, rel=1e-12)
    assert tl.head[REST] == 0.0
    np.testing.assert_allclose(_draw_counts(L, tl), pmf, atol=2.5e-4)


def test_every_light_keeps_a_probability():
    """A light no pilot saw (or every light, where no pilot met a surface) keeps its share of the floor:
    every light that can light a first vertex can be sampled there."""
    w = np.zeros(100)
    w[7] = 1.0
    L, tl = _table(w, 1)
    pmf = np.array([tile_pmf(L, tl, k) for k in range(100)])
    assert FLOOR >= 0.01 and pmf.min() == pytest.approx(FLOOR / 100, rel=1e-12)
    L, tl = _table(np.zeros(100), 0)
    np.testing.assert_allclose([tile_pmf(L, tl, k) for k in range(100)], 0.01, rtol=1e-12)


def test_a_light_that_outshines_the_rest_is_sampled_at_every_vertex():
    """Where one light takes more than 1 - SPLIT_BELOW of the choice it is the main sample of every vertex
    (expected count 1) and another light a side sample with the rest's probability q."""
    w = np.full(70, 0.1 / 69)
    w[20] = 0.9
    L, tl = _table(w, 1)
    assert int(tl.head[TOP]) == 20 and L.leaf_k[20] == 49
    q = tl.head[REST]
    assert 0.0 < q <= SPLIT_BELOW
    assert q == pytest.approx(0.1 * (1.0 - FLOOR) + FLOOR * 69 / 70, rel=1e-12)
    assert tile_pmf(L, tl, 49) == 1.0
    mains = {choose_tile_lights(L, tl, u)[0][0] for u in np.linspace(0.0, 0.99999, 301)}
    assert mains == {49}
    counts = _draw_counts(L, tl)
    pmf = np.array([tile_pmf(L, tl, k) for k in range(70)])
    np.testing.assert_allclose(counts, pmf, atol=2.5e-4)
    assert pmf.sum() == pytest.approx(1.0 + q, rel=1e-12)


def _many_lights(n=90, points=True):
    """A floor and a back wall under n point and rect lights of mixed brightness (`points`: else rect lights
    alone), and a dim dome: more than TILE_LIGHTS_MIN lights with a position."""
    rng = np.random.default_rng(11)
    lights = []
    for k in range(n):
        c = rng.uniform([-4, 0.3, -4], [4, 2.5, 1])
        if k % 2 and points:
            lights.append(D.Light(path=f'/p{k}', type=D.POINT, matrix=translate(*c),
                                  radiance=(float(rng.uniform(0.05, 0.6)),) * 3))
        else:
            m = translate(*c)
            m[:3, :3] = [[1, 0, 0], [0, 0, 1], [0, -1, 0]]           # facing down
            lights.append(D.Light(path=f'/r{k}', type=D.RECT, matrix=m, radiance=(float(rng.uniform(0.5, 4)),) * 3,
                                  width=0.3, height=0.3))
    lights.append(D.Light(path='/sky', type=D.DOME, matrix=np.eye(4), radiance=(0.05,) * 3))
    wall = D.Mesh(path='/wall', points=np.array([[-6, 0, -4.5], [6, 0, -4.5], [6, 6, -4.5], [-6, 6, -4.5]], float),
                  triangles=np.array([[0, 1, 2], [0, 2, 3]], np.int32), material=0)      # facing +Z
    cam = D.Camera(path='/cam', matrix=look_at((0.0, 2.5, 7.0), (0.0, 0.5, -1.0)))
    return scene([D.Container('/', meshes=[quad(12.0), wall])],
                 [D.Material('/m', diffuse=(0.6, 0.6, 0.6), roughness=0.5)], lights, cam)


@pytest.fixture(scope='module')
def many():
    return _many_lights()


def test_the_scene_uses_the_tile_choice(many):
    """90 lights with a position: a column each (the dome none); a scene of fewer than TILE_LIGHTS_MIN has no
    table (the tree chooses at every vertex)."""
    with Renderer(many) as r:
        L = r.path_lights()
        assert TILE_LIGHTS_MIN <= L.leaf_k.shape[0] == 90
        assert sorted(L.leaf_k.tolist()) == list(range(90))
        assert all(L.leaf_col[k] >= 0 for k in range(90)) and L.leaf_col[90] == -1
    with Renderer(_many_lights(n=TILE_LIGHTS_MIN - 1)) as r:
        assert r.path_lights().leaf_k.shape[0] == 0


def _render(desc, tiled, **kw):
    with Renderer(desc, threads=2) as r:
        assert (r.path_lights().leaf_k.shape[0] > 0) == tiled
        return r.render(RenderOptions(integrator='path', **kw)).image.astype(np.float64)


def test_renders_estimate_what_the_tree_estimates(many, monkeypatch):
    """The whole image's mean and its 8 x 8 blocks (D = 3) with the tile's choice and with the tree alone
    (every scene of fewer than TILE_LIGHTS_MIN lights) agree, each converged."""
    opts = dict(spp=256, max_depth=3, width=64, height=48, sampler='independent')
    tiled = _render(many, True, **opts)
    monkeypatch.setattr(light_selection, 'TILE_LIGHTS_MIN', 10 ** 9)
    tree = _render(many, False, **opts)
    assert tiled.mean() == pytest.approx(tree.mean(), rel=0.01)
    blocks = lambda im: im.mean(axis=2).reshape(6, 8, 8, 8).mean(axis=(1, 3))
    np.testing.assert_allclose(blocks(tiled), blocks(tree), rtol=0.05)


def test_light_bsdf_and_mis_estimates_agree():
    """Direct light by light sampling alone, BSDF sampling alone and MIS agree (rect lights: BSDF rays find
    them): the MIS weight of a BSDF ray from a first vertex that finds a light uses the tile's pmf, which the
    light samples drew with."""
    nee, bsdf, mis = estimator_means(_many_lights(points=False), nee_spp=64, bsdf_spp=512, mis_spp=64, seeds=1)
    assert mis == pytest.approx(nee, rel=0.01)
    assert bsdf == pytest.approx(mis, rel=0.02)


def test_bit_identical_across_threads_passes_and_windows(many):
    """The table depends on the tile alone: 1 or 2 threads, one pass or many, a window (a shot's tile) give
    the same pixels."""
    opts = dict(integrator='path', spp=6, max_depth=3, width=44, height=30, seed=5)
    with Renderer(many, threads=1) as r1, Renderer(many, threads=2) as r2:
        one = r1.render(RenderOptions(**opts)).image
        assert one.max() > 0.0
        np.testing.assert_array_equal(one, r2.render(RenderOptions(**opts)).image)
        np.testing.assert_array_equal(one, r2.render(RenderOptions(**opts, pass_seconds=1e-9)).image)
        part = r2.render(RenderOptions(**opts), window=(8, 8, 44, 24)).image
        np.testing.assert_array_equal(one[8:24, 8:44], part)
