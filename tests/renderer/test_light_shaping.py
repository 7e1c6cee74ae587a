"""UsdLux.ShapingAPI (`usd/lights._shaping`, `kernel/lights.shaped`): a spotlight's cone (1 inside its soft edge,
a smoothstep in the angle to 0 at the cone's angle), its focus (the off-axis cosine to the power focus, tinted).
The image of a floor lit by a shaped point light, divided by the image lit by the same light unshaped, is the
shaping function at each pixel (both integrators); light and BSDF sampling of a shaped sphere light agree."""
import math

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux

from rtc.renderer import description as D
from rtc.renderer.host.render import Renderer
from rtc.renderer.options import RenderOptions
from rtc.renderer.usd.stage import read_stage
from tests.renderer.handmade import estimator_means, ortho_down, quad, scene

H = 2.0                       # the light's height over the floor
W = 48                        # image pixels across the 6 x 6 film


def _down(pos):
    """A light frame at pos whose -Z points down (-Y)."""
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = (1, 0, 0), (0, 0, -1), (0, 1, 0), pos
    return m


def _floor(light):
    mats = [D.Material('/floor', diffuse=(0.6, 0.6, 0.6), roughness=0.7)]
    return scene([D.Container('/', meshes=[quad(12.0)])], mats, [light], ortho_down(width=6.0, y=5.0), width=W,
                 height=W)


def _render(desc, integrator, spp=4):
    with Renderer(desc, threads=1) as r:
        return r.render(RenderOptions(spp=spp, integrator=integrator, max_depth=1, filter='box', threads=1,
                                      sampler='sobol')).image.astype(np.float64)


def _angles(n=1):
    """The angle off the light's axis at n x n points spread over each pixel's footprint on the floor: (W, W, n * n)."""
    c = ((np.arange(W * n) + 0.5) / (W * n) * 6.0 - 3.0).reshape(W, n)
    x, z = c[None, :, None, :], c[:, None, :, None]
    return np.arctan2(np.hypot(x, z), H).reshape(W, W, n * n)


def _expected(shaping, n=16):
    """Each pixel's shaped image over its unshaped one: the shaping averaged over the pixel's footprint, weighted by
    the irradiance of the point light there (cos^3 theta / H^2), per channel."""
    theta = _angles(n)[..., None]
    angle, softness, focus, tint = shaping
    f = _cone(theta, angle, softness)
    if focus > 0.0:
        f = f * (np.asarray(tint) + (1.0 - np.asarray(tint)) * np.cos(theta) ** focus)
    e = np.cos(theta) ** 3
    return (f * e).sum(2) / e.sum(2)


def _cone(theta, angle, softness):
    hi, lo = math.radians(angle), math.radians(angle) * (1.0 - softness)
    t = np.clip((theta - lo) / (hi - lo), 0.0, 1.0) if hi > lo else (theta >= hi).astype(float)
    return 1.0 - t * t * (3.0 - 2.0 * t)


@pytest.mark.parametrize('integrator', ['cook', 'path'])
@pytest.mark.parametrize('shaping', [(35.0, 0.5, 0.0, (0.0, 0.0, 0.0)), (180.0, 0.0, 3.0, (0.25, 0.0, 0.5)),
                                     (50.0, 0.0, 0.0, (0.0, 0.0, 0.0))])
def test_a_shaped_point_light_is_the_unshaped_one_times_its_shaping(integrator, shaping):
    plain = D.Light(path='/spot', type=D.POINT, matrix=_down((0.0, H, 0.0)), radiance=(8.0, 8.0, 8.0))
    spot = D.Light(path='/spot', type=D.POINT, matrix=_down((0.0, H, 0.0)), radiance=(8.0, 8.0, 8.0), shaping=shaping)
    lit, shaped = _render(_floor(plain), integrator, 64), _render(_floor(spot), integrator, 64)
    expect, ratio = _expected(shaping), shaped / np.maximum(lit, 1e-12)
    # pixels at a hard cut (and their neighbours): their 64 samples' share of the cone, not the footprint's (1 / 64 a
    # sample)
    hard = shaping[1] == 0.0 and shaping[0] < 180.0
    cut = (expect[..., 0] > 1e-4) & (expect[..., 0] < 1.0 - 1e-4) if hard else np.zeros((W, W), bool)
    padded = np.pad(cut, 1)
    cut = np.max([padded[i:i + W, j:j + W] for i in range(3) for j in range(3)], 0)
    assert lit.min() > 0.0
    assert np.abs(ratio - expect)[~cut].max() < 0.003, np.abs(ratio - expect)[~cut].max()
    assert np.abs(ratio - expect)[cut].max() < 0.1 if cut.any() else True
    assert expect.max() > 0.99 and expect.min() < 0.35                    # (the shaping shows)


def _sphere_spot():
    return D.Light(path='/spot', type=D.SPHERE, matrix=_down((0.3, 1.2, -0.2)), radiance=(6.0, 6.0, 6.0), radius=0.35,
                   shaping=(40.0, 0.6, 1.0, (0.1, 0.2, 0.3)))


def test_light_sampling_and_bsdf_sampling_of_a_shaped_sphere_light_agree():
    nee, bsdf, mis = estimator_means(_floor(_sphere_spot()))
    assert mis > 1e-3
    assert nee == pytest.approx(mis, rel=0.01) and bsdf == pytest.approx(mis, rel=0.015), (nee, bsdf, mis)


def _usd_light(kind='SphereLight', apply=True, **inputs):
    st = Usd.Stage.CreateInMemory()
    light = getattr(UsdLux, kind).Define(st, '/L')
    light.CreateIntensityAttr(5.0)
    UsdGeom.Xformable(light).AddTranslateOp().Set(Gf.Vec3d(0, 3, 0))
    if apply:
        UsdLux.ShapingAPI.Apply(light.GetPrim())
    for name, value in inputs.items():
        kind_ = Sdf.ValueTypeNames.Color3f if isinstance(value, tuple) else Sdf.ValueTypeNames.Float
        light.GetPrim().CreateAttribute(f'inputs:shaping:{name}', kind_).Set(value)
    desc = read_stage(st)
    return [l for l in desc.lights if l.path == '/L'], desc.warnings


def test_the_reader_reads_the_cone_and_focus_and_names_what_it_cannot_use():
    (l,), warnings = _usd_light(**{'cone:angle': 30.0, 'cone:softness': 0.25, 'focus': 2.0, 'focusTint': (1, 0, 0)})
    assert l.shaping == (30.0, 0.25, 2.0, (1.0, 0.0, 0.0)) and not [w for w in warnings if 'haping' in w]
    (l,), _ = _usd_light()                                             # applied, nothing authored: the 90-degree cone
    assert l.shaping == (90.0, 0.0, 0.0, (0.0, 0.0, 0.0))
    (l,), _ = _usd_light(apply=False)
    assert l.shaping is None
    (l,), _ = _usd_light(**{'cone:angle': 200.0})                      # no cone, no focus: nothing to shape
    assert l.shaping is None
    (l,), _ = _usd_light(**{'cone:angle': -5.0, 'cone:softness': 3.0, 'focus': -1.0})     # clamped
    assert l.shaping == (0.0, 1.0, 0.0, (0.0, 0.0, 0.0))
    (l,), warnings = _usd_light(**{'cone:angle': float('nan')})
    assert l.shaping is None and any(w.startswith('/L: a ShapingAPI input that is not finite') for w in warnings)
    (l,), warnings = _usd_light('DistantLight', **{'cone:angle': 20.0})
    assert l.shaping is None and '/L: ShapingAPI on a DistantLight (one direction) is not applied' in warnings


def tree_leaves_out_above(light):
    """Whether the light tree, of `light` (a downward light at height H over the origin) and a dim lamp beside it,
    never chooses `light` for a point above it facing down, and can for a point on the floor below it."""
    from rtc.renderer.host.build import build
    from rtc.renderer.host.light_selection import path_lights
    from rtc.renderer.kernel.light_tree import choose_lights, light_pmf
    lamp = D.Light(path='/lamp', type=D.POINT, matrix=_down((2.0, 1.0, 0.0)), radiance=(1.0,) * 3)
    desc = _floor(light)
    desc.lights = [light, lamp]
    built = build(desc)
    try:
        L, _ = path_lights(desc, built.data.li_f, built.top.bounds(), len(built.top.groups))
        above, below = np.array([0.0, H + 1.0, 0.0]) - built.origin, np.array([0.3, 0.0, 0.2]) - built.origin
        down = (0.0, -1.0, 0.0)
        return (light_pmf(L, above, down, 0) == 0.0 and light_pmf(L, above, down, 1) == 1.0
                and light_pmf(L, below, (0.0, 1.0, 0.0), 0) > 0.0          # (1 where it outshines the lamp: a split)
                and all(choose_lights(L, above, down, u)[0][0] == 1 for u in np.linspace(0.0, 0.999, 50)))
    finally:
        built.close()


def test_the_light_tree_leaves_out_a_spotlight_where_its_cone_cannot_reach():
    """The tree bounds a spotlight by its cone about -Z (`host/light_tree.light_bounds`): above the light, more than
    theta_o + pi/2 off its axis, it is never chosen; below it, it is."""
    assert tree_leaves_out_above(D.Light(path='/spot', type=D.POINT, matrix=_down((0.0, H, 0.0)), radiance=(8.0,) * 3,
                                         shaping=(30.0, 0.2, 0.0, (0.0, 0.0, 0.0))))
