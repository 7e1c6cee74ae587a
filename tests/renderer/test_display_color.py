"""primvars:displayColor that varies over a mesh (uniform, vertex, varying or faceVarying, indexed or not) and
no usable bound material: the mesh keeps its colours per triangle corner (`Mesh.colors`, `usd/geometry.py`) and
the fallback material multiplies its white diffuse by them, interpolated at each hit (`shapes.corner_color`), as
Storm draws it; a constant one, or one on another kind of gprim, stays the material's one colour (the mean where
it varies)."""
import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from rtc.renderer.host.build import build
from rtc.renderer.host.render import Renderer
from rtc.renderer.kernel.records import Hit
from rtc.renderer.kernel.shapes import corner_color
from rtc.renderer.options import RenderOptions
from rtc.renderer.usd.stage import read_stage

POINTS = [(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1), (0, 0, 2)]
COLOURS = [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (1.0, 1.0, 0.0), (0.2, 0.4, 0.6)]


def _mesh(st, path, interpolation, values, indices=None, left=False, counts=(4, 3), faces=(0, 1, 2, 3, 3, 2, 4)):
    mesh = UsdGeom.Mesh.Define(st, path)
    mesh.CreatePointsAttr(POINTS)
    mesh.CreateFaceVertexCountsAttr(list(counts))
    mesh.CreateFaceVertexIndicesAttr(list(faces))
    if left:
        mesh.CreateOrientationAttr(UsdGeom.Tokens.leftHanded)
    if values is not None:
        pv = mesh.CreateDisplayColorPrimvar(interpolation)
        pv.Set(values)
        if indices is not None:
            pv.SetIndices(indices)
    return mesh


def _stage():
    st = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(st, 'Y')
    return st


def _read(st):
    desc = read_stage(st)
    return desc, {m.path: m for c in desc.containers for m in c.meshes}


@pytest.mark.parametrize('interpolation, values, indices', [
    ('vertex', COLOURS, None),
    ('varying', COLOURS, None),
    ('vertex', COLOURS[::-1], [4, 3, 2, 1, 0]),                      # indexed: the same colours
])
@pytest.mark.parametrize('left, scale', [(False, 1.0), (True, 1.0), (False, -1.0)])
def test_vertex_colours_follow_their_vertices(interpolation, values, indices, left, scale):
    """Whatever the winding does (leftHanded, a mirroring scale), each triangle corner keeps the colour of the
    vertex it is."""
    st = _stage()
    mesh = _mesh(st, '/M', interpolation, values, indices, left)
    mesh.AddScaleOp().Set(Gf.Vec3f(scale, 1.0, 1.0))
    desc, meshes = _read(st)
    m = meshes['/M']
    assert m.colors.shape == (3, 3, 3) and desc.materials[m.material].vertex_colors
    assert desc.materials[m.material].diffuse == (1.0, 1.0, 1.0)
    np.testing.assert_array_equal(m.colors, np.array(COLOURS, np.float32)[m.triangles])
    tri = m.points[m.triangles]                   # (and the winding: -Y as authored, +Y leftHanded; a mirror in x
    side = np.sign(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, 1])        # keeps the outside)
    assert np.all(side == (1 if left else -1))


def test_uniform_and_face_varying_colours_per_corner():
    st = _stage()
    _mesh(st, '/U', 'uniform', COLOURS[:2])
    fv = [COLOURS[k % 5] for k in range(7)]
    _mesh(st, '/F', 'faceVarying', fv)
    desc, meshes = _read(st)
    np.testing.assert_array_equal(meshes['/U'].colors, np.array([[COLOURS[0]] * 3, [COLOURS[0]] * 3,
                                                                 [COLOURS[1]] * 3], np.float32))
    # the quad's corners 0-3 fanned into (0, 1, 2), (0, 2, 3); the triangle's are corners 4-6
    np.testing.assert_array_equal(meshes['/F'].colors, np.array([[fv[0], fv[1], fv[2]], [fv[0], fv[2], fv[3]],
                                                                 [fv[4], fv[5], fv[6]]], np.float32))


def test_constant_bound_mismatched_and_other_gprims():
    """A constant colour is the material's own (no per-corner colours); a bound material is not shaded by
    displayColor (Storm neither, without a primvar reader); a colour count that fits no interpolation is warned
    and its mean used; a Cylinder with per-face colours keeps one colour, their mean (a Cube's are kept per face:
    `test_mesh_adapters.py`)."""
    st = _stage()
    _mesh(st, '/Const', 'constant', [(0.3, 0.2, 0.1)])
    _mesh(st, '/Same', 'vertex', [(0.5, 0.5, 0.5)] * 5)               # varies in name only
    bound = _mesh(st, '/Bound', 'vertex', COLOURS)
    mat = UsdShade.Material.Define(st, '/Mat')
    sh = UsdShade.Shader.Define(st, '/Mat/S')
    sh.CreateIdAttr('UsdPreviewSurface')
    sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).Set((0.1, 0.6, 0.2))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    UsdShade.MaterialBindingAPI.Apply(bound.GetPrim()).Bind(mat)
    _mesh(st, '/Odd', 'vertex', COLOURS[:3])                           # 3 colours, 5 points
    cylinder = UsdGeom.Cylinder.Define(st, '/Cylinder')
    cylinder.CreateDisplayColorPrimvar('uniform').Set([(1, 0, 0), (0, 1, 0)] * 3)
    desc, meshes = _read(st)
    material = lambda path: desc.materials[meshes[path].material]
    assert meshes['/Const'].colors is None and material('/Const').diffuse == pytest.approx((0.3, 0.2, 0.1))
    assert meshes['/Same'].colors is None and material('/Same').diffuse == pytest.approx((0.5, 0.5, 0.5))
    assert not material('/Bound').vertex_colors and material('/Bound').diffuse == pytest.approx((0.1, 0.6, 0.2))
    assert material('/Odd').vertex_colors
    np.testing.assert_allclose(meshes['/Odd'].colors, np.full((3, 3, 3), 1 / 3), rtol=1e-6)
    assert any('/Odd: primvars:displayColor: 3 values do not match interpolation "vertex"' in w for w in desc.warnings)
    assert meshes['/Cylinder'].colors is None and material('/Cylinder').diffuse == pytest.approx((0.5, 0.5, 0.0))


def test_a_hit_gets_its_corners_colours_interpolated():
    """`corner_color` at barycentrics (u, v) of a triangle: (1 - u - v) c0 + u c1 + v c2 of its corners' colours;
    white on a gprim without them."""
    st = _stage()
    _mesh(st, '/M', 'vertex', COLOURS)
    _mesh(st, '/Plain', None, None)
    desc, meshes = _read(st)
    built = build(desc)
    try:
        S = built.data
        gp = {m.path: S.pr_gp_start[k] + j for k, c in enumerate(desc.containers) for j, m in enumerate(c.meshes)}
        tris = np.array(COLOURS)[meshes['/M'].triangles]
        for prim in range(3):
            for u, v in ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.2, 0.3), (0.6, 0.1)):
                want = (1 - u - v) * tris[prim, 0] + u * tris[prim, 1] + v * tris[prim, 2]
                got = corner_color(S, gp['/M'], Hit(0, 0, 0, prim, u, v, 1.0))
                np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-7)
        assert corner_color(S, gp['/Plain'], Hit(0, 0, 0, 1, 0.2, 0.3, 1.0)) == (1.0, 1.0, 1.0)
    finally:
        built.close()


def _lit(split: bool):
    """A quad of two triangles, one red one green, under a rect light: one mesh with uniform displayColor, or
    (split) two meshes of one triangle each with constant displayColor."""
    st = _stage()
    if split:
        for k, (faces, colour) in enumerate((((0, 1, 2), COLOURS[0]), ((0, 2, 3), COLOURS[1]))):
            _mesh(st, f'/T{k}', 'constant', [colour], counts=(3,), faces=faces)
    else:
        _mesh(st, '/Q', 'uniform', COLOURS[:2], counts=(3, 3), faces=(0, 1, 2, 0, 2, 3))
    light = UsdLux.RectLight.Define(st, '/Light')
    light.CreateIntensityAttr(20.0)
    light.AddTranslateOp().Set(Gf.Vec3d(0.3, 2.0, 0.2))
    light.AddRotateXOp().Set(-90.0)
    cam = UsdGeom.Camera.Define(st, '/Cam')
    cam.AddTranslateOp().Set(Gf.Vec3d(0.0, 3.0, 3.0))
    cam.AddRotateXOp().Set(-45.0)
    return st


@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_per_face_colours_render_as_the_faces_split_in_one_colour_each(integrator):
    images = []
    for split in (False, True):
        with Renderer(read_stage(_lit(split)), threads=1) as r:
            images.append(r.render(RenderOptions(width=48, height=36, spp=4, integrator=integrator, max_depth=3,
                                                 threads=1)).image.astype(np.float64))
    a, b = images
    red, green = b[..., 0] > 4 * b[..., 1], b[..., 1] > 4 * b[..., 0]
    assert red.sum() > 100 and green.sum() > 100                       # both faces seen, each its colour
    assert np.abs(a - b).max() <= 1e-5 * b.max()
