"""Which primvar holds a gprim's texture coordinates (`usd/texture_coordinates.py`): where a mesh has several sets, the
one its material's texture reader names (through a material interface input and UsdTransform2d nodes), as Storm
reads it; else `st`, `UVMap`, or the first texCoord2f[]."""
import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from rtc.renderer.host.render import Renderer
from rtc.renderer.options import RenderOptions
from rtc.renderer.usd.stage import read_stage
from rtc.renderer.usd.texture_coordinates import uv_primvar
from tests.renderer.handmade import exr_file

A = [(0, 0), (1, 0), (1, 1), (0, 1)]
B = [(1, 1), (0, 1), (0, 0), (1, 0)]              # the image turned half a turn


def _quad(st, path, sets: dict, kind=Sdf.ValueTypeNames.TexCoord2fArray):
    mesh = UsdGeom.Mesh.Define(st, path)
    mesh.CreatePointsAttr([(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    mesh.CreateSubdivisionSchemeAttr('none')
    for name, values in sets.items():
        UsdGeom.PrimvarsAPI(mesh).CreatePrimvar(name, kind, UsdGeom.Tokens.vertex).Set(values)
    return mesh


def _material(st, image, varname, transform=False):
    """A UsdPreviewSurface whose diffuseColor is `image`, its coordinates from the primvar `varname` named through
    the material's `inputs:coords` (and a UsdTransform2d of identity when `transform`)."""
    mat = UsdShade.Material.Define(st, '/M')
    coords = mat.CreateInput('coords', Sdf.ValueTypeNames.String)
    coords.Set(varname)
    sh = UsdShade.Shader.Define(st, '/M/Surface')
    sh.CreateIdAttr('UsdPreviewSurface')
    tex = UsdShade.Shader.Define(st, '/M/Tex')
    tex.CreateIdAttr('UsdUVTexture')
    tex.CreateInput('file', Sdf.ValueTypeNames.Asset).Set(image)
    tex.CreateInput('sourceColorSpace', Sdf.ValueTypeNames.Token).Set('raw')
    reader = UsdShade.Shader.Define(st, '/M/Reader')
    reader.CreateIdAttr('UsdPrimvarReader_float2')
    reader.CreateInput('varname', Sdf.ValueTypeNames.String).ConnectToSource(coords)
    result = reader.CreateOutput('result', Sdf.ValueTypeNames.Float2)
    if transform:
        xf = UsdShade.Shader.Define(st, '/M/Xf')
        xf.CreateIdAttr('UsdTransform2d')
        xf.CreateInput('in', Sdf.ValueTypeNames.Float2).ConnectToSource(result)
        result = xf.CreateOutput('result', Sdf.ValueTypeNames.Float2)
    tex.CreateInput('st', Sdf.ValueTypeNames.Float2).ConnectToSource(result)
    sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).ConnectToSource(
        tex.CreateOutput('rgb', Sdf.ValueTypeNames.Float3))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    return mat


def _stage(tmp_path, sets, varname, kind=Sdf.ValueTypeNames.TexCoord2fArray, transform=False):
    st = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(st, 'Y')
    rng = np.random.default_rng(3)
    image = exr_file(tmp_path / 'grid.exr', rng.uniform(0.05, 0.95, (4, 4, 3)))
    mat = _material(st, image, varname, transform)
    UsdShade.MaterialBindingAPI.Apply(_quad(st, '/Q', sets, kind).GetPrim()).Bind(mat)
    sun = UsdLux.DistantLight.Define(st, '/Sun')
    sun.CreateIntensityAttr(3.0)
    sun.AddRotateXOp().Set(-90.0)
    cam = UsdGeom.Camera.Define(st, '/Cam')
    cam.AddTranslateOp().Set(Gf.Vec3d(0.0, 5.0, 0.0))
    cam.AddRotateXOp().Set(-90.0)
    return st


@pytest.mark.parametrize('sets, varname, kind, transform, expect', [
    ({'st': A, 'st_inverted': B}, 'st_inverted', Sdf.ValueTypeNames.TexCoord2fArray, False, 'st_inverted'),
    ({'st': A, 'st_inverted': B}, 'st_inverted', Sdf.ValueTypeNames.Float2Array, True, 'st_inverted'),
    ({'st': A, 'st_inverted': B}, 'st', Sdf.ValueTypeNames.TexCoord2fArray, False, 'st'),
    ({'map1': B}, 'map1', Sdf.ValueTypeNames.Float2Array, False, 'map1'),       # (float2[]: was not read)
    ({'st': A, 'uv2': B}, 'elsewhere', Sdf.ValueTypeNames.TexCoord2fArray, False, 'st'),   # (not on the mesh)
    ({'UVMap': A}, 'st', Sdf.ValueTypeNames.TexCoord2fArray, False, 'UVMap'),
])
def test_the_set_read_is_the_one_the_material_names(tmp_path, sets, varname, kind, transform, expect):
    st = _stage(tmp_path, sets, varname, kind, transform)
    assert uv_primvar(st.GetPrimAtPath('/Q')).GetPrimvarName() == expect


def test_a_mesh_renders_with_the_set_its_material_names(tmp_path):
    def render(st):
        with Renderer(read_stage(st), threads=1) as r:
            return r.render(RenderOptions(width=32, height=24, spp=2, integrator='cook', threads=1)).image

    both = render(_stage(tmp_path, {'st': A, 'st_inverted': B}, 'st_inverted'))
    only_b = render(_stage(tmp_path, {'st': B}, 'st'))
    only_a = render(_stage(tmp_path, {'st': A}, 'st'))
    assert np.array_equal(both, only_b)
    assert np.abs(both - only_a).max() > 0.1 * only_a.max()
