"""UDIM textures (a UsdUVTexture whose file names `<UDIM>`: `usd/materials._udim`, `kernel/textures.udim_tile`), as
Storm reads them: tile 1001 + 10 floor(t) + floor(s) at (s - floor s, t - floor t), the tiles found by
`UsdShade.UdimUtils` against the layer that authored the path; a missing tile reads as 0 with the texture's scale
and bias (Storm draws it black); no tile at all: the texture's fallback.  Measured against OpenUSD's own UDIM test
files and baselines in the notes of benchmarks/RESULTS.md."""
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from rtc.renderer.host.build import build
from rtc.renderer.host.render import Renderer
from rtc.renderer.host.surface_lights import texture_mean
from rtc.renderer.kernel.tables import TI_UDIM
from rtc.renderer.options import RenderOptions
from rtc.renderer.usd.stage import read_stage
from tests.renderer.handmade import exr_file

RED, CYAN, YELLOW, GREY = (0.5, 0.0, 0.0), (0.0, 0.6, 0.7), (0.8, 0.7, 0.0), 0.3


def _tiles(folder: Path, name='tex'):
    """Tiles 1001 (red), 1002 (2 x 4: its top two rows yellow, the others cyan) and 1012 (one grey channel) of
    `name`_<UDIM>.exr in folder; 1003, 1011 and 1013 missing."""
    folder.mkdir(parents=True, exist_ok=True)
    exr_file(folder / f'{name}_1001.exr', np.full((4, 4, 3), RED))
    exr_file(folder / f'{name}_1002.exr', np.array([[YELLOW] * 2] * 2 + [[CYAN] * 2] * 2))
    exr_file(folder / f'{name}_1012.exr', np.full((3, 5, 1), GREY))


def _material(stage, path, file, scale=None, bias=None, fallback=None, cutout=False):
    """A black UsdPreviewSurface whose emissiveColor reads `file` at the primvar st; `cutout`: whose emissiveColor
    is white and whose opacity reads the file's r channel, cut at opacityThreshold 0.1."""
    mat = UsdShade.Material.Define(stage, path)
    sh = UsdShade.Shader.Define(stage, path + '/Surface')
    sh.CreateIdAttr('UsdPreviewSurface')
    sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).Set((0.0, 0.0, 0.0))
    sh.CreateInput('specularColor', Sdf.ValueTypeNames.Color3f).Set((0.0, 0.0, 0.0))
    sh.CreateInput('useSpecularWorkflow', Sdf.ValueTypeNames.Int).Set(1)
    tex = UsdShade.Shader.Define(stage, path + '/Tex')
    tex.CreateIdAttr('UsdUVTexture')
    tex.CreateInput('file', Sdf.ValueTypeNames.Asset).Set(Sdf.AssetPath(file))
    for name, value in (('scale', scale), ('bias', bias), ('fallback', fallback)):
        if value is not None:
            tex.CreateInput(name, Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(*value))
    if cutout:
        sh.CreateInput('emissiveColor', Sdf.ValueTypeNames.Color3f).Set((1.0, 1.0, 1.0))
        sh.CreateInput('opacityThreshold', Sdf.ValueTypeNames.Float).Set(0.1)
        sh.CreateInput('opacity', Sdf.ValueTypeNames.Float).ConnectToSource(
            tex.CreateOutput('r', Sdf.ValueTypeNames.Float))
    else:
        sh.CreateInput('emissiveColor', Sdf.ValueTypeNames.Color3f).ConnectToSource(
            tex.CreateOutput('rgb', Sdf.ValueTypeNames.Float3))
    reader = UsdShade.Shader.Define(stage, path + '/Reader')
    reader.CreateIdAttr('UsdPrimvarReader_float2')
    reader.CreateInput('varname', Sdf.ValueTypeNames.String).Set('st')
    tex.CreateInput('st', Sdf.ValueTypeNames.Float2).ConnectToSource(
        reader.CreateOutput('result', Sdf.ValueTypeNames.Float2))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    return mat


def _stage(folder: Path, file='./tex_<UDIM>.exr', **inputs):
    """A quad over [0, 3] x [0, -2] in x, z with st = (x, -z), seen from above by an orthographic camera that
    frames it whole (60 x 40 pixels: a tile 20 x 20), emitting its UDIM texture; a dome of intensity 0."""
    stage = Usd.Stage.CreateNew(str(folder / 'quad.usda'))
    UsdGeom.SetStageUpAxis(stage, 'Y')
    mesh = UsdGeom.Mesh.Define(stage, '/Quad')
    mesh.CreatePointsAttr([(0, 0, 0), (3, 0, 0), (3, 0, -2), (0, 0, -2)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    UsdGeom.PrimvarsAPI(mesh).CreatePrimvar('st', Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex).Set(
        [(0, 0), (3, 0), (3, 2), (0, 2)])
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(_material(stage, '/M', file, **inputs))
    UsdLux.DomeLight.Define(stage, '/Dome').CreateIntensityAttr(0.0)
    cam = UsdGeom.Camera.Define(stage, '/Cam')
    cam.CreateProjectionAttr(UsdGeom.Tokens.orthographic)
    cam.CreateHorizontalApertureAttr(30.0)
    cam.CreateVerticalApertureAttr(20.0)
    cam.AddTranslateOp().Set(Gf.Vec3d(1.5, 5.0, -1.0))
    cam.AddRotateXOp().Set(-90.0)
    stage.GetRootLayer().Save()
    return stage


def _tile_colours(desc, integrator='path'):
    """The rendered radiance at the middle of each tile's square, {(column, row): rgb}, and at the middle of
    tile 1002's bottom and top halves, checked constant over the 8 x 8 pixels around each."""
    with Renderer(desc, threads=1) as r:
        img = r.render(RenderOptions(width=60, height=40, spp=4, integrator=integrator, max_depth=1, threads=1,
                                     filter='box')).image.astype(np.float64)
    out = {}
    for col in range(3):
        for row in range(2):
            y = 40 - 20 * row - 10                              # (image rows run down, t up)
            x = 20 * col + 10
            half = img[y - 4:y + 4, x - 4:x + 4] if (col, row) != (1, 0) else None
            if half is not None:
                assert np.ptp(half.reshape(-1, 3), axis=0).max() <= 1e-6
                out[col, row] = tuple(half[0, 0])
    out['bottom'], out['top'] = tuple(img[35, 30]), tuple(img[24, 30])      # (t 0.225, 0.775)
    return out


@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_tiles_are_read_where_their_numbers_say_and_missing_ones_are_black(tmp_path, integrator):
    _tiles(tmp_path)
    desc = read_stage(_stage(tmp_path))
    assert desc.warnings == []
    assert len(desc.textures) == 1 and len(desc.textures[0].tiles) == 20
    got = _tile_colours(desc, integrator)
    np.testing.assert_allclose(got[0, 0], RED, atol=1e-6)
    np.testing.assert_allclose(got['bottom'], CYAN, atol=1e-6)             # tile 1002, t up within the tile
    np.testing.assert_allclose(got['top'], YELLOW, atol=1e-6)
    np.testing.assert_allclose(got[2, 0], 0.0, atol=1e-6)                 # 1003: missing
    np.testing.assert_allclose(got[0, 1], 0.0, atol=1e-6)                 # 1011: missing
    np.testing.assert_allclose(got[1, 1], (GREY,) * 3, atol=1e-6)         # 1012: one channel, grey
    np.testing.assert_allclose(got[2, 1], 0.0, atol=1e-6)


def test_scale_and_bias_apply_to_every_tile_and_to_the_missing_ones(tmp_path):
    """As OpenUSD's usdUdimsScaleAndBias baseline shows: its missing tiles are the bias's blue."""
    _tiles(tmp_path)
    got = _tile_colours(read_stage(_stage(tmp_path, scale=(2, 1, 1, 1), bias=(0, 0, 0.25, 0))))
    np.testing.assert_allclose(got[0, 0], (1.0, 0.0, 0.25), atol=1e-6)
    np.testing.assert_allclose(got[2, 0], (0.0, 0.0, 0.25), atol=1e-6)
    np.testing.assert_allclose(got[1, 1], (2 * GREY, GREY, GREY + 0.25), atol=1e-6)


def test_a_scalar_input_reads_its_channel_from_the_tiles(tmp_path):
    """opacity from the r channel of the tiles, cut at 0.1 (`kernel/textures.sample_channel`): present where r is
    0.5 (1001), 0.8 (1002's top rows) or 0.3 (1012's one grey channel), cut where it is 0 (1002's bottom rows, the
    missing tiles)."""
    _tiles(tmp_path)
    got = _tile_colours(read_stage(_stage(tmp_path, cutout=True)))
    for where, present in (((0, 0), 1), ('top', 1), ((1, 1), 1), ('bottom', 0), ((2, 0), 0), ((0, 1), 0),
                           ((2, 1), 0)):
        np.testing.assert_allclose(got[where], (present,) * 3, atol=1e-6, err_msg=str(where))


def test_no_tile_at_all_is_the_fallback_and_is_named(tmp_path):
    desc = read_stage(_stage(tmp_path, file='./nothing_<UDIM>.exr', fallback=(0, 0, 1, 1)))
    assert desc.warnings == ['/M/Tex: texture "./nothing_<UDIM>.exr" not found (no UDIM tile)']
    got = _tile_colours(desc)
    np.testing.assert_allclose(got[2, 1], (0.0, 0.0, 1.0), atol=1e-6)


def test_an_unreadable_tile_is_named_and_read_as_missing(tmp_path):
    _tiles(tmp_path)
    (tmp_path / 'tex_1003.exr').write_bytes(b'not an image')
    desc = read_stage(_stage(tmp_path))
    assert len(desc.warnings) == 1 and 'tex_1003.exr' in desc.warnings[0]
    got = _tile_colours(desc)
    np.testing.assert_allclose(got[2, 0], 0.0, atol=1e-6)
    np.testing.assert_allclose(got[0, 0], RED, atol=1e-6)


def test_a_relative_path_finds_its_tiles_beside_the_layer_that_authored_it(tmp_path):
    """The material lives in looks/looks.usda, its tiles in looks/maps; the stage that references it one folder up."""
    _tiles(tmp_path / 'looks' / 'maps')
    looks = Usd.Stage.CreateNew(str(tmp_path / 'looks' / 'looks.usda'))
    _material(looks, '/M', './maps/tex_<UDIM>.exr')
    looks.GetRootLayer().Save()
    stage = _stage(tmp_path, file='./unused_<UDIM>.exr')
    stage.RemovePrim('/M')
    stage.DefinePrim('/M').GetReferences().AddReference('./looks/looks.usda', '/M')
    desc = read_stage(stage)
    assert desc.warnings == []
    got = _tile_colours(desc)
    np.testing.assert_allclose(got[0, 0], RED, atol=1e-6)
    np.testing.assert_allclose(got[1, 1], (GREY,) * 3, atol=1e-6)


def test_a_udim_textures_mean_is_its_tiles_mean(tmp_path):
    """The light tree's power of an emissive UDIM surface: the mean of its 20 tiles (the missing ones 0)."""
    _tiles(tmp_path)
    built = build(read_stage(_stage(tmp_path)))
    try:
        assert built.data.tex_i[0, TI_UDIM] >= 0
        expected = (np.array(RED) + (np.array(YELLOW) + np.array(CYAN)) / 2 + GREY) / 20
        np.testing.assert_allclose(texture_mean(built.data, 0), expected, rtol=1e-6)
    finally:
        built.close()


def test_rtc_info_lists_a_udim_textures_tiles(tmp_path):
    from rtc.renderer.host.info import describe
    _tiles(tmp_path)
    text = describe(read_stage(_stage(tmp_path)))
    assert f'{tmp_path}/tex_<UDIM>.exr (3 UDIM tiles of 20)' in text


def test_a_udim_path_on_a_light_is_named_and_not_read(tmp_path):
    _tiles(tmp_path)
    stage = _stage(tmp_path)
    UsdLux.DomeLight(stage.GetPrimAtPath('/Dome')).CreateTextureFileAttr(Sdf.AssetPath('./tex_<UDIM>.exr'))
    desc = read_stage(stage)
    assert any('a UDIM texture ("./tex_<UDIM>.exr") on a light is not read' in w for w in desc.warnings)
