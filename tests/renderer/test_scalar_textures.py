"""UsdPreviewSurface roughness, metallic and opacity driven by a UsdUVTexture's r, g, b or a output (`usd/materials.py`,
`kernel/materials.scalars`), and opacityThreshold: a cut-out.  A texture of one value per channel renders as that
value authored on the input (to float32's rounding of the bilinear weights); the channel each output reads from
an image of 1 to 4 channels is the spec's; a cut-out renders as the geometry cut."""
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade

from rtc.renderer.usd.stage import read_stage
from tests.renderer.handmade import exr_file
from tests.renderer.usd_stages import light_and_camera, render

CORPUS = Path(__file__).resolve().parents[3] / 'shared' / 'corpus' / 'usd'
CHANNELS = (0.9, 0.2, 0.7, 0.5)          # r, g, b, a of the constant image


def _quad(st, path, x0, x1, z, y=0.0):
    mesh = UsdGeom.Mesh.Define(st, path)
    mesh.CreatePointsAttr([(x0, y, z[0]), (x1, y, z[0]), (x1, y, z[1]), (x0, y, z[1])])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    pv = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar('st', Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
    pv.Set([(0, 0), (1, 0), (1, 1), (0, 1)])
    return mesh


def _material(st, path, constants=None, textured=None, image=None):
    """A UsdPreviewSurface with `constants` {input: value} and `textured` {input: output of the UsdUVTexture
    reading `image` (raw colour space)}."""
    mat = UsdShade.Material.Define(st, path)
    sh = UsdShade.Shader.Define(st, f'{path}/Surface')
    sh.CreateIdAttr('UsdPreviewSurface')
    for name, value in (constants or {}).items():
        kind = Sdf.ValueTypeNames.Color3f if isinstance(value, tuple) else Sdf.ValueTypeNames.Float
        sh.CreateInput(name, kind).Set(value)
    if textured:
        tex = UsdShade.Shader.Define(st, f'{path}/Tex')
        tex.CreateIdAttr('UsdUVTexture')
        tex.CreateInput('file', Sdf.ValueTypeNames.Asset).Set(image)
        tex.CreateInput('sourceColorSpace', Sdf.ValueTypeNames.Token).Set('raw')
        tex.CreateInput('fallback', Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(0.3, 0.4, 0.6, 0.8))
        for name, output in textured.items():
            sh.CreateInput(name, Sdf.ValueTypeNames.Float).ConnectToSource(
                tex.CreateOutput(output, Sdf.ValueTypeNames.Float))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    return mat


def _metal_plane(tmp_path, textured: bool, coat: bool = False):
    """A plane of roughness g and metallic b of CHANNELS (`coat`: a plastic of clearcoat r and clearcoatRoughness
    a), from the image or authored."""
    st = Usd.Stage.CreateInMemory()
    image = exr_file(tmp_path / 'rgba.exr', np.broadcast_to(CHANNELS, (4, 4, 4)))
    inputs = {'clearcoat': 'r', 'clearcoatRoughness': 'a'} if coat else {'roughness': 'g', 'metallic': 'b'}
    if textured:
        mat = _material(st, '/M', {'diffuseColor': (0.9, 0.6, 0.3)}, inputs, image)
    else:
        mat = _material(st, '/M', {'diffuseColor': (0.9, 0.6, 0.3),
                                   **{name: CHANNELS['rgba'.index(c)] for name, c in inputs.items()}})
    UsdShade.MaterialBindingAPI.Apply(_quad(st, '/P', -1.5, 1.5, (-1.5, 1.5)).GetPrim()).Bind(mat)
    return light_and_camera(st)


@pytest.mark.parametrize('integrator', ['cook', 'path'])
@pytest.mark.parametrize('coat', [False, True])
def test_scalar_textures_render_as_their_channels_authored(tmp_path, integrator, coat):
    """Roughness and metallic, or clearcoat and clearcoatRoughness, from an image's channels."""
    a = render(_metal_plane(tmp_path, True, coat), integrator)
    b = render(_metal_plane(tmp_path, False, coat), integrator)
    assert b.max() > 0.05
    assert np.abs(a - b).max() <= 1e-4 * b.max()


def test_the_reader_records_texture_and_channel_and_the_fallback_channel(tmp_path):
    st = Usd.Stage.CreateInMemory()
    image = exr_file(tmp_path / 'rgba.exr', np.broadcast_to(CHANNELS, (4, 4, 4)))
    _material(st, '/M', textured={'roughness': 'g', 'metallic': 'b', 'opacity': 'a'}, image=image)
    _material(st, '/Missing', textured={'roughness': 'g', 'opacity': 'a'}, image=str(tmp_path / 'none.exr'))
    for path in ('/A', '/B'):
        mesh = _quad(st, path, -1, 1, (-1, 1))
        UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(UsdShade.Material.Get(st, '/M' if path == '/A'
                                                                                     else '/Missing'))
    desc = read_stage(st)
    m = {g.path: desc.materials[g.material] for c in desc.containers for g in c.gprims}
    a, b = m['/A'], m['/B']
    assert a.scalar_textures[0] >= 0 and a.scalar_textures == (a.scalar_textures[0],) * 3 + (-1, -1)
    assert a.scalar_channels == (1, 2, 3, 0, 0) and (a.roughness, a.metallic, a.opacity) == (1.0, 1.0, 1.0)
    assert b.scalar_textures == (-1,) * 5
    assert (b.roughness, b.opacity) == pytest.approx((0.4, 0.8))            # the fallback's g and a
    assert any('/Missing/Tex: texture' in w and 'not found' in w for w in desc.warnings)
    assert not [w for w in desc.warnings if 'not supported' in w]


@pytest.mark.parametrize('channels, expect', [
    (1, lambda px: (px[0], px[0], px[0], 1.0)),            # grey: r = g = b, no alpha
    (2, lambda px: (px[0], px[0], px[0], px[1])),          # grey and alpha
    (3, lambda px: (px[0], px[1], px[2], 1.0)),            # no alpha
    (4, lambda px: tuple(px)),
])
def test_each_output_reads_the_specs_channel_of_an_image(tmp_path, channels, expect):
    """`kernel/textures.sample_channel` at a texel's centre: that texel's value of the channel each output reads
    (UsdUVTexture: a one-channel image is grey, two are grey and alpha, three have an alpha of 1)."""
    from rtc.renderer.host.build import build
    from rtc.renderer.kernel.tables import MI_SCALAR_TEX, S_ROUGH
    from rtc.renderer.kernel.textures import sample_channel
    rng = np.random.default_rng(channels)
    pixels = rng.uniform(0.1, 0.9, (2, 2, channels)).astype(np.float32)
    st = Usd.Stage.CreateInMemory()
    mat = _material(st, '/M', textured={'roughness': 'r'}, image=exr_file(tmp_path / f'c{channels}.exr', pixels))
    UsdShade.MaterialBindingAPI.Apply(_quad(st, '/A', -1, 1, (-1, 1)).GetPrim()).Bind(mat)
    light_and_camera(st)
    built = build(read_stage(st))
    try:
        S = built.data
        tid = int(S.mat_i[:, MI_SCALAR_TEX + S_ROUGH].max())   # (the one texture)
        for row, col in ((0, 0), (1, 1), (0, 1)):
            s, t = (col + 0.5) / 2, 1.0 - (row + 0.5) / 2     # (t up: row 0 is the top)
            got = [sample_channel(S, tid, s, t, c) for c in range(4)]
            assert got == pytest.approx(expect(pixels[row, col].astype(np.float64)), abs=1e-6)
    finally:
        built.close()


def _cutout(tmp_path, cut: bool, glow: bool):
    """A white quad over a red floor; `cut`: the quad is twice as wide and its left half cut away (alpha 0.2
    under an opacityThreshold of 0.5, its right half alpha 0.8: opaque), else only the right half is there.
    `glow`: the floor emits its red and reflects nothing (no shadow on it)."""
    st = Usd.Stage.CreateInMemory()
    floor = _material(st, '/Red', {'diffuseColor': (0.0, 0.0, 0.0), 'emissiveColor': (0.8, 0.1, 0.1)} if glow
                      else {'diffuseColor': (0.8, 0.1, 0.1)})
    UsdShade.MaterialBindingAPI.Apply(_quad(st, '/Floor', -3, 3, (-3, 3)).GetPrim()).Bind(floor)
    if cut:
        image = exr_file(tmp_path / 'cut.exr', np.array([[[1, 1, 1, 0.2], [1, 1, 1, 0.8]]], np.float32))
        mat = _material(st, '/White', {'diffuseColor': (0.9, 0.9, 0.9), 'opacityThreshold': 0.5},
                        {'opacity': 'a'}, image)
        quad = _quad(st, '/Card', -0.8, 0.8, (-0.5, 0.5), y=0.4)
    else:
        mat = _material(st, '/White', {'diffuseColor': (0.9, 0.9, 0.9)})
        quad = _quad(st, '/Card', 0.0, 0.8, (-0.5, 0.5), y=0.4)
    UsdShade.MaterialBindingAPI.Apply(quad.GetPrim()).Bind(mat)
    return light_and_camera(st)


@pytest.mark.parametrize('integrator, glow', [('path', False), ('path', True), ('cook', True)])
def test_an_opacity_threshold_cuts_the_surface_out(tmp_path, integrator, glow):
    """Out of camera rays, and (path) of shadow rays: the cook integrator's shadow rays see every surface as
    opaque (as they see a constant opacity < 1), so it is compared on a floor that glows, where no shadow falls.
    Bilinear lookups blur the cut over one texel's width (the texture is 2 texels wide): the images are compared
    away from it."""
    a = render(_cutout(tmp_path, True, glow), integrator, spp=16)
    b = render(_cutout(tmp_path, False, glow), integrator, spp=16)
    assert b[..., 0].mean() > 0.05
    cols = np.r_[0:18, 30:48]                                 # away from the cut's blurred band
    assert np.abs(a[:, cols] - b[:, cols]).mean() <= 0.03 * b[:, cols].mean()
    assert a[:, cols].mean() == pytest.approx(b[:, cols].mean(), rel=0.02)


def test_roughness_test_usdz_reads_its_roughness_textures():
    """The corpus's RoughnessTest.usdz: three materials whose roughness is a texture's channel."""
    found = sorted(CORPUS.rglob('RoughnessTest.usdz')) if CORPUS.is_dir() else []
    if not found:
        pytest.skip('the shared corpus is not here')
    desc = read_stage(str(found[0]))
    tex = [m for m in desc.materials if m.path.split('/')[-1].startswith('Tex')]
    assert len(tex) == 3 and all(m.scalar_textures[0] >= 0 and m.roughness == 1.0 for m in tex)
    assert not [w for w in desc.warnings if 'not supported' in w]


def _glowing_card(tmp_path, cut: bool):
    """A card glowing warm over a grey floor (faintly lit by the rect light): cut out by its opacity texture's alpha
    (opacityThreshold 0.5: its half x > 0 stays), or its half x > 0 as geometry."""
    st = Usd.Stage.CreateInMemory()
    floor = _material(st, '/Grey', {'diffuseColor': (0.6, 0.6, 0.6)})
    UsdShade.MaterialBindingAPI.Apply(_quad(st, '/Floor', -3, 3, (-3, 3)).GetPrim()).Bind(floor)
    glow = {'diffuseColor': (0.0, 0.0, 0.0), 'emissiveColor': (4.0, 3.0, 2.0)}
    if cut:
        image = exr_file(tmp_path / 'cut.exr', np.array([[[1, 1, 1, 0.2], [1, 1, 1, 0.8]]], np.float32))
        mat = _material(st, '/Glow', {**glow, 'opacityThreshold': 0.5}, {'opacity': 'a'}, image)
        card = _quad(st, '/Card', -0.8, 0.8, (-0.5, 0.5), y=0.6)
    else:
        mat = _material(st, '/Glow', glow)
        card = _quad(st, '/Card', 0.0, 0.8, (-0.5, 0.5), y=0.6)
    UsdShade.MaterialBindingAPI.Apply(card.GetPrim()).Bind(mat)
    return light_and_camera(st, intensity=1.0)


def test_a_glowing_cut_out_is_a_light_that_lights_as_the_geometry_cut(tmp_path):
    """An emissive card cut out by an opacity texture is a light of the path integrator (its emission times its
    opacity at each point: `kernel/surface_lights._emission_at`; it was found by BSDF rays alone): the floor under it
    is lit as under the card cut as geometry, and light sampling, BSDF sampling and MIS agree on it."""
    from rtc.renderer.host.render import Renderer
    from rtc.renderer.options import RenderOptions
    desc = read_stage(_glowing_card(tmp_path, True))
    with Renderer(desc, threads=2) as r:
        assert r.path_lights().n_surface == 1

        def mean(strategy, spp):
            return np.mean([r.render(RenderOptions(width=48, height=36, spp=spp, seed=s, integrator='path', max_depth=1,
                                                   strategy=strategy, sampler='independent')).image.astype(np.float64)
                            for s in range(2)], 0)
        nee, bsdf, mis = mean('nee', 128), mean('bsdf', 512), mean('mis', 128)
    assert nee.mean() == pytest.approx(mis.mean(), rel=0.015) and bsdf.mean() == pytest.approx(mis.mean(), rel=0.02)
    a = render(_glowing_card(tmp_path, True), 'path', spp=32)
    b = render(_glowing_card(tmp_path, False), 'path', spp=32)
    rows = np.r_[24:36]                                       # the floor in front of the card (its glow, no card)
    assert b[rows].mean() > 0.05
    assert a[rows].mean() == pytest.approx(b[rows].mean(), rel=0.03)
