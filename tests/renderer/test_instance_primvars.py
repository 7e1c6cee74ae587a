"""Primvars a UsdGeom.PointInstancer gives each instance (`usd/instance_primvars.py`): one value per instance
(vertex, varying, uniform) or one for all (constant), read by the prototype's gprims as if authored above
them - by a material's UsdPrimvarReader and by the displayColor fallback - as Storm binds them; the prototype's
own primvars are closer and win; primvars nothing reads cost nothing."""
from pathlib import Path

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from rtc.renderer.host.render import Renderer
from rtc.renderer.options import RenderOptions
from rtc.renderer.usd.stage import read_stage

COLOURS = [(0.8, 0.1, 0.1), (0.1, 0.8, 0.1), (0.1, 0.1, 0.8)]
CORPUS = Path(__file__).resolve().parents[3] / 'shared' / 'corpus' / 'usd'


def _stage(name='tint', interpolation=UsdGeom.Tokens.varying, values=COLOURS, reader=True, own=None, extra=False):
    """Three instances of a sphere along x; the instancer gives `name` = `values`; `reader`: the sphere's material
    reads it (else no material: the displayColor fallback); `own`: a colour the prototype authors itself."""
    st = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(st, 'Y')
    pi = UsdGeom.PointInstancer.Define(st, '/World/PI')
    pi.CreatePositionsAttr([(-2.2, 0, 0), (0, 0, 0), (2.2, 0, 0)])
    pi.CreateProtoIndicesAttr([0, 0, 0])
    ball = UsdGeom.Sphere.Define(st, '/World/PI/Protos/Ball')
    pi.CreatePrototypesRel().SetTargets([ball.GetPath()])
    pv = UsdGeom.PrimvarsAPI(pi.GetPrim()).CreatePrimvar(name, Sdf.ValueTypeNames.Color3fArray, interpolation)
    pv.Set(values)
    if extra:                                   # per-instance data nothing reads
        UsdGeom.PrimvarsAPI(pi.GetPrim()).CreatePrimvar('id', Sdf.ValueTypeNames.FloatArray,
                                                        UsdGeom.Tokens.varying).Set([1.0, 2.0, 3.0])
    if own is not None:
        UsdGeom.PrimvarsAPI(ball.GetPrim()).CreatePrimvar(name, Sdf.ValueTypeNames.Color3fArray).Set([own])
    if reader:
        mat = UsdShade.Material.Define(st, '/Looks/M')
        sh = UsdShade.Shader.Define(st, '/Looks/M/Surface')
        sh.CreateIdAttr('UsdPreviewSurface')
        rd = UsdShade.Shader.Define(st, '/Looks/M/Read')
        rd.CreateIdAttr('UsdPrimvarReader_float3')
        rd.CreateInput('varname', Sdf.ValueTypeNames.String).Set(name)
        sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).ConnectToSource(
            rd.CreateOutput('result', Sdf.ValueTypeNames.Float3))
        mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
        UsdShade.MaterialBindingAPI.Apply(ball.GetPrim()).Bind(mat)
    light = UsdLux.DistantLight.Define(st, '/Sun')
    light.CreateIntensityAttr(3.0)
    cam = UsdGeom.Camera.Define(st, '/Cam')
    cam.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, 9.0))
    return st


def _colours(desc):
    """The diffuse colour of each placement, in the order of the instancer's instances (by x)."""
    inst = desc.instances
    x = inst.matrices[:, 0, 0, 3]
    return [tuple(round(v, 4) for v in desc.materials[inst.material_sets[inst.material_set[k]][0]].diffuse)
            for k in np.argsort(x)]


def _rounded(colours):
    return [tuple(round(v, 4) for v in c) for c in colours]


@pytest.mark.parametrize('reader, name', [(True, 'tint'), (True, 'displayColor'), (False, 'displayColor')])
def test_each_instance_gets_the_value_the_instancer_gives_it(reader, name):
    desc = read_stage(_stage(name=name, reader=reader))
    assert _colours(desc) == _rounded(COLOURS)


def test_the_instances_render_in_their_colours():
    with Renderer(read_stage(_stage()), threads=1) as r:
        img = r.render(RenderOptions(width=96, height=32, spp=4, integrator='path', max_depth=2, threads=1)).image
    img = img.astype(np.float64)
    for k, third in enumerate((img[:, :32], img[:, 32:64], img[:, 64:])):
        sums = third.reshape(-1, 3).sum(0)
        assert sums[k] > 3 * max(np.delete(sums, k)), (k, sums)


def test_a_constant_one_is_every_instances_and_the_prototypes_own_wins():
    assert _colours(read_stage(_stage(interpolation=UsdGeom.Tokens.constant, values=[COLOURS[2]]))) == \
        _rounded([COLOURS[2]] * 3)
    assert _colours(read_stage(_stage(own=(0.5, 0.5, 0.5)))) == _rounded([(0.5, 0.5, 0.5)] * 3)


def test_a_count_that_fits_no_instance_is_named_and_given_to_none():
    desc = read_stage(_stage(values=COLOURS[:2]))
    assert _colours(desc) == [(0.0, 0.0, 0.0)] * 3                   # the reader's fallback
    assert any(w.startswith('/World/PI.primvars:tint: 2 values for 3 instances; not given to its instances')
               for w in desc.warnings), desc.warnings


def test_primvars_nothing_reads_make_no_material_sets():
    plain = read_stage(_stage(reader=False, name='unread'))
    extra = read_stage(_stage(reader=False, name='unread', extra=True))
    assert len(plain.instances.material_sets) == len(extra.instances.material_sets) == 1
    assert len(plain.materials) == len(extra.materials)


def _corpus(name):
    found = sorted(CORPUS.rglob(name)) if CORPUS.is_dir() else []
    if not found:
        pytest.skip(f'{name}: the shared corpus is not here')
    return str(found[0])


def test_openusd_instance_primvar_files():
    """OpenUSD's testUsdImagingGLInstancePrimvars: testFiltering.usda's three instances read perInstanceColor
    (and ten unused primvars); test.usda's point instances take their displayColor, its native ones theirs."""
    assert _colours(read_stage(_corpus('testFiltering.usda'))) == _rounded(COLOURS)
    desc = read_stage(_corpus('testUsdImagingGLInstancePrimvars/test.usda'))
    inst = desc.instances
    by_path = {}
    for k, p in enumerate(inst.paths):
        by_path.setdefault(p, []).append(desc.materials[inst.material_sets[inst.material_set[k]][0]].diffuse)
    assert sorted(_rounded(by_path['/World/TeapotPair4_PointInstances/Geom/Instancer'])) == \
        sorted(_rounded([(0.1, 0.6, 0.1), (0.8, 0.6, 0.1)]))
    assert _rounded(by_path['/World/TeapotPair2_NativeInstances_Scalar/Teapot2']) == [(0.8, 0.3, 0.1)]
    assert not [w for w in desc.warnings if 'displayColor' in w]
