"""A RectLight's image (`inputs:texture:file`): its texels multiply the emission over the rect, the image's top-left
corner at the light's local (+X, +Y) as the UsdLux schema puts it, in both integrators; the path integrator draws a
far rect's points by the image and weighs the rays that meet it by the same density.

Independent references: a rect whose image is black on one half lights the scene as a rect of half the size over
the other half does (pixel blocks, near and far, cook and path); a camera facing the light sees the image upright;
light sampling alone, BSDF sampling alone and MIS agree for a rect with one hot spot; the light's power (the light
tree's and the light choice's) is scaled by the image's mean."""
import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux

from rtc.renderer import description as D
from rtc.renderer.host.light_images import image_tables
from rtc.renderer.host.light_selection import light_phi
from rtc.renderer.host.render import Renderer
from rtc.renderer.options import RenderOptions
from rtc.renderer.usd.stage import read_stage
from tests.renderer.handmade import estimator_means, exr_file, look_at, ortho_down, quad, rect_light, scene

N = 32                                         # image pixels across the 6 x 6 film


def _half(n=64, lit='left'):
    """A 8 x n image, white on its `lit` half (columns), black on the other."""
    px = np.zeros((8, n, 3), np.float32)
    if lit == 'left':
        px[:, :n // 2] = 1.0
    else:
        px[:, n // 2:] = 1.0
    return D.Texture(path='/half.exr', pixels=px, wrap_s='clamp', wrap_t='clamp')


def _floor(light, textures=()):
    mats = [D.Material('/floor', diffuse=(0.6, 0.6, 0.6), roughness=0.7)]
    return scene([D.Container('/', meshes=[quad(12.0)])], mats, [light], ortho_down(width=6.0, y=5.0), width=N,
                 height=N, textures=textures)


def _imaged(light, texture):
    light.texture = 0
    return _floor(light, (texture,))


def _render(desc, integrator, spp):
    with Renderer(desc, threads=2) as r:
        return r.render(RenderOptions(spp=spp, integrator=integrator, max_depth=1, sampler='sobol')).image.astype(
            np.float64)


def _blocks(img, b=4):
    return img[..., 0].reshape(N // b, b, N // b, b).mean((1, 3))


@pytest.mark.parametrize('integrator', ['cook', 'path'])
@pytest.mark.parametrize('height', [0.5, 4.0])          # near (solid angle) and far (by the image) in path
def test_a_half_black_image_lights_as_the_rect_of_its_lit_half(integrator, height):
    """The image's left half (its top-left corner at local +X) is white: the light is the rect's +X half.  The
    rect's local X is world +X here, so a mirrored image would light the other side (a factor of ~4 in the
    blocks near the light)."""
    full = _imaged(rect_light((0.0, height, 0.0), 2.0, 1.0, (5.0,) * 3), _half(lit='left'))
    half = _floor(rect_light((0.5, height, 0.0), 1.0, 1.0, (5.0,) * 3))
    a, b = _render(full, integrator, 1024), _render(half, integrator, 1024)
    assert a.mean() == pytest.approx(b.mean(), rel=0.005)
    ba, bb = _blocks(a), _blocks(b)                  # (4 x 4 pixel blocks, their errors against the brightest)
    assert np.abs(ba - bb).max() < 0.015 * bb.max(), np.abs(ba - bb).max() / bb.max()
    if height < 1.0:
        assert bb[:, -2:].mean() > 3.0 * bb[:, :2].mean()           # (the reference is lopsided)


def test_a_camera_facing_the_light_sees_its_image_upright():
    """Four coloured quadrants; the camera looks at the emitting side with its up along the light's +Y: what it
    shows is the image as drawn (top-left red, top-right green, bottom-left blue, bottom-right white)."""
    px = np.zeros((16, 16, 3), np.float32)
    px[:8, :8] = (1, 0, 0)
    px[:8, 8:] = (0, 1, 0)
    px[8:, :8] = (0, 0, 1)
    px[8:, 8:] = (1, 1, 1)
    m = np.eye(4)                                        # local +Z = world -Y: the light emits up (+Y)
    m[:3, 0], m[:3, 1], m[:3, 2] = (1, 0, 0), (0, 0, 1), (0, -1, 0)
    light = D.Light(path='/rect', type=D.RECT, matrix=m, radiance=(1.0,) * 3, width=2.0, height=2.0, texture=0)
    cam = D.Camera(path='/cam', matrix=look_at((0.0, 4.0, 0.0), (0.0, 0.0, 0.0), up=(0.0, 0.0, 1.0)),
                   projection='orthographic', horizontal_aperture=2.0, vertical_aperture=2.0)
    desc = scene([D.Container('/', meshes=[quad(8.0, y=-1.0)])], [D.Material('/m')], [light], cam, width=16, height=16,
                 textures=(D.Texture(path='/q.exr', pixels=px, wrap_s='clamp', wrap_t='clamp'),))
    with Renderer(desc, threads=1) as r:
        img = r.render(RenderOptions(spp=4, integrator='path', max_depth=1)).image.astype(np.float64)
    quads = {'top-left': img[1:6, 1:6], 'top-right': img[1:6, 10:15], 'bottom-left': img[10:15, 1:6],
             'bottom-right': img[10:15, 10:15]}
    expect = {'top-left': (1, 0, 0), 'top-right': (0, 1, 0), 'bottom-left': (0, 0, 1), 'bottom-right': (1, 1, 1)}
    for name, block in quads.items():
        assert np.allclose(block.reshape(-1, block.shape[-1])[:, :3], expect[name], atol=1e-3), name


def _spot(n=32):
    """A dim image with one hot spot off-centre: most of the light from 1/64 of the rect."""
    px = np.full((n, n, 3), 0.02, np.float32)
    px[4:8, 20:24] = (40.0, 30.0, 20.0)
    return D.Texture(path='/spot.exr', pixels=px, wrap_s='clamp', wrap_t='clamp')


@pytest.mark.parametrize('height', [0.6, 5.0])
def test_light_and_bsdf_sampling_of_an_imaged_rect_agree(height):
    desc = _imaged(rect_light((0.2, height, -0.1), 1.5, 1.0, (0.5,) * 3), _spot())
    nee, bsdf, mis = estimator_means(desc, nee_spp=512, bsdf_spp=4096, mis_spp=512)
    assert mis > 1e-4
    assert nee == pytest.approx(mis, rel=0.01) and bsdf == pytest.approx(mis, rel=0.015), (nee, bsdf, mis)


def test_far_points_are_drawn_by_the_image():
    """Seen from far, light samples follow the image: the estimate of a floor lit by a rect with one hot spot is
    much less noisy than with the points drawn uniformly over the rect (the image tables dropped)."""
    desc = _imaged(rect_light((0.0, 5.0, 0.0), 1.5, 1.0, (0.5,) * 3), _spot())
    with Renderer(desc, threads=2) as r:
        ref = r.render(RenderOptions(spp=256, integrator='path', max_depth=1)).image.astype(np.float64)
        err = [np.sqrt(np.mean((r.render(RenderOptions(spp=4, seed=s, integrator='path', max_depth=1,
                                                       sampler='independent', strategy='nee')).image - ref) ** 2))
               for s in range(3)]
    uniform = _uniform_error(desc, ref)
    assert np.mean(err) < 0.3 * uniform, (np.mean(err), uniform)


def _uniform_error(desc, ref):
    """The same estimate's RMS error with the image's distribution dropped (uniform points, the image a factor)."""
    from benchmarks.bench_rect_images import uniform_renderer
    with uniform_renderer(desc, 2) as r:
        return np.mean([np.sqrt(np.mean((r.render(RenderOptions(
            spp=4, seed=s, integrator='path', max_depth=1, sampler='independent', strategy='nee')).image - ref) ** 2))
            for s in range(3)])


def test_the_power_of_an_imaged_rect_is_scaled_by_the_image_mean():
    desc = _imaged(rect_light((0.0, 2.0, 0.0), 2.0, 1.0, (5.0,) * 3), _half(lit='left'))
    with Renderer(desc, threads=1) as r:
        li_f = r.built.data.li_f
    plain = light_phi(desc, li_f, 10.0, {})
    imaged = light_phi(desc, li_f, 10.0, image_tables(desc)[2])
    assert imaged[0] == pytest.approx(0.5 * plain[0], rel=1e-9)
    assert plain[0] == pytest.approx(2.0 * 5.0, rel=1e-9)                # area x luminance


def _stage(tmp_path, texture):
    st = Usd.Stage.CreateNew(str(tmp_path / 'rect.usda'))
    UsdGeom.SetStageUpAxis(st, UsdGeom.Tokens.y)
    light = UsdLux.RectLight.Define(st, '/World/Panel')
    light.CreateWidthAttr(2.0)
    light.CreateHeightAttr(1.0)
    if texture is not None:
        light.CreateTextureFileAttr(Sdf.AssetPath(texture))
    UsdGeom.Xformable(light).AddTranslateOp().Set(Gf.Vec3d(0, 3, 0))
    cam = UsdGeom.Camera.Define(st, '/World/Camera')
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 1, 8))
    st.Save()
    return tmp_path / 'rect.usda'


def test_the_stage_reader_reads_a_rect_light_image(tmp_path):
    exr_file(tmp_path / 'panel.exr', np.full((4, 8, 3), 0.5, np.float32))
    desc = read_stage(str(_stage(tmp_path, 'panel.exr')))
    (light,) = desc.lights
    assert light.type == D.RECT and light.texture >= 0
    tex = desc.textures[light.texture]
    assert (tex.wrap_s, tex.wrap_t) == ('clamp', 'clamp') and tex.pixels.shape[:2] == (4, 8)
    assert not any('texture' in w for w in desc.warnings), desc.warnings


def test_a_missing_rect_light_image_is_warned_and_the_light_kept(tmp_path):
    desc = read_stage(str(_stage(tmp_path, 'nowhere.exr')))
    (light,) = desc.lights
    assert light.texture == -1
    assert any('/World/Panel' in w and 'nowhere.exr' in w for w in desc.warnings), desc.warnings


@pytest.mark.parametrize('where, alpha, metallic', [((0.3, 1.8, -4.6), 0.3, False),     # near: solid angle
                                                    ((1.0, 0.0, 9.0), 0.3, False),      # far: by the image
                                                    ((0.3, 0.0, -4.0), 0.0225, True)])  # a metal's lobe
def test_a_ray_meeting_an_imaged_rect_gets_the_light_samples_emission_and_pdf(where, alpha, metallic):
    """For each light sample of a rect with one hot spot, a ray from the vertex along its direction meets the light
    at its distance, and the emission `shape_emission` gives that ray, weighed as if the BSDF had drawn it with
    the light sample's pdf, is half the sample's own: the image is read at the same point, and the ray that meets
    the light is weighed by the density the light sample was drawn with (the MIS weights sum to 1)."""
    import math
    from rtc.renderer.host.build import build
    from rtc.renderer.host.light_selection import path_lights
    from rtc.renderer.kernel import lobe_sampling as R
    from rtc.renderer.kernel.integrator import new_tile_lights
    from rtc.renderer.kernel.light_sampling import hit_shape, sample_ld_lobe, shape_emission
    from rtc.renderer.kernel.light_tree import light_pmf
    from tests.accuracy.test_lobe_sampling import CENTRE, H, W, vertex
    desc = _imaged(rect_light(tuple(CENTRE), W, H, (5.0,) * 3), _spot())
    built = build(desc)
    try:
        S = built.data
        L, _ = path_lights(desc, S.li_f, built.top.bounds(), len(built.top.groups))
        vtx, sb, _ = vertex(S, where, CENTRE, alpha, metallic)
        lobe = R.glossy_lobe(sb, (vtx.tt, vtx.bb, vtx.ns))
        assert (lobe[4] == 1.0) == metallic
        pmf = light_pmf(L, vtx.p, vtx.ns, 0)
        met, spread = 0, []
        for u in np.random.default_rng(3).random((300, 2)):
            wi, dist, Le, pdf, delta = sample_ld_lobe(S, L, 0, vtx, (float(u[0]), float(u[1])))
            if not pdf > 0.0:
                continue
            t, _ = hit_shape(S, L, 0, vtx.p, wi, math.inf, vtx.p)
            assert t == pytest.approx(dist, rel=1e-9)
            e = shape_emission(S, L, 0, (vtx.p, wi), t, (vtx.p, vtx.ns, pmf * pdf, 0, lobe, (-1.0, -1.0, -1.0), False),
                               new_tile_lights())
            assert np.allclose(e, 0.5 * np.asarray(Le), rtol=1e-6, atol=0.0), (e, Le)
            spread.append(Le[0])
            met += 1
        assert met > 100 and max(spread) > 100 * min(spread)            # (samples on the spot and off it)
    finally:
        built.close()


def _quadrants():
    px = np.zeros((16, 16, 3), np.float32)
    px[:8, :8], px[:8, 8:], px[8:, :8], px[8:, 8:] = (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1)
    return px


def _facing_stage(tmp_path, mirrored):
    """A 2 x 2 RectLight with the quadrant image before an orthographic camera that looks at its emitting side,
    its up along the light's +Y; the light mirrored by a scale of -1 along its X, or not."""
    exr_file(tmp_path / 'quadrants.exr', _quadrants())
    name = 'mirrored' if mirrored else 'plain'
    st = Usd.Stage.CreateNew(str(tmp_path / f'{name}.usda'))
    UsdGeom.SetStageUpAxis(st, UsdGeom.Tokens.y)
    light = UsdLux.RectLight.Define(st, '/World/Panel')
    light.CreateWidthAttr(2.0)
    light.CreateHeightAttr(2.0)
    light.CreateTextureFileAttr(Sdf.AssetPath('quadrants.exr'))
    if mirrored:
        light.AddScaleOp().Set(Gf.Vec3f(-1.0, 1.0, 1.0))
    floor = UsdGeom.Mesh.Define(st, '/World/Back')          # (behind the light: unlit, black)
    floor.CreatePointsAttr([(-5, -5, 3), (5, -5, 3), (5, 5, 3), (-5, 5, 3)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    cam = UsdGeom.Camera.Define(st, '/World/Camera')
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 0, -4))
    cam.AddRotateYOp().Set(180.0)                            # (looking along +Z at the light's -Z face)
    cam.CreateProjectionAttr(UsdGeom.Tokens.orthographic)
    cam.CreateHorizontalApertureAttr(20.0)                   # (tenths of a unit: 2 units across)
    cam.CreateVerticalApertureAttr(20.0)
    st.Save()
    return read_stage(str(tmp_path / f'{name}.usda'))


def test_a_mirrored_light_shows_its_image_mirrored(tmp_path):
    """Through the stage reader: the light as authored shows the image upright (its top-left red at the camera's
    top-left); mirrored along its X, the image mirrored left to right (not turned upside down, which the rigid
    frame alone would give)."""
    images = []
    for mirrored in (False, True):
        desc = _facing_stage(tmp_path, mirrored)
        desc.settings.width = desc.settings.height = 16
        with Renderer(desc, threads=1) as r:
            images.append(r.render(RenderOptions(spp=4, integrator='path', max_depth=1)).image[..., :3].astype(
                np.float64))
    plain, mirrored = images
    inner = {'top-left': (slice(3, 6), slice(3, 6)), 'top-right': (slice(3, 6), slice(10, 13)),
             'bottom-left': (slice(10, 13), slice(3, 6)), 'bottom-right': (slice(10, 13), slice(10, 13))}
    colour = {'top-left': (1, 0, 0), 'top-right': (0, 1, 0), 'bottom-left': (0, 0, 1), 'bottom-right': (1, 1, 1)}
    across = {'top-left': 'top-right', 'top-right': 'top-left', 'bottom-left': 'bottom-right',
              'bottom-right': 'bottom-left'}
    for name, window in inner.items():
        assert np.allclose(plain[window], colour[name], atol=1e-3), name
        assert np.allclose(mirrored[window], colour[across[name]], atol=1e-3), name


def test_the_image_tables_are_inverted_as_a_sorted_search_does():
    """`dome_sampling.invert` (a dome's and a rect's image tables): the bin of u is the largest i with cdf[i] <= u,
    as numpy's sorted search finds it, empty bins (repeated values) skipped, at the ends too."""
    from rtc.renderer.kernel.dome_sampling import invert
    rng = np.random.default_rng(11)
    for n in (1, 2, 3, 7, 64, 97):
        w = rng.random(n) * (rng.random(n) > 0.3)
        w[rng.integers(n)] += 0.1
        cdf = np.concatenate([[0.0], np.cumsum(w) / w.sum()])
        cdf[-1] = 1.0
        pad = np.concatenate([rng.random(5), cdf])            # (at an offset, as in the flat tables)
        for u in np.concatenate([rng.random(200), cdf[cdf < 1.0], [0.0, 0.99999994]]):     # (u < 1, as drawn)
            i, frac, p = invert.py_func(pad, 5, n, u)
            assert i == np.searchsorted(cdf, u, side='right') - 1
            assert p == cdf[i + 1] - cdf[i] and (p == 0.0 or 0.0 <= frac <= 1.0)


@pytest.mark.parametrize('integrator', ['cook', 'path'])
@pytest.mark.parametrize('shape', [(1, 1), (1, 7), (5, 1), (3, 4)])
def test_a_constant_image_scales_the_light_by_its_value(integrator, shape):
    """An image of one value v everywhere (of any size, one texel too) renders v times the light without it, near
    and far: exactly in cook (the same points, uniform by area); in path the far points are drawn by the image's
    distribution, uniform too but from other sample values (its columns run along -X), so there the same image
    within its noise (4 x 4 blocks within 1.5 % of the peak at 1024 spp)."""
    v = np.float32(0.37)
    tex = D.Texture(path='/v.exr', pixels=np.full(shape + (3,), v, np.float32), wrap_s='clamp', wrap_t='clamp')
    spp = 16 if integrator == 'cook' else 1024
    for height in (0.5, 4.0):
        plain = _render(_floor(rect_light((0.2, height, 0.1), 1.5, 1.0, (5.0,) * 3)), integrator, spp)
        imaged = _render(_imaged(rect_light((0.2, height, 0.1), 1.5, 1.0, (5.0,) * 3), tex), integrator, spp)
        assert plain.max() > 0.0
        if integrator == 'cook':
            assert np.allclose(imaged, float(v) * plain, rtol=1e-5, atol=1e-12), height
        else:
            ba, bb = _blocks(imaged), float(v) * _blocks(plain)
            assert np.abs(ba - bb).max() < 0.015 * bb.max(), (height, np.abs(ba - bb).max() / bb.max())


@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_a_black_image_puts_the_light_out(integrator):
    """An image of zeros: the light emits nothing (no NaN from its empty tables or its power of 0), the floor black
    under it, in both integrators."""
    tex = D.Texture(path='/black.exr', pixels=np.zeros((4, 4, 3), np.float32), wrap_s='clamp', wrap_t='clamp')
    for height in (0.5, 4.0):
        img = _render(_imaged(rect_light((0.0, height, 0.0), 1.5, 1.0, (5.0,) * 3), tex), integrator, 8)
        assert np.isfinite(img).all() and img[..., :3].max() == 0.0


def test_a_light_image_authored_with_the_wrong_type_is_warned_and_the_light_kept(tmp_path):
    """`inputs:texture:file` authored as a string or a number (the schema says asset), on a RectLight or a DomeLight,
    and `inputs:shaping:ies:file` as a string: each light kept without its image or profile, a warning naming the
    prim, the attribute and the authored type; an empty asset path is no image, silently; a file that is no image
    is named."""
    (tmp_path / 'bad.usda').write_text('''#usda 1.0
def RectLight "Text"
{
    string inputs:texture:file = "panel.png"
}
def RectLight "Number"
{
    int inputs:texture:file = 3
}
def RectLight "Empty"
{
    asset inputs:texture:file = @@
}
def RectLight "NotAnImage"
{
    asset inputs:texture:file = @bad.usda@
}
def DomeLight "Sky"
{
    string inputs:texture:file = "sky.exr"
}
def SphereLight "Lamp" (
    prepend apiSchemas = ["ShapingAPI"]
)
{
    string inputs:shaping:ies:file = "lamp.ies"
}
''')
    desc = read_stage(str(tmp_path / 'bad.usda'))
    assert len(desc.lights) == 6 and all(light.texture == -1 and light.ies is None for light in desc.lights)
    for name, kind in (('/Text', 'string'), ('/Number', 'int'), ('/Sky', 'string')):
        assert any(w.startswith(f'{name}.inputs:texture:file: authored as {kind}') for w in desc.warnings), name
    assert any(w.startswith('/Lamp.inputs:shaping:ies:file: authored as string') for w in desc.warnings)
    assert any('/NotAnImage' in w and 'bad.usda' in w for w in desc.warnings)
    assert not any('/Empty' in w for w in desc.warnings)
