"""UsdPrimvarReader_float / _float3 driving UsdPreviewSurface inputs (`usd/materials.py`): each gprim bound to
the material gets its own primvar's value (found with inheritance: an instance's from its own ancestors), the
reader's fallback where it has none, its per-corner colours where displayColor varies over a mesh, as Storm
binds a gprim's primvars to its shader.  The images are checked against the same scenes with the values
authored on the shader itself."""
import os
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from rtc.renderer.host.render import Renderer
from rtc.renderer.options import RenderOptions
from rtc.renderer.usd.stage import read_stage

RED, BLUE = (0.8, 0.1, 0.1), (0.1, 0.2, 0.9)
CORPUS = Path(os.environ.get('RTC_SHARED', Path(__file__).resolve().parents[3] / 'shared')) / 'corpus' / 'usd'


def _material(st, path, readers=None, constants=None):
    """A UsdPreviewSurface whose inputs `readers` {input: (reader id, varname or None, fallback or None)} read
    primvars and whose inputs `constants` {input: value} are authored."""
    mat = UsdShade.Material.Define(st, path)
    sh = UsdShade.Shader.Define(st, f'{path}/Surface')
    sh.CreateIdAttr('UsdPreviewSurface')
    for name, value in (constants or {}).items():
        kind = Sdf.ValueTypeNames.Color3f if isinstance(value, tuple) else Sdf.ValueTypeNames.Float
        sh.CreateInput(name, kind).Set(value)
    for k, (name, (sid, varname, fallback)) in enumerate((readers or {}).items()):
        rd = UsdShade.Shader.Define(st, f'{path}/Reader{k}')
        rd.CreateIdAttr(sid)
        kind = Sdf.ValueTypeNames.Float if sid.endswith('_float') else Sdf.ValueTypeNames.Float3
        if varname is not None:
            rd.CreateInput('varname', Sdf.ValueTypeNames.String).Set(varname)
        if fallback is not None:
            rd.CreateInput('fallback', kind).Set(fallback)
        out = rd.CreateOutput('result', kind)
        sh.CreateInput(name, Sdf.ValueTypeNames.Color3f if kind == Sdf.ValueTypeNames.Float3
                       else Sdf.ValueTypeNames.Float).ConnectToSource(out)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    return mat


def _sphere(st, path, x, mat, colour=None, rough=None):
    s = UsdGeom.Sphere.Define(st, path)
    s.AddTranslateOp().Set(Gf.Vec3d(x, 0.0, 0.0))
    if colour is not None:
        s.CreateDisplayColorPrimvar().Set([colour])
    if rough is not None:                                   # a constant primvar of a scalar type
        UsdGeom.PrimvarsAPI(s.GetPrim()).CreatePrimvar('rough', Sdf.ValueTypeNames.Float).Set(rough)
    UsdShade.MaterialBindingAPI.Apply(s.GetPrim()).Bind(mat)
    return s


def _lit(st):
    UsdGeom.SetStageUpAxis(st, 'Y')
    light = UsdLux.RectLight.Define(st, '/Light')
    light.CreateIntensityAttr(30.0)
    light.CreateWidthAttr(3.0)
    light.CreateHeightAttr(3.0)
    light.AddTranslateOp().Set(Gf.Vec3d(0.0, 4.0, 2.0))
    light.AddRotateXOp().Set(-60.0)
    cam = UsdGeom.Camera.Define(st, '/Cam')
    cam.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 8.0))
    return st


def _two_spheres(read: bool):
    """Two spheres, red and blue, rough 0.3 and 0.7: one material reading their primvars, or (not read) each
    its own material with the values authored."""
    st = Usd.Stage.CreateInMemory()
    if read:
        mat = _material(st, '/Looks/M', {'diffuseColor': ('UsdPrimvarReader_float3', 'displayColor', None),
                                         'roughness': ('UsdPrimvarReader_float', 'rough', None)},
                        {'metallic': 0.5})
        _sphere(st, '/A', -1.2, mat, RED, 0.3)
        _sphere(st, '/B', 1.2, mat, BLUE, 0.7)
    else:
        for k, (path, x, colour, rough) in enumerate((('/A', -1.2, RED, 0.3), ('/B', 1.2, BLUE, 0.7))):
            mat = _material(st, f'/Looks/M{k}', constants={'diffuseColor': colour, 'roughness': rough,
                                                           'metallic': 0.5})
            _sphere(st, path, x, mat)
    return _lit(st)


def _materials(desc):
    """{gprim path: its Material} of a description's root container."""
    return {g.path: desc.materials[g.material] for c in desc.containers for g in c.gprims}


def test_each_gprim_reads_its_own_primvars():
    desc = read_stage(_two_spheres(True))
    m = _materials(desc)
    assert m['/A'].diffuse == pytest.approx(RED) and m['/A'].roughness == pytest.approx(0.3)
    assert m['/B'].diffuse == pytest.approx(BLUE) and m['/B'].roughness == pytest.approx(0.7)
    assert m['/A'].metallic == m['/B'].metallic == 0.5                  # the shader's own inputs kept
    assert not [w for w in desc.warnings if 'not supported' in w]


@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_primvars_read_render_as_the_values_authored(integrator):
    images = []
    for read in (True, False):
        with Renderer(read_stage(_two_spheres(read)), threads=1) as r:
            images.append(r.render(RenderOptions(width=64, height=32, spp=4, integrator=integrator, max_depth=3,
                                                 threads=1)).image.astype(np.float64))
    a, b = images
    assert np.array_equal(a, b)                                         # the same materials, bit for bit
    left, right = a[:, :32], a[:, 32:]
    assert left[..., 0].sum() > 3 * left[..., 2].sum() and right[..., 2].sum() > 3 * right[..., 0].sum()


def test_fallback_where_the_gprim_has_no_such_primvar():
    """The reader's authored fallback, else its Sdr default 0; a reader without varname reads nothing."""
    st = Usd.Stage.CreateInMemory()
    mat = _material(st, '/Looks/M', {'diffuseColor': ('UsdPrimvarReader_float3', 'tint', (0.0, 0.5, 1.0)),
                                     'roughness': ('UsdPrimvarReader_float', 'rough', None),
                                     'metallic': ('UsdPrimvarReader_float', None, 0.25)})
    _sphere(st, '/A', 0.0, mat, RED, None)
    desc = read_stage(st)
    m = _materials(desc)['/A']
    assert m.diffuse == pytest.approx((0.0, 0.5, 1.0)) and m.roughness == 0.0 and m.metallic == 0.25
    assert any('/Looks/M/Reader2: UsdPrimvarReader_float without inputs:varname' in w for w in desc.warnings)


def test_varname_through_the_material_interface_and_with_its_namespace():
    st = Usd.Stage.CreateInMemory()
    mat = _material(st, '/Looks/M', {'diffuseColor': ('UsdPrimvarReader_float3', None, None)})
    iface = mat.CreateInput('colourName', Sdf.ValueTypeNames.String)
    iface.Set('primvars:tint')
    UsdShade.Shader(st.GetPrimAtPath('/Looks/M/Reader0')).CreateInput(
        'varname', Sdf.ValueTypeNames.String).ConnectToSource(iface)
    s = _sphere(st, '/A', 0.0, mat)
    UsdGeom.PrimvarsAPI(s.GetPrim()).CreatePrimvar('tint', Sdf.ValueTypeNames.Color3fArray).Set([BLUE])
    assert _materials(read_stage(st))['/A'].diffuse == pytest.approx(BLUE)


@pytest.mark.parametrize('name', ['displayColor', 'tint'])
def test_instances_read_the_primvars_of_their_own_ancestors(name):
    """One prototype sphere under two instanceable Xforms, each with its own constant primvar (inherited by the
    sphere): each instance gets its colour (material sets), not the first instance's."""
    st = Usd.Stage.CreateInMemory()
    mat = _material(st, '/Looks/M', {'diffuseColor': ('UsdPrimvarReader_float3', name, None)})
    proto = UsdGeom.Xform.Define(st, '/Proto')
    proto.GetPrim().SetSpecifier(Sdf.SpecifierClass)
    ball = UsdGeom.Sphere.Define(st, '/Proto/Ball')
    UsdShade.MaterialBindingAPI.Apply(ball.GetPrim()).Bind(mat)
    for root, x, colour in (('L', -1.2, RED), ('R', 1.2, BLUE)):
        inst = UsdGeom.Xform.Define(st, f'/{root}')
        inst.GetPrim().GetReferences().AddInternalReference('/Proto')
        inst.GetPrim().SetInstanceable(True)
        inst.AddTranslateOp().Set(Gf.Vec3d(x, 0.0, 0.0))
        UsdGeom.PrimvarsAPI(inst.GetPrim()).CreatePrimvar(name, Sdf.ValueTypeNames.Color3fArray).Set([colour])
    _lit(st)
    desc = read_stage(st)
    colours = sorted(tuple(round(v, 4) for v in desc.materials[s[0]].diffuse) for s in desc.instances.material_sets)
    assert set(colours) >= {tuple(round(v, 4) for v in RED), tuple(round(v, 4) for v in BLUE)}
    with Renderer(desc, threads=1) as r:
        img = r.render(RenderOptions(width=64, height=32, spp=4, integrator='path', max_depth=2, threads=1)).image
    left, right = img[:, :32].astype(np.float64), img[:, 32:].astype(np.float64)
    assert left[..., 0].sum() > 3 * left[..., 2].sum() and right[..., 2].sum() > 3 * right[..., 0].sum()


def test_varying_display_color_and_opacity_reads_go_per_corner_and_another_is_averaged():
    """diffuseColor reading displayColor and opacity reading displayOpacity, both uniform over the mesh: per corner
    (the RGB and the A of `Mesh.colors`); roughness reading displayOpacity too: its mean, warned."""
    st = Usd.Stage.CreateInMemory()
    mat = _material(st, '/Looks/M', {'diffuseColor': ('UsdPrimvarReader_float3', 'displayColor', None),
                                     'opacity': ('UsdPrimvarReader_float', 'displayOpacity', None),
                                     'roughness': ('UsdPrimvarReader_float', 'displayOpacity', None)})
    mesh = UsdGeom.Mesh.Define(st, '/Q')
    mesh.CreatePointsAttr([(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1)])
    mesh.CreateFaceVertexCountsAttr([3, 3])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 0, 2, 3])
    mesh.CreateDisplayColorPrimvar(UsdGeom.Tokens.uniform).Set([RED, BLUE])
    mesh.CreateDisplayOpacityPrimvar(UsdGeom.Tokens.uniform).Set([0.2, 0.6])
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(mat)
    desc = read_stage(st)
    m = _materials(desc)['/Q']
    assert m.vertex_colors and m.diffuse == (1.0, 1.0, 1.0)
    assert m.vertex_opacity and m.opacity == 1.0 and m.roughness == pytest.approx(0.4)
    q = next(g for c in desc.containers for g in c.meshes)
    assert q.colors is not None and np.allclose(q.colors[0, :, :3], RED) and np.allclose(q.colors[1, :, :3], BLUE)
    np.testing.assert_allclose(q.colors[..., 3], [[0.2] * 3, [0.6] * 3], rtol=1e-6)
    mean = [w for w in desc.warnings if w.startswith('/Q: primvars:displayOpacity varies over it (uniform)')]
    assert len(mean) == 1 and 'reads its mean' in mean[0], desc.warnings


def _two_faces(st, path, mat, name, subsets=None):
    """Two triangles of a quad whose colour primvar `name` is red on one face and blue on the other (uniform), bound
    to `mat`, or with materialBind subsets of a face each bound to the materials `subsets`."""
    mesh = UsdGeom.Mesh.Define(st, path)
    mesh.CreatePointsAttr([(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)])       # (facing the camera of `_lit`)
    mesh.CreateFaceVertexCountsAttr([3, 3])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 0, 2, 3])
    UsdGeom.PrimvarsAPI(mesh.GetPrim()).CreatePrimvar(name, Sdf.ValueTypeNames.Color3fArray,
                                                      UsdGeom.Tokens.uniform).Set([RED, BLUE])
    if subsets is None:
        UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(mat)
    for k, m in enumerate(subsets or ()):
        sub = UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).CreateMaterialBindSubset(f'Face{k}', [k])
        UsdShade.MaterialBindingAPI.Apply(sub.GetPrim()).Bind(m)
    return mesh


@pytest.mark.parametrize('how', ['mesh', 'subsets'])
def test_another_varying_colour_read_goes_per_corner_as_display_color_does(how):
    """A mesh whose bound material (or each of its materialBind subsets' materials) reads a colour primvar other than
    displayColor that varies over it (`tint`, uniform) keeps that primvar per corner and shades by it, as Storm binds
    it: no warning, and the image is the one of the same mesh whose displayColor holds those colours (bit for bit)."""
    images = []
    for name in ('tint', 'displayColor'):
        st = Usd.Stage.CreateInMemory()
        mat = _material(st, '/Looks/M', {'diffuseColor': ('UsdPrimvarReader_float3', name, None)})
        _two_faces(st, '/Q', mat, name, None if how == 'mesh' else [mat, mat])
        _lit(st)
        desc = read_stage(st)
        assert not [w for w in desc.warnings if 'varies' in w], desc.warnings
        meshes = [g for c in desc.containers for g in c.meshes]
        colours = np.concatenate([g.colors for g in meshes]).reshape(-1, 3).astype(np.float64)
        assert {tuple(np.round(c, 4).tolist()) for c in colours} == {tuple(np.round(RED, 4)), tuple(np.round(BLUE, 4))}
        assert all(desc.materials[g.material].vertex_colors for g in meshes)
        with Renderer(desc, threads=1) as r:
            images.append(r.render(RenderOptions(width=32, height=32, spp=4, integrator='path', max_depth=2,
                                                 threads=1)).image)
    assert np.array_equal(images[0], images[1])
    assert images[0][..., 0].max() > 3 * images[0][..., 0].min() + 1e-3


def test_materials_that_read_other_colours_on_one_mesh_keep_display_color():
    """Subsets whose materials read two other colour primvars: the mesh keeps displayColor per corner (none here),
    and each reader reads its primvar's mean (warned), as before."""
    st = Usd.Stage.CreateInMemory()
    a = _material(st, '/Looks/A', {'diffuseColor': ('UsdPrimvarReader_float3', 'tint', None)})
    b = _material(st, '/Looks/B', {'diffuseColor': ('UsdPrimvarReader_float3', 'shade', None)})
    mesh = _two_faces(st, '/Q', a, 'tint', [a, b])
    UsdGeom.PrimvarsAPI(mesh.GetPrim()).CreatePrimvar('shade', Sdf.ValueTypeNames.Color3fArray,
                                                      UsdGeom.Tokens.uniform).Set([BLUE, RED])
    desc = read_stage(st)
    assert all(g.colors is None for c in desc.containers for g in c.meshes)
    assert sum('varies over it (uniform)' in w and 'reads its mean' in w for w in desc.warnings) == 2


@pytest.mark.parametrize('value, warned', [
    (['red'], 'is not a list of finite RGB colours'),
    ([(float('nan'), 0.0, 0.0)], 'is not a list of finite RGB colours'),
])
def test_unusable_primvar_values_give_the_fallback_by_name(value, warned):
    st = Usd.Stage.CreateInMemory()
    mat = _material(st, '/Looks/M', {'diffuseColor': ('UsdPrimvarReader_float3', 'tint', (0.0, 1.0, 0.0))})
    s = _sphere(st, '/A', 0.0, mat)
    kind = Sdf.ValueTypeNames.StringArray if isinstance(value[0], str) else Sdf.ValueTypeNames.Color3fArray
    UsdGeom.PrimvarsAPI(s.GetPrim()).CreatePrimvar('tint', kind).Set(value)
    desc = read_stage(st)
    assert _materials(desc)['/A'].diffuse == (0.0, 1.0, 0.0)
    assert any(w.startswith('/A: primvars:tint ' + warned) for w in desc.warnings), desc.warnings


def test_a_nonfinite_reader_fallback_is_zero_by_name():
    st = Usd.Stage.CreateInMemory()
    mat = _material(st, '/Looks/M', {'roughness': ('UsdPrimvarReader_float', 'rough', float('inf'))})
    _sphere(st, '/A', 0.0, mat)
    desc = read_stage(st)
    assert _materials(desc)['/A'].roughness == 0.0
    assert any(w.startswith('/Looks/M/Reader0.inputs:fallback: inf is not finite') for w in desc.warnings)


def _corpus(name):
    found = sorted(CORPUS.rglob(name)) if CORPUS.is_dir() else []
    if not found:
        pytest.skip(f'{name}: the shared corpus is not here')
    return found[0]


def test_openusd_connected_scalar_spheres_get_their_roughness():
    """OpenUSD's testPreviewSurfaceConnectedScalar.usda: six spheres, one material, roughness 0 to 1 from each
    sphere's `primvars:roughness`."""
    desc = read_stage(str(_corpus('testPreviewSurfaceConnectedScalar.usda')))
    m = _materials(desc)
    assert [m[f'/Scene/Geom/pSphere{k}'].roughness for k in range(6)] == pytest.approx([0, 0.2, 0.4, 0.6, 0.8, 1])
    assert not [w for w in desc.warnings if 'not supported' in w]


def test_openusd_primvars_and_instanced_material_files():
    """testPreviewSurfacePrimvars.usda: 100 spheres of 100 materials whose diffuseColor reads displayColor, green
    on their parent; testPreviewSurfaceInstancedMaterial.usda: a material and an instance of it that renames the
    primvar (a material-interface input): green and blue."""
    desc = read_stage(str(_corpus('testPreviewSurfacePrimvars.usda')))
    m = _materials(desc)
    assert len(m) == 100 and {x.diffuse for x in m.values()} == {(0.0, 1.0, 0.0)}
    assert len({x.roughness for x in m.values()}) == 10
    m = _materials(read_stage(str(_corpus('testPreviewSurfaceInstancedMaterial.usda'))))
    assert m['/Scene/Geom/Sphere1'].diffuse == (0.0, 1.0, 0.0) and m['/Scene/Geom/Sphere2'].diffuse == (0.0, 0.0, 1.0)


@pytest.mark.parametrize('name', ['Pyramid.usd', 'Creases_SpinningPyramids.usda'])
def test_usd_wg_pyramids_read_their_corner_colours(name):
    """The USD working group's pyramids: displayColor per corner, read by the material's primvar reader."""
    desc = read_stage(str(_corpus(name)))
    assert not [w for w in desc.warnings if 'not supported' in w]
    gprims = [g for c in desc.containers for g in c.gprims]
    assert gprims and all(desc.materials[g.material].vertex_colors and g.colors is not None for g in gprims)


@pytest.mark.parametrize('reader', [False, True])
def test_a_constant_primvar_of_a_scalar_type_is_read(reader):
    """`color3f primvars:displayColor = (...)` (not an array: OpenUSD's testUsdImagingGLInstancePrimvars authors
    it so, and Storm draws it): its colour, for the displayColor fallback and for a primvar reader alike."""
    st = Usd.Stage.CreateInMemory()
    parent = UsdGeom.Xform.Define(st, '/P')                     # (a Gprim's own displayColor is declared an array)
    UsdGeom.PrimvarsAPI(parent.GetPrim()).CreatePrimvar('displayColor', Sdf.ValueTypeNames.Color3f).Set(
        Gf.Vec3f(*RED))
    s = UsdGeom.Sphere.Define(st, '/P/A')
    if reader:
        UsdShade.MaterialBindingAPI.Apply(s.GetPrim()).Bind(
            _material(st, '/Looks/M', {'diffuseColor': ('UsdPrimvarReader_float3', 'displayColor', None)}))
    desc = read_stage(st)
    assert _materials(desc)['/P/A'].diffuse == pytest.approx(RED)
    assert not [w for w in desc.warnings if 'displayColor' in w]


def test_an_empty_primvar_gives_the_fallback():
    """An empty array (the USD fuzzer's seed 491 raised numpy's ValueError from it): the reader's fallback."""
    st = Usd.Stage.CreateInMemory()
    mat = _material(st, '/Looks/M', {'diffuseColor': ('UsdPrimvarReader_float3', 'tint', (0.0, 1.0, 0.0)),
                                     'roughness': ('UsdPrimvarReader_float', 'rough', 0.25)})
    s = _sphere(st, '/A', 0.0, mat)
    UsdGeom.PrimvarsAPI(s.GetPrim()).CreatePrimvar('tint', Sdf.ValueTypeNames.Color3fArray).Set([])
    UsdGeom.PrimvarsAPI(s.GetPrim()).CreatePrimvar('rough', Sdf.ValueTypeNames.FloatArray).Set([])
    m = _materials(read_stage(st))['/A']
    assert m.diffuse == (0.0, 1.0, 0.0) and m.roughness == 0.25
