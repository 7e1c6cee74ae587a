"""NaN / Inf in any input is rejected at compile or load time, never rendered.

* Compiler: a NaN or Inf in a course XML value -> `rtc compile` and `rtc render` exit 2.
* Stage reader: a USD with a NaN/Inf point, transform, radius, light or camera value -> the gprim or
  light is dropped with a reason, or `SceneError` (camera: there is no sensible fallback view); the
  description that reaches the renderer holds only finite numbers, and the image has no NaN/Inf.
"""
import re
import subprocess
import warnings

import numpy as np
import pytest
from click.testing import CliRunner
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux

from rtc.renderer.errors import SceneError
from rtc.renderer.host.render import RenderOptions, render
from rtc.renderer.usd.stage import read_stage
from rtc.cli import main
from rtc.renderer.images import read_pixels
from tests.interop.interop_helpers import REPO, RTC

XML = """<?xml version="1.0" encoding="UTF-8" ?>
<scene>
  <camera name="main" type="perspective"><position>0 1 5</position><lookatPoint>0 0 0</lookatPoint>
    <focalLength>0.5</focalLength><imagePlaneWidth>0.5</imagePlaneWidth></camera>
  <light type="point"><position>{light}</position><intensity>1 1 1</intensity></light>
  <shader name="w" type="Lambertian"><diffuse>0.8 0.8 0.8</diffuse></shader>
  <shape name="s" type="sphere"><shader ref="w"/><center>0 0 0</center><radius>{radius}</radius></shape>
</scene>
"""


@pytest.mark.parametrize('light, radius', [('0 3 nan', '1'), ('0 3 0', 'NaN'), ('0 inf 0', '1'), ('0 3 0', '-inf')])
def test_compiler_rejects_nonfinite_xml_values(tmp_path, light, radius):
    src = tmp_path / 'bad.xml'
    src.write_text(XML.format(light=light, radius=radius))
    r = CliRunner().invoke(main, ['compile', str(src), '-o', str(tmp_path / 'bad.usda')])
    assert r.exit_code == 2, r.output
    assert not (tmp_path / 'bad.usda').exists()
    r = CliRunner().invoke(main, ['render', str(src), '-o', str(tmp_path / 'bad.exr'), '--width', '8', '-q'])
    assert r.exit_code == 2 and not (tmp_path / 'bad.exr').exists()


def test_the_clean_xml_compiles(tmp_path):
    src = tmp_path / 'ok.xml'
    src.write_text(XML.format(light='0 3 0', radius='1'))
    assert CliRunner().invoke(main, ['compile', str(src), '-o', str(tmp_path / 'ok.usda')]).exit_code == 0


NAN, INF = float('nan'), float('inf')


def stage():
    st = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(st, 'Y')
    cam = UsdGeom.Camera.Define(st, '/cam')
    UsdGeom.Xformable(cam).AddTranslateOp().Set(Gf.Vec3d(0, 0, 8))
    m = UsdGeom.Mesh.Define(st, '/m')
    m.CreatePointsAttr([(-3, -1, -3), (3, -1, -3), (3, -1, 3), (-3, -1, 3)])
    m.CreateFaceVertexCountsAttr([4])
    m.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    UsdGeom.Sphere.Define(st, '/s').CreateRadiusAttr(1.0)
    light = UsdLux.SphereLight.Define(st, '/l')
    light.CreateIntensityAttr(30.0)
    UsdGeom.Xformable(light).AddTranslateOp().Set(Gf.Vec3d(0, 4, 2))
    return st


DROPPED = {   # corruption -> the prim that must disappear from the description
    'mesh point': ('/m', lambda st: UsdGeom.Mesh(st.GetPrimAtPath('/m')).GetPointsAttr().Set(
        [(-3, -1, -3), (NAN, -1, -3), (3, -1, 3), (-3, -1, 3)])),
    'mesh transform': ('/m', lambda st: UsdGeom.Xformable(st.GetPrimAtPath('/m')).AddTranslateOp().Set(
        Gf.Vec3d(NAN, 0, 0))),
    'sphere radius': ('/s', lambda st: UsdGeom.Sphere(st.GetPrimAtPath('/s')).GetRadiusAttr().Set(NAN)),
    'sphere scale': ('/s', lambda st: UsdGeom.Xformable(st.GetPrimAtPath('/s')).AddScaleOp().Set(
        Gf.Vec3f(INF, 1, 1))),
    'light intensity': ('/l', lambda st: UsdLux.SphereLight(st.GetPrimAtPath('/l')).GetIntensityAttr().Set(NAN)),
    'light transform': ('/l', lambda st: UsdGeom.Xformable(st.GetPrimAtPath('/l')).AddRotateXOp().Set(NAN)),
    'light exposure past float64': ('/l', lambda st: UsdLux.SphereLight(st.GetPrimAtPath('/l')).CreateExposureAttr(
        1e38)),                                                       # (2 ** 1e38 was an OverflowError)
    # past float32's range, in which Embree traces: refused by name (a point3f of 1e39 is inf as authored already)
    'mesh point past float32': ('/m', lambda st: UsdGeom.Mesh(st.GetPrimAtPath('/m')).GetPointsAttr().Set(
        [(-3, -1, -3), (1e39, -1, -3), (3, -1, 3), (-3, -1, 3)])),
    'mesh scaled past float32': ('/m', lambda st: UsdGeom.Xformable(st.GetPrimAtPath('/m')).AddScaleOp(
        UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(1e300, 1, 1))),
    'sphere radius past float32': ('/s', lambda st: UsdGeom.Sphere(st.GetPrimAtPath('/s')).GetRadiusAttr().Set(1e300)),
    'sphere placed past float32': ('/s', lambda st: UsdGeom.Xformable(st.GetPrimAtPath('/s')).AddTranslateOp().Set(
        Gf.Vec3d(0, 0, -1e301))),
}


def numbers(desc):
    """Every float the renderer will consume."""
    out = [desc.instances.matrices.ravel()]
    for c in desc.containers:
        out += [m.points.ravel() for m in c.meshes]
        out += [np.r_[s.radius, s.matrix.ravel()] for s in c.spheres]
    for l in desc.lights:
        out += [l.matrix.ravel(), np.asarray(l.radiance, float), np.r_[l.radius, l.width, l.height, l.angle]]
    c = desc.camera
    out.append(np.r_[c.matrix.ravel(), c.focal_length, c.horizontal_aperture, c.vertical_aperture,
                     c.lens_radius, c.focus_distance])
    return np.concatenate(out)


def paths(desc):
    return {g.path for c in desc.containers for g in c.gprims} | {l.path for l in desc.lights}


@pytest.mark.parametrize('case', list(DROPPED))
def test_reader_drops_nonfinite_prims(case):
    path, corrupt = DROPPED[case]
    clean = read_stage(stage())
    assert path in paths(clean)
    st = stage()
    corrupt(st)
    desc = read_stage(st)
    assert path not in paths(desc)
    assert any(path in s for s in [*desc.skipped, *desc.warnings]), (desc.skipped, desc.warnings)
    assert np.all(np.isfinite(numbers(desc)))
    img = render(desc, RenderOptions(width=24, height=16, spp=2)).image
    assert np.all(np.isfinite(img))


def test_points_and_curves_past_float32_are_refused_by_name():
    """A cloud and a curve whose coordinates pass float32's range are left out, each named with the reason; the
    same prims at 1e37 (within it) are kept."""
    def read(scale):                 # (a scale op in double: point3f values past float32 are inf already)
        st = stage()
        pts = UsdGeom.Points.Define(st, '/cloud')
        pts.CreatePointsAttr([(0, 0, 0), (1e9, 0, 0)])
        pts.CreateWidthsAttr([1.0, 1.0])
        curve = UsdGeom.BasisCurves.Define(st, '/hair')
        curve.CreateTypeAttr('linear')
        curve.CreateCurveVertexCountsAttr([2])
        curve.CreatePointsAttr([(0, 0, 0), (0, 1e9, 0)])
        for gprim in (pts, curve):
            gprim.AddScaleOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(scale / 1e9, scale / 1e9, scale / 1e9))
        return read_stage(st)
    kept = read(1e37)
    assert {'/cloud', '/hair'} <= paths(kept)
    desc = read(1e39)
    assert not {'/cloud', '/hair'} & paths(desc)
    for path in ['/cloud', '/hair']:
        assert any(s.startswith(f'{path}: coordinates up to 1e+39') and "past float32's range" in s
                   for s in desc.skipped), desc.skipped


def test_a_spheres_reach_bounds_its_surface():
    """`Sphere.reach`, a bound of the largest coordinate in container space, holds for points of the surface under
    a sheared, scaled and moved matrix, and is attained within the norm inequality's slack (the bound is tight for
    an axis-aligned sphere)."""
    from rtc.renderer.description import Sphere
    rng = np.random.default_rng(3)
    m = np.eye(4)
    m[:3, :3] = rng.normal(size=(3, 3)) * 4.0
    m[:3, 3] = (5.0, -7.0, 2.0)
    s = Sphere('/s', 2.0, m, centers=np.array([[1.0, 2.0, -3.0], [0.0, 0.0, 0.0]]), radii=np.array([0.5, 2.0]))
    n = rng.normal(size=(20000, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    surface = np.concatenate([c + r * n for c, r in zip(s.centers, s.radii)])
    placed = surface @ m[:3, :3].T + m[:3, 3]
    assert np.abs(placed).max() <= s.reach()
    lone = Sphere('/t', 3.0, np.diag([2.0, 1.0, 1.0, 1.0]))
    lone.matrix[:3, 3] = (1.0, 0.0, 0.0)
    assert lone.reach() == 7.0                                       # |1 + 2 x 3|: the sphere reaches x = 7


@pytest.mark.parametrize('corrupt, message', [
    (lambda st: UsdGeom.Xformable(st.GetPrimAtPath('/cam')).AddRotateYOp().Set(NAN), "/cam: the camera's transform"),
    (lambda st: UsdGeom.Camera(st.GetPrimAtPath('/cam')).CreateFocalLengthAttr(NAN), '/cam.focalLength: nan'),
    (lambda st: UsdGeom.Camera(st.GetPrimAtPath('/cam')).CreateHorizontalApertureAttr(INF),
     '/cam.horizontalAperture: inf'),
    (lambda st: UsdGeom.Camera(st.GetPrimAtPath('/cam')).CreateHorizontalApertureAttr(NAN),
     '/cam.horizontalAperture: the camera aperture must be positive, not nan'),
    (lambda st: UsdGeom.Camera(st.GetPrimAtPath('/cam')).CreateVerticalApertureOffsetAttr(-INF),
     '/cam.verticalApertureOffset: -inf'),
    (lambda st: UsdGeom.Camera(st.GetPrimAtPath('/cam')).CreateFocalLengthAttr(-35.0),
     '/cam.focalLength: the camera focal length must be positive, not -35'),
    (lambda st: UsdGeom.Camera(st.GetPrimAtPath('/cam')).CreateVerticalApertureAttr(0.0),
     '/cam.verticalAperture: the camera aperture must be positive, not 0'),
], ids=['transform', 'focal length', 'aperture', 'NaN aperture', 'aperture offset', 'negative focal length',
        'zero aperture'])
def test_reader_rejects_a_nonfinite_camera(corrupt, message):
    """The message names the prim and its attribute."""
    st = stage()
    corrupt(st)
    with pytest.raises(SceneError, match=re.escape(message)):
        read_stage(st)


@pytest.mark.parametrize('corrupt', [
    lambda st: UsdGeom.Camera(st.GetPrimAtPath('/cam')).CreateFStopAttr(INF),
    lambda st: UsdGeom.Camera(st.GetPrimAtPath('/cam')).CreateFocusDistanceAttr(NAN),
], ids=['fStop', 'focusDistance'])
def test_reader_keeps_a_camera_whose_unused_lens_values_are_odd(corrupt):
    """An infinite fStop is a pinhole, a NaN focusDistance is unset (the default, 1): nothing to refuse."""
    st = stage()
    corrupt(st)
    assert read_stage(st).camera.lens_radius == 0.0


@pytest.mark.parametrize('integrator', ['path', 'cook'])
def test_values_past_float32_render_without_numpy_warnings(tmp_path, integrator):
    """Finite values whose products pass float32's range (a radius of 1e300, a light of intensity 3e38 and width
    1e30) render, and numpy's overflow warnings (Python's own text) do not reach the user."""
    st = stage()
    UsdGeom.Sphere.Define(st, '/huge').CreateRadiusAttr(1e300)
    UsdGeom.Xformable(st.GetPrimAtPath('/huge')).AddTranslateOp().Set(Gf.Vec3d(0, 0, -1e301))
    rect = UsdLux.RectLight.Define(st, '/bright')
    rect.CreateIntensityAttr(3e38)
    rect.CreateWidthAttr(1e30)
    UsdGeom.Xformable(rect).AddTranslateOp().Set(Gf.Vec3d(0, 5, 0))
    st.GetRootLayer().Export(str(tmp_path / 'huge.usda'))
    with warnings.catch_warnings():
        warnings.filterwarnings('error', message='.*encountered in', category=RuntimeWarning)
        result = CliRunner().invoke(main, ['render', str(tmp_path / 'huge.usda'), '-o', str(tmp_path / 'out.png'),
                                           '--width', '16', '--height', '12', '--spp', '2', '--integrator', integrator],
                                    catch_exceptions=False)
    assert result.exit_code == 0 and (tmp_path / 'out.png').stat().st_size > 0, result.output
    assert 'RuntimeWarning' not in result.output


@pytest.mark.parametrize('radius, scale, kept', [(1.0, 1.0, 2), (1.0, 1e37, 2), (100.0, 1e37, 1)])
def test_placements_past_float32_are_dropped_with_a_warning(radius, scale, kept):
    """An instance whose matrix places its prototype past float32's range (scale x radius > 3.4e38), or is itself
    past it (a translation of 1e300), is dropped with a warning; the other placements stay."""
    st = stage()
    st.DefinePrim('/protos').SetSpecifier(Sdf.SpecifierClass)
    UsdGeom.Sphere.Define(st, '/protos/ball/s').CreateRadiusAttr(radius)
    for i, (s, t) in enumerate([(1.0, 2.0), (scale, -2.0), (1.0, 1e300)]):
        p = UsdGeom.Xform.Define(st, f'/b{i}').GetPrim()
        p.GetReferences().AddInternalReference('/protos/ball')
        p.SetInstanceable(True)
        op = UsdGeom.Xformable(p)
        op.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(t, 0, 0))
        op.AddScaleOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(s, s, s))
    desc = read_stage(st)
    balls = [i for i, c in enumerate(desc.containers) if any(s.path.endswith('/s') and s.path != '/s'
                                                           for s in c.spheres)]
    assert len(balls) == 1
    assert int(np.sum(desc.instances.container == balls[0])) == kept
    dropped = 3 - kept
    assert any(f'{dropped} placements dropped' in w and "past float32's range" in w for w in desc.warnings), \
        desc.warnings


@pytest.mark.parametrize('kind, name, value', [
    ('RectLight', 'inputs:height', INF), ('RectLight', 'inputs:width', NAN), ('DiskLight', 'inputs:radius', INF),
    ('CylinderLight', 'inputs:length', INF), ('CylinderLight', 'inputs:radius', NAN),
    ('DistantLight', 'inputs:angle', INF), ('SphereLight', 'inputs:radius', -INF),
    ('SphereLight', 'inputs:exposure', NAN), ('RectLight', 'inputs:colorTemperature', INF)])
def test_a_light_with_a_nonfinite_input_is_dropped_by_name(kind, name, value):
    """Every number a light's reading uses is checked, not only its radiance: an infinite size made NaN light
    samples, whose shadow rays crashed Embree (the USD fuzzer's seeds 2730 and 3394, before `trace.traceable`)."""
    st = stage()
    prim = st.DefinePrim('/odd', kind)
    prim.CreateAttribute(name, Sdf.ValueTypeNames.Float).Set(value)
    prim.CreateAttribute('inputs:enableColorTemperature', Sdf.ValueTypeNames.Bool).Set(True)
    desc = read_stage(st)
    assert '/odd' not in paths(desc) and '/l' in paths(desc)
    assert f'/odd.{name}: {value} is not a finite number; light ignored' in desc.warnings, desc.warnings


@pytest.mark.parametrize('name, value', [('inputs:shaping:ies:angleScale', NAN), ('inputs:colorTemperature', INF),
                                         ('inputs:shadow:distance', INF)])
def test_a_nonfinite_input_the_reading_does_not_use_keeps_the_light(name, value):
    """A light keeps its place when the odd value is in an input rtc does not read (an IES profile's scale, a colour
    temperature that is not enabled), as renderers that do not read it would."""
    st = stage()
    st.GetPrimAtPath('/l').CreateAttribute(name, Sdf.ValueTypeNames.Float).Set(value)
    desc = read_stage(st)
    assert '/l' in paths(desc) and not any('not a finite number' in w for w in desc.warnings), desc.warnings


@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_the_gallery_curves_under_a_light_of_infinite_height_render(tmp_path, integrator):
    """The fuzzer's seed 2730, whole: scenes/curves.usda with its RectLight's height infinite, in a child process (it
    was a segmentation fault with cook): the light is dropped by name and the image is finite."""
    st = Usd.Stage.Open(str(REPO / 'scenes' / 'curves.usda'))
    st.GetPrimAtPath('/World/Key').GetAttribute('inputs:height').Set(INF)
    st.GetRootLayer().Export(str(tmp_path / 'curves.usda'))
    out = tmp_path / 'out.exr'
    args = ['render', str(tmp_path / 'curves.usda'), '-o', str(out), '--width', '16', '--height', '12', '--spp', '1']
    child = subprocess.run([*RTC, *args, '--integrator', integrator], capture_output=True, text=True, timeout=900)
    assert child.returncode == 0, child.stderr[-3000:]
    assert '/World/Key.inputs:height: inf is not a finite number; light ignored' in child.stderr + child.stdout
    assert np.all(np.isfinite(read_pixels(out)[0]))


@pytest.mark.parametrize('integrator', ['cook', 'path'])
def test_samples_that_overflow_are_left_out_and_counted(tmp_path, integrator):
    """A point light of finite intensity 2**1023 / 4 five hundredths from a sphere: its irradiance there passes
    float64's range, so those samples are inf.  They are left out of their pixels and the user is told how many;
    pixels whose means pass float32's range are written as 0, and said so in rtc's words, not numpy's or Python's
    warnings (made errors here).  At exposure 0 nothing is said."""
    def render_with(exposure):
        st = stage()
        st.RemovePrim('/l')
        light = UsdLux.SphereLight.Define(st, '/hot')
        light.CreateRadiusAttr(0.0)
        light.CreateExposureAttr(exposure)
        UsdGeom.Xformable(light).AddTranslateOp().Set(Gf.Vec3d(0, 0, 1.05))
        src = tmp_path / f'hot{exposure:g}.usda'          # (a file each: USD keeps the layer it opened)
        st.GetRootLayer().Export(str(src))
        with warnings.catch_warnings():
            warnings.simplefilter('error', RuntimeWarning)
            result = CliRunner().invoke(main, ['render', str(src), '-o', str(tmp_path / 'hot.exr'),
                                               '--width', '16', '--height', '12', '--spp', '2', '--integrator',
                                               integrator], catch_exceptions=False)
        assert result.exit_code == 0, result.output
        assert np.all(np.isfinite(read_pixels(tmp_path / 'hot.exr')[0]))
        return result.output
    output = render_with(1023)
    said = re.search(r'rtc: warning: (\d+) samples were not finite \(NaN or inf\) and were left out', output)
    assert said and 0 < int(said.group(1)) < 16 * 12 * 2
    written = re.search(r"rtc: warning: .*hot.exr: replaced (\d+) non-finite values by 0 \(past float32's", output)
    assert written and 0 < int(written.group(1)) <= 16 * 12 * 3, output
    assert 'not finite' not in render_with(0.0)
