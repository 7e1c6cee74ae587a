"""UsdTransform2d between a UsdUVTexture's inputs:st and its primvar reader (`usd/materials._st_transform`,
`kernel/textures._footprint`): the coordinates scaled, rotated counter-clockwise, then translated, as the spec
and Storm apply them; nested transforms composed.  A quad whose texture reads transformed coordinates renders as
the same quad with those coordinates authored."""
import math
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from rtc.renderer.host.render import Renderer
from rtc.renderer.options import RenderOptions
from rtc.renderer.usd.stage import read_stage
from tests.renderer.handmade import exr_file

CORPUS = Path(__file__).resolve().parents[3] / 'shared' / 'corpus' / 'usd'
ST = [(0, 0), (1, 0), (1, 1), (0, 1)]


def _stage(tmp_path, transforms=(), st=ST):
    """A quad with texture coordinates `st` whose diffuseColor reads a 4 x 4 image of distinct colours through
    the UsdTransform2d chain `transforms` [(rotation, scale, translation), ...] (the first nearest the texture)."""
    rng = np.random.default_rng(5)
    image = exr_file(tmp_path / 'grid.exr', rng.uniform(0.05, 0.95, (4, 4, 3)))
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, 'Y')
    mesh = UsdGeom.Mesh.Define(stage, '/Quad')
    mesh.CreatePointsAttr([(-1, 0, 1), (1, 0, 1), (1, 0, -1), (-1, 0, -1)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    UsdGeom.PrimvarsAPI(mesh).CreatePrimvar('st', Sdf.ValueTypeNames.TexCoord2fArray,
                                            UsdGeom.Tokens.vertex).Set(st)
    mat = UsdShade.Material.Define(stage, '/M')
    sh = UsdShade.Shader.Define(stage, '/M/Surface')
    sh.CreateIdAttr('UsdPreviewSurface')
    tex = UsdShade.Shader.Define(stage, '/M/Tex')
    tex.CreateIdAttr('UsdUVTexture')
    tex.CreateInput('file', Sdf.ValueTypeNames.Asset).Set(image)
    tex.CreateInput('sourceColorSpace', Sdf.ValueTypeNames.Token).Set('raw')
    sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).ConnectToSource(
        tex.CreateOutput('rgb', Sdf.ValueTypeNames.Float3))
    reader = UsdShade.Shader.Define(stage, '/M/Reader')
    reader.CreateIdAttr('UsdPrimvarReader_float2')
    reader.CreateInput('varname', Sdf.ValueTypeNames.String).Set('st')
    downstream = tex.CreateInput('st', Sdf.ValueTypeNames.Float2)
    for k, (rotation, scale, translation) in enumerate(transforms):
        xf = UsdShade.Shader.Define(stage, f'/M/T{k}')
        xf.CreateIdAttr('UsdTransform2d')
        xf.CreateInput('rotation', Sdf.ValueTypeNames.Float).Set(rotation)
        xf.CreateInput('scale', Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(*scale))
        xf.CreateInput('translation', Sdf.ValueTypeNames.Float2).Set(Gf.Vec2f(*translation))
        downstream.ConnectToSource(xf.CreateOutput('result', Sdf.ValueTypeNames.Float2))
        downstream = xf.CreateInput('in', Sdf.ValueTypeNames.Float2)
    downstream.ConnectToSource(reader.CreateOutput('result', Sdf.ValueTypeNames.Float2))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(mat)
    UsdLux.DomeLight.Define(stage, '/Dome').CreateIntensityAttr(1.0)
    cam = UsdGeom.Camera.Define(stage, '/Cam')
    cam.AddTranslateOp().Set(Gf.Vec3d(0.0, 3.0, 0.0))
    cam.AddRotateXOp().Set(-90.0)
    return stage


def _apply(transforms, st):
    """The transforms' map of st, the nearest the reader first (the spec's order: scale, rotate, translate)."""
    out = []
    for s, t in st:
        for rotation, (sx, sy), (tx, ty) in reversed(transforms):
            c, n = math.cos(math.radians(rotation)), math.sin(math.radians(rotation))
            s, t = c * sx * s - n * sy * t + tx, n * sx * s + c * sy * t + ty
        out.append((s, t))
    return out


CHAINS = [
    [(45.0, (1.0, 1.0), (0.5, -0.2))],
    [(-90.0, (2.0, 2.0), (0.0, 1.0))],
    [(30.0, (0.5, 2.0), (0.1, 0.0)), (-60.0, (1.5, 1.0), (0.0, 0.3))],
]


@pytest.mark.parametrize('chain', CHAINS)
def test_the_map_read_is_the_specs(tmp_path, chain):
    desc = read_stage(_stage(tmp_path, chain))
    a, b, c, d, e, f = desc.textures[0].transform
    for (s, t), (s2, t2) in zip(ST, _apply(chain, ST)):
        assert (a * s + b * t + c, d * s + e * t + f) == pytest.approx((s2, t2), abs=1e-6)   # (float inputs)


@pytest.mark.parametrize('chain', CHAINS[1:])
@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_a_transformed_texture_renders_as_the_coordinates_transformed(tmp_path, chain, integrator):
    """(An affine map commutes with interpolation across the triangles: the two quads read the same texels.)"""
    images = []
    for stage in (_stage(tmp_path, chain), _stage(tmp_path, (), [tuple(p) for p in _apply(chain, ST)])):
        with Renderer(read_stage(stage), threads=1) as r:
            images.append(r.render(RenderOptions(width=40, height=40, spp=4, integrator=integrator, max_depth=2,
                                                 threads=1)).image.astype(np.float64))
    a, b = images
    assert b.std() > 0.05                                     # (the texture's texels are seen)
    assert np.abs(a - b).max() <= 2e-4 * b.max()


def test_a_nonfinite_transform_is_named_and_ignored(tmp_path):
    desc = read_stage(_stage(tmp_path, [(float('nan'), (1.0, 1.0), (0.0, 0.0))]))
    assert desc.textures[0].transform == (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)
    assert any(w.startswith('/M/T0: a value that is not finite') for w in desc.warnings)


def test_openusd_transform2d_file():
    """OpenUSD's testPreviewSurfaceTransform2d.usda: its four materials' maps."""
    found = sorted(CORPUS.rglob('testPreviewSurfaceTransform2d.usda')) if CORPUS.is_dir() else []
    if not found:
        pytest.skip('the shared corpus is not here')
    got = sorted(tuple(round(x, 6) for x in t.transform) for t in read_stage(str(found[0])).textures)
    h = round(math.sqrt(0.5), 6)
    assert got == sorted([(1.0, 0.0, 0.0, 0.0, 1.0, 0.0), (h, -h, 0.5, h, h, -0.2), (0.5, 0.0, 0.0, 0.0, 1.0, 0.0),
                          (0.0, 2.0, 0.0, -2.0, 0.0, 1.0)])
