"""A UsdPreviewSurface's `normal` read from a UsdUVTexture (`usd/materials.py`, `kernel/normal_maps.py`): the
shading normal turned to the texture's tangent-space normal, x along dp/ds, y along dp/dt, z the surface's normal.
A quad whose normal map holds one normal renders as the same quad with that normal authored as its `normals`
(computed here from the texture coordinates' directions), in both integrators, placed as authored, rotated and
mirrored; a flat map renders as no map."""
import math
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from rtc.renderer.host.render import Renderer
from rtc.renderer.options import RenderOptions, resolve
from rtc.renderer.usd.stage import read_stage
from tests.renderer.handmade import exr_file
from tests.renderer.usd_stages import light_and_camera, render

CORPUS = Path(__file__).resolve().parents[3] / 'shared' / 'corpus' / 'usd'
TILT = (math.sin(0.6) * math.cos(0.4), math.sin(0.6) * math.sin(0.4), math.cos(0.6))   # a unit tangent normal
ST = [(0, 0), (1, 0), (1, 1), (0, 1)]               # s along +x, t along +z (`_quad`'s corners)
MIRRORED = [(1, 0), (0, 0), (0, 1), (1, 1)]         # s along -x


def _quad(st, path, coords=ST, normal=None):
    """A 2 x 2 quad in y = 0 facing +y, its corners' texture coordinates `coords`; `normal`: authored at every
    corner."""
    mesh = UsdGeom.Mesh.Define(st, path)
    mesh.CreatePointsAttr([(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1)])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    mesh.CreateSubdivisionSchemeAttr('none')
    UsdGeom.PrimvarsAPI(mesh).CreatePrimvar('st', Sdf.ValueTypeNames.TexCoord2fArray,
                                            UsdGeom.Tokens.vertex).Set(coords)
    if normal is not None:
        mesh.CreateNormalsAttr([normal] * 4)
        mesh.SetNormalsInterpolation(UsdGeom.Tokens.vertex)
    return mesh


def _material(st, image=None, output='rgb'):
    """A grey UsdPreviewSurface (roughness 0.6), its normal from `image` (raw, scale 2, bias -1) when given."""
    mat = UsdShade.Material.Define(st, '/M')
    sh = UsdShade.Shader.Define(st, '/M/Surface')
    sh.CreateIdAttr('UsdPreviewSurface')
    sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.6, 0.6, 0.6))
    sh.CreateInput('roughness', Sdf.ValueTypeNames.Float).Set(0.6)
    if image is not None:
        tex = UsdShade.Shader.Define(st, '/M/Normals')
        tex.CreateIdAttr('UsdUVTexture')
        tex.CreateInput('file', Sdf.ValueTypeNames.Asset).Set(image)
        tex.CreateInput('sourceColorSpace', Sdf.ValueTypeNames.Token).Set('raw')
        tex.CreateInput('scale', Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(2, 2, 2, 1))
        tex.CreateInput('bias', Sdf.ValueTypeNames.Float4).Set(Gf.Vec4f(-1, -1, -1, 0))
        sh.CreateInput('normal', Sdf.ValueTypeNames.Normal3f).ConnectToSource(
            tex.CreateOutput(output, Sdf.ValueTypeNames.Float3 if output == 'rgb' else Sdf.ValueTypeNames.Float))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    return mat


def _normal_image(tmp_path, n, name='n.exr'):
    """An image of tangent-space normal n everywhere (stored as (n + 1) / 2)."""
    return exr_file(tmp_path / name, np.broadcast_to((np.asarray(n) + 1.0) / 2.0, (4, 4, 3)))


def _stage(tmp_path, mapped, coords=ST, normal=None, placed=False, n=TILT):
    """The quad (under an Xform rotated 90 degrees about y and mirrored in x when `placed`) lit by a rect light;
    `mapped`: its normal from an image of n; `normal`: authored."""
    st = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(st, 'Y')
    xf = UsdGeom.Xform.Define(st, '/G')
    if placed:
        xf.AddRotateYOp().Set(90.0)
        xf.AddScaleOp().Set(Gf.Vec3f(-1.0, 1.0, 1.0))
    mat = _material(st, _normal_image(tmp_path, n) if mapped else None)
    UsdShade.MaterialBindingAPI.Apply(_quad(st, '/G/Q', coords, normal).GetPrim()).Bind(mat)
    return light_and_camera(st, at=(1.2, 1.0, 0.5), size=0.5, intensity=30.0)


def _expected(n, coords):
    """The object-space normal a constant map of tangent normal n gives `_quad` with texture coordinates
    `coords`: x along dp/ds (+x, or -x when s runs the other way), y along dp/dt (+z), z along +y."""
    sx = 1.0 if coords[1][0] > coords[0][0] else -1.0
    return (sx * n[0], n[2], n[1])


@pytest.mark.parametrize('integrator', ['cook', 'path'])
@pytest.mark.parametrize('coords, placed', [(ST, False), (MIRRORED, False), (ST, True)])
def test_a_constant_map_renders_as_its_normal_authored(tmp_path, integrator, coords, placed):
    mapped = render(_stage(tmp_path, True, coords, placed=placed), integrator)
    authored = render(_stage(tmp_path, False, coords, normal=_expected(TILT, coords), placed=placed), integrator)
    plain = render(_stage(tmp_path, False, coords, placed=placed), integrator)
    assert authored.max() > 0.05
    assert np.abs(mapped - authored).max() <= 1e-4 * authored.max()
    assert np.abs(plain - authored).max() > 0.1 * authored.max()      # (the tilt shows)


@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_a_flat_map_renders_as_no_map(tmp_path, integrator):
    flat = render(_stage(tmp_path, True, n=(0.0, 0.0, 1.0)), integrator)
    plain = render(_stage(tmp_path, False), integrator)
    assert np.abs(flat - plain).max() <= 1e-5 * plain.max()


def _sphere_stage(tmp_path, mapped, n):
    st = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(st, 'Y')
    mat = _material(st, _normal_image(tmp_path, n, f'n{n}.exr') if mapped else None)
    UsdShade.MaterialBindingAPI.Apply(UsdGeom.Sphere.Define(st, '/S').GetPrim()).Bind(mat)
    sun = UsdLux.DistantLight.Define(st, '/Sun')
    sun.CreateIntensityAttr(3.0)
    sun.CreateAngleAttr(0.0)
    sun.AddRotateYOp().Set(45.0)                     # (light from +x +z)
    cam = UsdGeom.Camera.Define(st, '/Cam')
    cam.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 6.0))
    return st


@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_a_spheres_map_tilts_along_its_parallels(tmp_path, integrator):
    """At the point facing +z, dp/ds runs along +x: a map tilting 35 degrees towards x turns the normal towards the
    light (from 45 degrees on the +x side), a tilt towards y turns it up (the light's cosine falls); a flat map
    changes nothing."""
    plain = render(_sphere_stage(tmp_path, False, None), integrator)
    flat = render(_sphere_stage(tmp_path, True, (0.0, 0.0, 1.0)), integrator)
    a = math.radians(35.0)
    towards_x = render(_sphere_stage(tmp_path, True, (math.sin(a), 0.0, math.cos(a))), integrator)
    towards_y = render(_sphere_stage(tmp_path, True, (0.0, math.sin(a), math.cos(a))), integrator)
    c = (slice(16, 20), slice(22, 26))               # (the centre of the 48 x 36 image)
    assert np.abs(flat - plain).max() <= 1e-5 * plain.max()
    lambert_x = math.cos(math.radians(10.0)) / math.cos(math.radians(45.0))        # 1.39
    lambert_y = math.cos(a) * math.cos(math.radians(45.0)) / math.cos(math.radians(45.0))   # 0.82
    assert towards_x[c].mean() / plain[c].mean() == pytest.approx(lambert_x, rel=0.08)
    assert towards_y[c].mean() / plain[c].mean() == pytest.approx(lambert_y, rel=0.08)


def test_the_reader_records_the_map_and_names_what_it_cannot_read(tmp_path, monkeypatch):
    st = _stage(tmp_path, True)
    desc = read_stage(st)
    m = next(m for m in desc.materials if m.path == '/M')
    assert m.normal_texture >= 0 and not [w for w in desc.warnings if 'normal' in w]
    assert scene_features_of(desc, monkeypatch).normal_maps
    assert not scene_features_of(read_stage(_stage(tmp_path, False)), monkeypatch).normal_maps
    st = Usd.Stage.CreateInMemory()                   # a channel, not rgb: named, not read
    mat = _material(st, _normal_image(tmp_path, TILT), output='r')
    sh = UsdShade.Shader.Get(st, '/M/Surface')
    disp = UsdShade.Shader.Define(st, '/M/Disp')
    disp.CreateIdAttr('UsdUVTexture')
    sh.CreateInput('displacement', Sdf.ValueTypeNames.Float).ConnectToSource(
        disp.CreateOutput('r', Sdf.ValueTypeNames.Float))
    UsdShade.MaterialBindingAPI.Apply(_quad(st, '/Q').GetPrim()).Bind(mat)
    desc = read_stage(st)
    assert next(m for m in desc.materials if m.path == '/M').normal_texture == -1
    assert any(w.startswith('/M: inputs:normal is driven by UsdUVTexture (/M/Normals, not its rgb), which is not '
                            "supported; the surface's own normals used") for w in desc.warnings), desc.warnings
    assert any(w.startswith('/M: inputs:displacement is driven by UsdUVTexture (/M/Disp), which is not supported')
               for w in desc.warnings), desc.warnings


def scene_features_of(desc, monkeypatch):
    """The `Features` a path render of description desc specialises its kernel for."""
    monkeypatch.setenv('RTC_KERNELS', 'specialized')
    with Renderer(desc, threads=1) as r:
        f = r.setup(resolve(RenderOptions(spp=1, integrator='path'), r.desc.settings)).features
    monkeypatch.setenv('RTC_KERNELS', 'general')
    return f


def test_openusd_normal_map_test_lights_the_walls_storm_lights(tmp_path):
    """OpenUSD's testPreviewSurfaceNormalMap.usda: planes of one normal-mapped material (grooves and ridges) lit
    from their side by a red light at x = -1.5.  The map is read; on the first plane, framed by a camera added here,
    the walls of the left circle's groove that the map turns towards the light brighten and the others darken: the
    right wall brightens, the left darkens, as in Pixar's baseline image for the test, where the right arc is red."""
    found = sorted(CORPUS.rglob('testPreviewSurfaceNormalMap.usda')) if CORPUS.is_dir() else []
    if not found:
        pytest.skip('the shared corpus is not here')
    images = []
    for mapped in (True, False):
        st = Usd.Stage.Open(str(found[0]))
        with Usd.EditContext(st, st.GetSessionLayer()):
            cam = UsdGeom.Camera.Define(st, '/Cam')
            cam.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 5.5))
            cam.CreateFocalLengthAttr(50.0)
        if not mapped:
            st.GetPrimAtPath('/Scene/Looks/Material/PbrPreview').GetAttribute('inputs:normal').ClearConnections()
        desc = read_stage(st)
        assert [m.normal_texture >= 0 for m in desc.materials if m.path == '/Scene/Looks/Material'] == [mapped]
        assert not [w for w in desc.warnings if 'not supported' in w], desc.warnings
        with Renderer(desc, threads=1) as r:
            images.append(r.render(RenderOptions(width=120, height=90, spp=4, integrator='path', max_depth=2,
                                                 threads=1)).image[..., 0].astype(np.float64))
    d = (images[0] - images[1])[54:, 12:60]            # (the lower left quarter: the left circle)
    rows, cols = np.nonzero(np.abs(d) > 0.2 * np.abs(d).max())
    brighter, darker = cols[d[rows, cols] > 0], cols[d[rows, cols] < 0]
    assert len(brighter) >= 5 and len(darker) >= 5
    assert brighter.mean() > darker.mean() + 5, (brighter.mean(), darker.mean())


@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_coordinates_that_do_not_vary_leave_the_normal_as_it_was(tmp_path, integrator):
    """Every corner at the same (s, t), or all on one line: no tangent frame (dp/ds is undefined), so the map is not
    applied (Storm's derivatives would be zero there too); the image is the unmapped quad's, and finite."""
    for coords in ([(0.3, 0.6)] * 4, [(0, 0), (0.5, 0.5), (1, 1), (0.5, 0.5)]):
        mapped = render(_stage(tmp_path, True, coords), integrator)
        plain = render(_stage(tmp_path, False, coords), integrator)
        assert np.isfinite(mapped).all() and plain.max() > 0.05
        assert np.abs(mapped - plain).max() <= 1e-6 * plain.max()
