"""IES profiles (UsdLux.ShapingAPI `shaping:ies:*`: `usd/ies.py` reads the file, `kernel/ies_profiles.py` weighs the
emission).  Profiles whose intensity is bilinear in the vertical and horizontal angles are interpolated exactly, so
the image of a floor under a profiled point light over the image under the same light without it is the closed form
at each pixel (averaged over the pixel's footprint), in both integrators; the file's symmetries unfold as LM-63
defines them; `normalize` divides by the mean hdEmbree computes (1 for an isotropic candela, 1/2 for a cosine over
the hemisphere); light and BSDF sampling agree; a file that cannot be used is named with its line, and the light
kept without its profile."""
import math

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux

from rtc.renderer import description as D
from rtc.renderer.usd.ies import IesError, mean_intensity, parse_ies
from rtc.renderer.usd.stage import read_stage
from tests.renderer.handmade import estimator_means
from tests.renderer.test_light_shaping import H, W, _down, _floor, _render, tree_leaves_out_above


def ies_text(vertical, horizontal, candela, multiplier=1.0, tilt='NONE', kind=1):
    """An LM-63-2002 file: `candela` (len(horizontal), len(vertical)) in candela."""
    rows = '\n'.join(' '.join(f'{c:g}' for c in row) for row in np.asarray(candela, float).reshape(len(horizontal), -1))
    return (f'IESNA:LM-63-2002\n[TEST] rtc\n[MANUFAC] none\nTILT={tilt}\n'
            f'1 -1 {multiplier:g} {len(vertical)} {len(horizontal)} {kind} 2 0 0 0\n1.0 1.0 0\n'
            + ' '.join(f'{v:g}' for v in vertical) + '\n' + ' '.join(f'{h:g}' for h in horizontal) + '\n' + rows + '\n')


def profile(vertical, horizontal, fn, **kw):
    """The profile of fn(theta, phi) (radians) sampled at the angles (degrees)."""
    v, h = np.radians(vertical), np.radians(horizontal)
    return parse_ies('test.ies', ies_text(vertical, horizontal, fn(v[None, :], h[:, None]), **kw))


def _footprint(n=12):
    """(theta, phi, irradiance weight) of n x n points over each pixel's footprint on the floor, seen from the light
    at height H above the origin, its frame `_down` (X = +X, Y = -Z, Z = +Y): the direction towards the light from a
    floor point (x, 0, z) is (-x, H, -z) / r, so its vertical angle is acos(H / r) and its horizontal angle
    atan2(z, -x) (the angles of the direction towards the light in the light's frame)."""
    c = ((np.arange(W * n) + 0.5) / (W * n) * 6.0 - 3.0).reshape(W, n)
    x, z = c[None, :, None, :], c[:, None, :, None]          # (columns: x; rows: z, image up is -Z)
    x, z = np.broadcast_to(x, (W, W, n, n)).reshape(W, W, -1), np.broadcast_to(z, (W, W, n, n)).reshape(W, W, -1)
    r = np.sqrt(x * x + z * z + H * H)
    return np.arccos(H / r), np.mod(np.arctan2(z, -x), 2 * np.pi), (H / r) ** 3


def _expected(fn):
    theta, phi, e = _footprint()
    return (fn(theta, phi) * e).sum(2) / e.sum(2)


def _light(**kw):
    return D.Light(path='/lamp', type=D.POINT, matrix=_down((0.0, H, 0.0)), radiance=(8.0, 8.0, 8.0), **kw)


def bilinear(theta, phi):
    """Bilinear in (theta, phi): the profile interpolates it exactly (and it differs along every direction)."""
    return 40.0 + 30.0 * theta + 6.0 * phi + 4.0 * theta * phi


@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_a_profiled_point_light_is_the_plain_one_times_its_profile(integrator):
    prof = profile(np.arange(0, 181, 15), np.arange(0, 361, 30), bilinear)
    plain, lit = _render(_floor(_light()), integrator, 64), _render(_floor(_light(ies=prof)), integrator, 64)
    ratio, expect = lit[..., 0] / np.maximum(plain[..., 0], 1e-12), _expected(bilinear)
    assert plain.min() > 0.0
    seam = np.zeros((W, W), bool)                      # (the pixels that straddle phi = 0, the file's seam)
    seam[W // 2 - 1:W // 2 + 1, :W // 2] = True
    assert np.abs(ratio / expect - 1.0)[~seam].max() < 0.003, np.abs(ratio / expect - 1.0)[~seam].max()
    assert expect.max() / expect.min() > 1.5                               # (the profile shows)


@pytest.mark.parametrize('scale', [0.5, -0.4])
def test_angle_scale_maps_the_vertical_angle_as_usdlux_specifies(scale):
    """theta_ies = pi - (pi - theta) / (1 + angleScale), clamped to [0, pi] (the UsdLux specification's,
    RenderMan's)."""
    prof = profile(np.arange(0, 181, 10), [0], lambda t, p: 10.0 + 20.0 * t + 0.0 * p)

    def fn(theta, phi):
        t = np.clip(np.pi - (np.pi - theta) / (1.0 + scale), 0.0, np.pi)
        return 10.0 + 20.0 * t
    plain = _render(_floor(_light()), 'path', 64)
    lit = _render(_floor(_light(ies=prof, ies_angle_scale=scale)), 'path', 64)
    ratio, expect = lit[..., 0] / plain[..., 0], _expected(fn)
    assert np.abs(ratio / expect - 1.0).max() < 0.003, np.abs(ratio / expect - 1.0).max()


def test_past_its_vertical_angles_a_profile_emits_nothing():
    """A downlight's file covers 0-60 degrees: beyond, the light is dark (and the cone and focus still apply)."""
    prof = profile([0, 30, 60], [0], lambda t, p: 100.0 + 0.0 * t * p)
    lit = _render(_floor(_light(ies=prof)), 'path', 4)
    theta = _footprint(1)[0][..., 0]
    inside, outside = theta < np.radians(58), theta > np.radians(62)
    assert lit[inside].min() > 0.0 and lit[outside].max() == 0.0
    spot = _render(_floor(_light(ies=prof, shaping=(30.0, 0.0, 0.0, (0.0, 0.0, 0.0)))), 'path', 4)
    assert spot[theta > np.radians(32)].max() == 0.0 and spot[theta < np.radians(28)].min() > 0.0


def test_normalize_divides_by_the_mean_hdembree_computes():
    iso = profile(np.arange(0, 181, 5), [0], lambda t, p: 250.0 + 0.0 * t * p)
    assert iso.mean == pytest.approx(250.0, rel=1e-3)
    cosine = profile(np.arange(0, 91, 1), [0], lambda t, p: np.cos(t) + 0.0 * p)
    assert cosine.mean == pytest.approx(0.5, rel=1e-3)          # (its integral pi over the hemisphere's 2 pi)
    plain = _render(_floor(_light()), 'cook', 4)
    same = _render(_floor(_light(ies=iso, ies_gain=1.0 / iso.mean)), 'cook', 4)
    bright = _render(_floor(_light(ies=iso)), 'cook', 4)
    assert np.allclose(same, plain, rtol=2e-3) and np.allclose(bright, 250.0 * plain, rtol=1e-5)


def test_light_sampling_and_bsdf_sampling_of_a_profiled_sphere_light_agree():
    prof = profile(np.arange(0, 181, 15), np.arange(0, 361, 30), bilinear)
    nee, bsdf, mis = estimator_means(_floor(D.Light(path='/lamp', type=D.SPHERE, matrix=_down((0.3, 1.2, -0.2)),
                                                    radiance=(0.2,) * 3, radius=0.35, ies=prof)))
    assert mis > 1e-3
    assert nee == pytest.approx(mis, rel=0.01) and bsdf == pytest.approx(mis, rel=0.015), (nee, bsdf, mis)


def _at(prof, theta_deg, phi_deg):
    """The profile's candela at one direction, by the kernel's interpolation."""
    from rtc.renderer.kernel.ies_profiles import ies_weight
    blocks = np.concatenate([[len(prof.vertical), len(prof.horizontal)], prof.vertical, prof.horizontal,
                             prof.candela.ravel()])
    lf = np.zeros((1, 64))
    from rtc.renderer.kernel.tables import LF_IES
    lf[0, LF_IES:LF_IES + 3] = (0.0, 1.0, 1.0)
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return ies_weight(blocks, lf, 0, math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t))


@pytest.mark.parametrize('horizontal, rows, phi, expect', [
    ([0], [[7]], [0, 123, 300], [7, 7, 7]),                                   # the same all round
    ([0, 45, 90], [[1], [2], [3]], [30, 135, 200, 315], [5 / 3, 2, 13 / 9, 2]),   # a quadrant, mirrored twice
    ([0, 90, 180], [[1], [2], [3]], [45, 270, 315], [1.5, 2, 1.5]),            # a half, mirrored about 0-180
    ([90, 180, 270], [[1], [2], [3]], [0, 45, 300, 350], [2, 1.5, 8 / 3, 2 + 1 / 9]),   # about the 90-270 plane
    ([0, 90, 180, 270], [[1], [2], [3], [4]], [315, 350], [2.5, 1 + 3 * 10 / 90]),    # closed at 360 with 0's
])
def test_the_horizontal_symmetries_unfold_as_lm63_defines(horizontal, rows, phi, expect):
    prof = parse_ies('s.ies', ies_text([0, 90], horizontal, np.repeat(rows, 2, axis=1)))
    assert [_at(prof, 45.0, p) for p in phi] == pytest.approx(expect, rel=1e-9)
    assert prof.horizontal[0] == 0.0 and prof.horizontal[-1] == pytest.approx(2 * np.pi)


def test_the_multiplier_ballast_and_tilt_block_are_read():
    text = ies_text([0, 90], [0], [[10, 10]], multiplier=2.5, tilt='INCLUDE')
    text = text.replace('TILT=INCLUDE\n', 'TILT=INCLUDE\n1\n3\n0 45 90\n1 0.9 0.8\n')
    assert parse_ies('t.ies', text).candela.max() == pytest.approx(25.0)
    assert mean_intensity(np.radians([0.0, 180.0]), np.radians([0.0, 360.0]), np.full((2, 2), 3.0)) == \
        pytest.approx(3.0 * 2 * np.pi * np.pi / (4 * np.pi))         # (one patch: its centre's sine, as hdEmbree)


@pytest.mark.parametrize('edit, message', [
    (lambda t: t.replace('TILT=NONE\n', ''), 'test.ies: no TILT= line'),
    (lambda t: t.replace('0 90\n0', '0 x\n0'), 'test.ies:7: a vertical angle: "x" is not a number'),
    (lambda t: t.rsplit('\n', 2)[0] + '\n', 'test.ies:8: the file ends before a candela value'),
    (lambda t: t.replace('1 2 0 0 0', '2 2 0 0 0'), 'test.ies:5: photometric type B is not supported'),
    (lambda t: t.replace('0 90\n0', '90 0\n0'), 'test.ies:7: the vertical angles do not increase'),
    (lambda t: t.replace('10 10', '10 -1'), 'test.ies:9: a negative candela value'),
])
def test_a_file_rtc_cannot_use_is_named_with_its_line(edit, message):
    with pytest.raises(IesError) as e:
        parse_ies('test.ies', edit(ies_text([0, 90], [0], [[10, 10]])))
    assert str(e.value).startswith(message), str(e.value)


def _stage(tmp_path, ies_file, kind='SphereLight', **inputs):
    layer = tmp_path / f'lamp{len(list(tmp_path.glob("*.usda")))}.usda'
    st = Usd.Stage.CreateNew(str(layer))
    light = getattr(UsdLux, kind).Define(st, '/L')
    UsdGeom.Xformable(light).AddTranslateOp().Set(Gf.Vec3d(0, 3, 0))
    api = UsdLux.ShapingAPI.Apply(light.GetPrim())
    api.CreateShapingIesFileAttr(Sdf.AssetPath(ies_file))
    for name, value in inputs.items():
        getattr(api, f'CreateShapingIes{name}Attr')(value)
    st.Save()
    desc = read_stage(Usd.Stage.Open(str(layer)))
    return [l for l in desc.lights if l.path == '/L'], desc.warnings


def test_the_stage_reader_reads_the_profile_next_to_the_layer_and_names_what_it_cannot_use(tmp_path):
    (tmp_path / 'lamp.ies').write_text(ies_text([0, 90, 180], [0], [[4, 2, 0]]))
    (l,), warnings = _stage(tmp_path, './lamp.ies', AngleScale=0.25, Normalize=True)
    assert l.ies is not None and l.ies.candela.max() == 4.0 and l.ies_angle_scale == 0.25
    assert l.ies_gain == pytest.approx(1.0 / l.ies.mean) and not [w for w in warnings if 'ies' in w]
    (l,), warnings = _stage(tmp_path, './missing.ies')
    assert l.ies is None and '/L.inputs:shaping:ies:file: "./missing.ies" not found; the light emits without its ' \
        'profile' in warnings
    (tmp_path / 'bad.ies').write_text('IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 two 1 1 2 0 0 0\n')
    (l,), warnings = _stage(tmp_path, './bad.ies')
    assert l.ies is None and any(w.startswith('/L.inputs:shaping:ies:file: ') and 'bad.ies:3: the number of vertical '
                                 'angles: "two" is not a number; the light emits without its profile' in w
                                 for w in warnings), warnings
    (l,), warnings = _stage(tmp_path, './lamp.ies', AngleScale=-1.5)
    assert l.ies is not None and l.ies_angle_scale == 0.0
    assert '/L.inputs:shaping:ies:angleScale: -1.5 maps no angle (finite and > -1 do); not applied' in warnings
    (l,), warnings = _stage(tmp_path, './lamp.ies', kind='DistantLight')
    assert l.ies is None and '/L.inputs:shaping:ies:file: an IES profile on a DistantLight (one direction) is not ' \
        'applied' in warnings


@pytest.mark.parametrize('scale', [0.0, 0.2, -0.5])
def test_the_light_trees_cone_of_a_profile_holds_all_it_emits(scale):
    """`light_tree.emitting_angle`: past it (the profile's last lit vertical angle, mapped back through angleScale)
    the kernel weighs the emission 0, and just inside it does not: the tree's cone is exact, so leaving the light out
    where the cone cannot reach keeps the estimate unbiased."""
    from rtc.renderer.host.light_tree import emitting_angle
    from rtc.renderer.kernel.ies_profiles import ies_weight
    from rtc.renderer.kernel.tables import LF_IES
    prof = profile([0, 20, 40, 60, 90], [0], lambda t, p: np.where(t < 0.8, 100.0 - 50.0 * t, 0.0) + 0.0 * p)
    light = _light(ies=prof, ies_angle_scale=scale)
    theta = emitting_angle(light)
    block = np.concatenate([[len(prof.vertical), len(prof.horizontal)], prof.vertical, prof.horizontal,
                            prof.candela.ravel()])
    lf = np.zeros((1, 64))
    lf[0, LF_IES:LF_IES + 3] = (0.0, 1.0 + scale, 1.0)
    for t, lit in ((theta - 1e-3, True), (theta + 1e-3, False)):
        w = ies_weight(block, lf, 0, math.sin(t), 0.0, math.cos(t))
        assert (w > 0.0) == lit, (t, w)
    assert theta == pytest.approx(np.pi - (1.0 + scale) * (np.pi - np.radians(60.0)))


def test_the_light_tree_leaves_out_a_downlight_above_it():
    assert tree_leaves_out_above(_light(ies=profile([0, 30, 60], [0], lambda t, p: 100.0 + 0.0 * t * p)))
