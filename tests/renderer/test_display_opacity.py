"""primvars:displayOpacity, as Storm's fallback material reads it, and opacity primvars read by a
UsdPrimvarReader_float: a constant one is the fallback material's opacity (the first of several values, clamped to
[0, 1]); one that varies over a mesh, a Cube or a point cloud is kept per corner (the A of `Mesh.colors`,
`usd/geometry.corner_values`) and multiplies the material's opacity at each hit (`shapes.corner_opacity`), as
Storm draws it; a material whose opacity reads another primvar that varies keeps it per corner where every material
bound to the mesh reads that one (`usd/corner_primvars.py`).  Renders: a per-face opacity draws as subsets of those
constant opacities do, and a ramp of opacities across an emissive card is seen as its closed form."""
import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from rtc.renderer.host.render import Renderer
from rtc.renderer.options import RenderOptions
from rtc.renderer.usd.stage import read_stage

POINTS = [(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1), (0, 0, 2)]
OPACITIES = [0.1, 0.3, 0.5, 0.7, 0.9]


def _stage():
    st = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(st, 'Y')
    return st


def _mesh(st, path='/M', points=POINTS, counts=(4, 3), faces=(0, 1, 2, 3, 3, 2, 4)):
    mesh = UsdGeom.Mesh.Define(st, path)
    mesh.CreatePointsAttr(points)
    mesh.CreateFaceVertexCountsAttr(list(counts))
    mesh.CreateFaceVertexIndicesAttr(list(faces))
    return mesh


def _opacity(gprim, interpolation, values, name='displayOpacity'):
    pv = UsdGeom.PrimvarsAPI(gprim).CreatePrimvar(name, Sdf.ValueTypeNames.FloatArray, interpolation)
    pv.Set(values)
    return pv


def _read(st):
    desc = read_stage(st)
    return desc, {m.path: m for c in desc.containers for m in c.meshes}


@pytest.mark.parametrize('interpolation, values, expected', [
    ('uniform', [0.25, 0.75], lambda tris: np.array([0.25, 0.25, 0.75])[:, None].repeat(3, 1)),
    ('vertex', OPACITIES, lambda tris: np.array(OPACITIES)[tris]),
    ('faceVarying', [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7], None),
])
@pytest.mark.parametrize('scale', [1.0, -1.0])
def test_a_varying_display_opacity_is_kept_per_corner(interpolation, values, expected, scale):
    """Each triangle corner keeps the opacity of its face, vertex or face corner (whatever a mirroring scale does to
    the winding); the colours stay white, the fallback material's opacity 1 times them."""
    st = _stage()
    mesh = _mesh(st)
    mesh.AddScaleOp().Set(Gf.Vec3f(scale, 1.0, 1.0))
    _opacity(mesh, interpolation, values)
    desc, meshes = _read(st)
    m = meshes['/M']
    mat = desc.materials[m.material]
    assert m.colors.shape == (3, 3, 4) and m.colors.dtype == np.float32
    assert mat.vertex_opacity and not mat.vertex_colors and mat.opacity == 1.0
    assert mat.diffuse == pytest.approx((0.18, 0.18, 0.18))
    np.testing.assert_array_equal(m.colors[..., :3], 1.0)
    if expected is not None:
        np.testing.assert_allclose(m.colors[..., 3], expected(m.triangles), rtol=1e-6)
    else:                                  # faceVarying: a corner's value is the one authored at its point in its face
        authored = {(f, v): a for (f, v), a in zip([(0, 0), (0, 1), (0, 2), (0, 3), (1, 3), (1, 2), (1, 4)], values)}
        face = np.array([0, 0, 1])
        want = [[authored[(face[t], v)] for v in m.triangles[t]] for t in range(3)]
        np.testing.assert_allclose(m.colors[..., 3], want, rtol=1e-6)


def test_a_mesh_whose_colour_and_opacity_vary_keeps_both():
    st = _stage()
    mesh = _mesh(st)
    colours = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (0.2, 0.4, 0.6)]
    mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex).Set(colours)
    _opacity(mesh, 'uniform', [0.2, 0.6])
    desc, meshes = _read(st)
    m = meshes['/M']
    mat = desc.materials[m.material]
    assert mat.vertex_colors and mat.vertex_opacity
    np.testing.assert_array_equal(m.colors[..., :3], np.array(colours, np.float32)[m.triangles])
    np.testing.assert_allclose(m.colors[..., 3], [[0.2] * 3, [0.2] * 3, [0.6] * 3], rtol=1e-6)


@pytest.mark.parametrize('values, interpolation, expected', [
    ([0.25], 'constant', 0.25),
    ([0.7, 1.0], 'constant', 0.7),             # several values of a constant primvar: the first, as Storm
    ([1.5], 'constant', 1.0),                  # clamped to [0, 1]
    ([-0.5], 'constant', 0.0),
    ([0.2, 0.4], 'uniform', 0.3),              # varying over a Sphere, which keeps nothing per corner: the mean
])
def test_a_display_opacity_that_is_not_kept_per_corner_is_the_fallback_materials_opacity(values, interpolation,
                                                                                          expected):
    st = _stage()
    sphere = UsdGeom.Sphere.Define(st, '/S')
    _opacity(sphere, interpolation, values)
    desc = read_stage(st)
    (s,) = [s for c in desc.containers for s in c.spheres]
    mat = desc.materials[s.material]
    assert mat.opacity == pytest.approx(expected) and not mat.vertex_opacity
    said = [w for w in desc.warnings if w.startswith('/S: primvars:displayOpacity')]
    if len(values) > 1 and interpolation == 'constant':
        assert said == ['/S: primvars:displayOpacity is constant with 2 values; the first used (as Storm)']
    elif not 0.0 <= values[0] <= 1.0:
        assert said == [f'/S: primvars:displayOpacity is {values[0]:g}, outside [0, 1]; clamped']
    else:
        assert said == []


def test_a_display_opacity_that_is_not_numbers_is_warned_and_opaque():
    st = _stage()
    st.GetRootLayer().ImportFromString('''#usda 1.0
def Sphere "S"
{
    string[] primvars:displayOpacity = ["half"]
}
''')
    desc = read_stage(st)
    (s,) = [s for c in desc.containers for s in c.spheres]
    assert desc.materials[s.material].opacity == 1.0
    assert any(w.startswith('/S: primvars:displayOpacity') for w in desc.warnings), desc.warnings


def test_a_cubes_uniform_opacity_follows_its_faces_as_its_colours_do():
    """A Cube's uniform primvars are given in Hydra's face order; its opacities go where its colours go."""
    st = _stage()
    cube = UsdGeom.Cube.Define(st, '/C')
    colours = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (0, 1, 1), (1, 0, 1)]
    opacities = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6]
    cube.CreateDisplayColorPrimvar(UsdGeom.Tokens.uniform).Set(colours)
    _opacity(cube, 'uniform', opacities)
    desc, meshes = _read(st)
    m = meshes['/C']
    assert m.colors.shape == (12, 3, 4)
    for tri in m.colors:
        face = colours.index(tuple(int(x) for x in tri[0, :3]))
        np.testing.assert_allclose(tri[:, 3], opacities[face], rtol=1e-6)


def test_a_point_clouds_opacity_is_kept_a_point():
    st = _stage()
    pts = UsdGeom.Points.Define(st, '/P')
    pts.CreatePointsAttr([(0, 0, 0), (2, 0, 0), (4, 0, 0)])
    _opacity(pts, 'vertex', [0.2, 0.5, 0.8])
    desc = read_stage(st)
    (s,) = [s for c in desc.containers for s in c.spheres]
    assert s.colors.shape == (3, 4) and desc.materials[s.material].vertex_opacity
    np.testing.assert_allclose(s.colors[:, 3], [0.2, 0.5, 0.8], rtol=1e-6)


def _preview(st, path, varname, emission=None):
    """A UsdPreviewSurface whose opacity reads primvar `varname`."""
    material = UsdShade.Material.Define(st, path)
    shader = UsdShade.Shader.Define(st, f'{path}/Surface')
    shader.CreateIdAttr('UsdPreviewSurface')
    reader = UsdShade.Shader.Define(st, f'{path}/Reader')
    reader.CreateIdAttr('UsdPrimvarReader_float')
    reader.CreateInput('varname', Sdf.ValueTypeNames.String).Set(varname)
    reader.CreateInput('fallback', Sdf.ValueTypeNames.Float).Set(1.0)
    shader.CreateInput('opacity', Sdf.ValueTypeNames.Float).ConnectToSource(
        reader.CreateOutput('result', Sdf.ValueTypeNames.Float))
    if emission is not None:
        shader.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).Set((0.0, 0.0, 0.0))
        shader.CreateInput('useSpecularWorkflow', Sdf.ValueTypeNames.Int).Set(1)
        shader.CreateInput('specularColor', Sdf.ValueTypeNames.Color3f).Set((0.0, 0.0, 0.0))
        shader.CreateInput('emissiveColor', Sdf.ValueTypeNames.Color3f).Set(emission)
    material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), 'surface')
    return material


def test_a_reader_of_another_opacity_primvar_keeps_it_per_corner():
    """A material whose opacity reads `alpha`, which varies over the mesh: per corner, the material's opacity 1
    times it; the mesh's displayOpacity, which varies too, is not what it keeps."""
    st = _stage()
    mesh = _mesh(st)
    _opacity(mesh, 'uniform', [0.2, 0.6], name='alpha')
    _opacity(mesh, 'uniform', [0.9, 0.9], name='displayOpacity')
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(_preview(st, '/Looks/A', 'alpha'))
    desc, meshes = _read(st)
    m = meshes['/M']
    mat = desc.materials[m.material]
    assert mat.vertex_opacity and mat.opacity == 1.0
    np.testing.assert_allclose(m.colors[..., 3], [[0.2] * 3, [0.2] * 3, [0.6] * 3], rtol=1e-6)
    assert not any('reads its mean' in w for w in desc.warnings), desc.warnings


def test_subsets_reading_different_opacity_primvars_read_their_means():
    st = _stage()
    mesh = _mesh(st)
    _opacity(mesh, 'uniform', [0.2, 0.6], name='alpha')
    _opacity(mesh, 'uniform', [0.4, 0.8], name='beta')
    for k, name in enumerate(('alpha', 'beta')):
        subset = UsdGeom.Subset.CreateGeomSubset(mesh, f'part{k}', UsdGeom.Tokens.face, [k],
                                                 familyName='materialBind')
        UsdShade.MaterialBindingAPI.Apply(subset.GetPrim()).Bind(_preview(st, f'/Looks/{name}', name))
    desc, meshes = _read(st)
    opacities = sorted(desc.materials[m.material].opacity for m in meshes.values())
    assert opacities == pytest.approx([0.4, 0.6])
    assert sum('reads its mean' in w for w in desc.warnings) == 2, desc.warnings


def test_an_emissive_point_clouds_opacity_reader_reads_its_mean():
    """A glowing cloud's balls are lights of one emission each: its opacity primvar is read as its mean (warned)."""
    st = _stage()
    pts = UsdGeom.Points.Define(st, '/P')
    pts.CreatePointsAttr([(0, 0, 0), (2, 0, 0)])
    _opacity(pts, 'vertex', [0.2, 0.6], name='alpha')
    UsdShade.MaterialBindingAPI.Apply(pts.GetPrim()).Bind(_preview(st, '/Looks/A', 'alpha', emission=(1, 1, 1)))
    desc = read_stage(st)
    (s,) = [s for c in desc.containers for s in c.spheres]
    mat = desc.materials[s.material]
    assert not mat.vertex_opacity and mat.opacity == pytest.approx(0.4)
    assert any('reads its mean' in w for w in desc.warnings), desc.warnings


def _lit_card_stage(per_face: bool):
    """A grey floor and, above it, a two-face card (faces x < 0 and x > 0) of opacities 0.25 and 0.75: as a
    displayOpacity per face, or as materialBind subsets bound to UsdPreviewSurfaces of those opacities and the
    fallback's other inputs (diffuse the displayColor, roughness 1); a distant light, a camera looking down at an
    angle."""
    st = _stage()
    floor = _mesh(st, '/Floor', [(-3, 0, -3), (3, 0, -3), (3, 0, 3), (-3, 0, 3)], (4,), (0, 3, 2, 1))
    floor.CreateDisplayColorPrimvar().Set([(0.5, 0.5, 0.5)])
    card = _mesh(st, '/Card', [(-1, 1, -1), (0, 1, -1), (1, 1, -1), (1, 1, 1), (0, 1, 1), (-1, 1, 1)], (4, 4),
                 (0, 5, 4, 1, 1, 4, 3, 2))
    card.CreateDisplayColorPrimvar().Set([(0.8, 0.3, 0.1)])
    if per_face:
        _opacity(card, 'uniform', [0.25, 0.75])
    else:
        for k, a in enumerate((0.25, 0.75)):
            material = UsdShade.Material.Define(st, f'/Looks/M{k}')
            shader = UsdShade.Shader.Define(st, f'/Looks/M{k}/Surface')
            shader.CreateIdAttr('UsdPreviewSurface')
            shader.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).Set((0.8, 0.3, 0.1))
            shader.CreateInput('roughness', Sdf.ValueTypeNames.Float).Set(1.0)
            shader.CreateInput('opacity', Sdf.ValueTypeNames.Float).Set(a)
            material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), 'surface')
            subset = UsdGeom.Subset.CreateGeomSubset(card, f'face{k}', UsdGeom.Tokens.face, [k],
                                                     familyName='materialBind')
            UsdShade.MaterialBindingAPI.Apply(subset.GetPrim()).Bind(material)
    sun = UsdLux.DistantLight.Define(st, '/Sun')
    sun.CreateIntensityAttr(3.0)
    sun.CreateNormalizeAttr(True)                  # (3 the irradiance it gives)
    sun.AddRotateXYZOp().Set(Gf.Vec3f(-70.0, 20.0, 0.0))
    cam = UsdGeom.Camera.Define(st, '/Cam')
    cam.AddTranslateOp().Set(Gf.Vec3d(0.0, 5.0, 4.0))
    cam.AddRotateXOp().Set(-50.0)
    return st


@pytest.mark.parametrize('integrator', ['path', 'cook'])
def test_a_per_face_opacity_draws_as_subsets_of_those_opacities(integrator):
    """The card's faces let the floor show through (and its shadow through) as the subsets' materials do: the same
    images, to float rounding."""
    images = []
    for per_face in (True, False):
        with Renderer(read_stage(_lit_card_stage(per_face))) as r:
            images.append(r.render(RenderOptions(width=48, height=36, spp=8, integrator=integrator, max_depth=3,
                                                 seed=3)).image.astype(np.float64))
    assert images[0].max() > 0.05
    np.testing.assert_allclose(images[0], images[1], rtol=1e-5, atol=1e-6)


def test_a_ramp_of_opacities_over_an_emissive_card_is_seen_as_its_closed_form():
    """A card emitting 1 that reflects nothing, its opacity a primvar that ramps from 0 at its left edge to 1 at
    its right (vertex-interpolated), fills the frame before a dome of radiance 0.25: a pixel's expected value is
    a + (1 - a) 0.25 at its centre (a is linear across the card, the box filter averages it over the pixel)."""
    st = _stage()
    card = _mesh(st, '/Card', [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], (4,), (0, 1, 2, 3))
    _opacity(card, 'vertex', [0.0, 1.0, 1.0, 0.0], name='alpha')
    UsdShade.MaterialBindingAPI.Apply(card.GetPrim()).Bind(_preview(st, '/Looks/Glow', 'alpha', emission=(1, 1, 1)))
    UsdLux.DomeLight.Define(st, '/Dome').CreateIntensityAttr(0.25)
    cam = UsdGeom.Camera.Define(st, '/Cam')
    cam.CreateFocalLengthAttr(50.0)
    cam.CreateHorizontalApertureAttr(36.0)
    cam.CreateVerticalApertureAttr(27.0)
    cam.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 2.0 * 50.0 / 36.0))      # the card's width fills the frame
    width, height = 32, 24
    with Renderer(read_stage(st)) as r:
        img = r.render(RenderOptions(width=width, height=height, spp=256, integrator='path', filter='box',
                                     seed=1)).image.astype(np.float64)[..., 0]
    a = (np.arange(width) + 0.5) / width
    np.testing.assert_allclose(img.mean(axis=0), a + (1.0 - a) * 0.25, atol=0.01)


def _strand(st, opacities, path='/Strand', basis=None, xs=(-1.5, -0.5, 0.5, 1.5)):
    curves = UsdGeom.BasisCurves.Define(st, path)
    curves.CreateTypeAttr('cubic' if basis else 'linear')
    if basis:
        curves.CreateBasisAttr(basis)
    curves.CreatePointsAttr([(x, 0.0, 0.0) for x in xs])
    curves.CreateCurveVertexCountsAttr([len(xs)])
    curves.CreateWidthsAttr([0.4])
    curves.CreateDisplayColorPrimvar().Set([(0.9, 0.2, 0.1)])
    _opacity(curves, 'vertex' if len(opacities) > 1 else 'constant', opacities)
    return curves


@pytest.mark.parametrize('basis, opacities, ends', [
    (None, [1.0, 0.5, 0.5, 0.0], [[1.0, 0.5], [0.5, 0.5], [0.5, 0.0]]),
    ('bspline', [0.0, 0.3, 0.6, 0.9], [[0.3, 0.6]]),          # a B-spline's ends: (p0 + 4 p1 + p2) / 6
])
def test_curves_keep_their_opacity_at_each_segment_end(basis, opacities, ends):
    st = _stage()
    _strand(st, opacities, basis=basis)
    desc = read_stage(st)
    (c,) = [c for k in desc.containers for c in k.curves]
    assert c.colors.shape == (len(ends), 2, 4) and desc.materials[c.material].vertex_opacity
    np.testing.assert_allclose(c.colors[..., 3], ends, atol=1e-6)
    np.testing.assert_allclose(c.colors[..., :3], np.broadcast_to([1.0, 1.0, 1.0], (len(ends), 2, 3)))


def _strand_image(opacities, integrator):
    """A strand along x (its segments over x in [-1.5, -0.5], [-0.5, 0.5], [0.5, 1.5]) above a grey floor, lit
    straight down and seen from above: the frame spans x in [-2, 2] at the strand."""
    st = _stage()
    _strand(st, opacities)
    floor = _mesh(st, '/Floor', [(-4, -0.5, -4), (4, -0.5, -4), (4, -0.5, 4), (-4, -0.5, 4)], (4,), (0, 3, 2, 1))
    floor.CreateDisplayColorPrimvar().Set([(0.5, 0.5, 0.5)])
    sun = UsdLux.DistantLight.Define(st, '/Sun')
    sun.CreateIntensityAttr(3.0)
    sun.CreateNormalizeAttr(True)
    sun.AddRotateXOp().Set(-90.0)
    cam = UsdGeom.Camera.Define(st, '/Cam')
    cam.CreateFocalLengthAttr(50.0)
    cam.CreateHorizontalApertureAttr(50.0)
    cam.CreateVerticalApertureAttr(25.0)
    cam.AddTranslateOp().Set(Gf.Vec3d(0.0, 4.0, 0.0))
    cam.AddRotateXOp().Set(-90.0)
    with Renderer(read_stage(st)) as r:
        return r.render(RenderOptions(width=64, height=32, spp=16, integrator=integrator, max_depth=1,
                                      seed=5)).image.astype(np.float64)


@pytest.mark.parametrize('integrator', ['path', 'cook'])
def test_a_strand_of_varying_opacity_draws_each_constant_segment_as_that_opacity_does(integrator):
    """Opacities 0.3, 0.3, 0.8, 0.8 along the strand: its first segment (and its shadow) draws as a strand of
    opacity 0.3 does, its last as one of 0.8, to float rounding."""
    varying = _strand_image([0.3, 0.3, 0.8, 0.8], integrator)
    x = -2.0 + (np.arange(64) + 0.5) * 4.0 / 64
    for a, cols in ((0.3, (x > -1.4) & (x < -0.7)), (0.8, (x > 0.7) & (x < 1.4))):
        same = _strand_image([a], integrator)
        assert same[:, cols].max() > 0.05
        np.testing.assert_allclose(varying[:, cols], same[:, cols], rtol=1e-5, atol=1e-6)
