"""UsdGeom.Points: a cloud of spheres, one gprim (`usd/geometry._points`, `description.Sphere.centers`), each
point a primitive of the gprim's Embree geometry (`shapes.surface` reads row gp_off + primID).  Read: widths
per point, constant or unauthored (1, as Hydra draws them), bad points left out with a warning.  Rendered: the
same image as the same spheres authored as UsdGeom.Sphere prims, by both integrators, placed once or
instanced.  Emissive: each point a light of the path integrator (lit by the cloud alone, the same image as the
same emissive spheres, placed once, instanced, squashed into ellipsoids or moving); `scenes/points.usda`."""
import contextlib

import numpy as np
import pytest
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade

from rtc.renderer.host.render import Renderer
from rtc.renderer.options import RenderOptions
from rtc.renderer.usd.stage import read_stage

CENTRES = [(-1.0, 0.5, 0.0), (0.0, 0.5, 0.3), (1.1, 0.6, 0.0), (0.0, 1.5, -1.0), (-0.4, 0.2, 1.0)]
WIDTHS = [0.8, 0.6, 1.0, 0.5, 0.3]
COLOURS = [(0.9, 0.1, 0.1), (0.1, 0.8, 0.2), (0.2, 0.3, 0.9), (0.9, 0.8, 0.1), (0.6, 0.2, 0.7)]


def _stage(cloud: bool, instanced: bool = False, glow: bool = False, squash: bool = False,
           moving: bool = False, coloured: bool = False) -> Usd.Stage:
    """A floor, a sphere light, a camera and five balls, as one Points prim (cloud) or as five Spheres,
    under a rotated, uniformly scaled and moved Xform; `instanced`: that Xform an instanceable prototype
    placed twice.  `glow`: the balls emit (UsdPreviewSurface emissiveColor) and the sphere light is gone;
    `squash`: the second placement scaled by (1, 0.6, 1) (its balls ellipsoids); `moving`: it moves over
    the shutter; `coloured`: each ball its displayColor (the cloud's per point, a sphere's constant)."""
    st = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(st, 'Y')
    UsdGeom.SetStageMetersPerUnit(st, 1.0)
    floor = UsdGeom.Mesh.Define(st, '/World/Floor')
    floor.CreatePointsAttr([(-6, 0, -6), (-6, 0, 6), (6, 0, 6), (6, 0, -6)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    if not glow:
        light = UsdLux.SphereLight.Define(st, '/World/Light')
        light.CreateIntensityAttr(300.0)
        light.CreateRadiusAttr(0.5)
        light.AddTranslateOp().Set(Gf.Vec3d(2, 4, 3))
    cam = UsdGeom.Camera.Define(st, '/World/Cam')
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 1.5, 7))
    cam.CreateShutterOpenAttr(0.0)
    cam.CreateShutterCloseAttr(1.0 if moving else 0.0)
    if instanced:
        UsdGeom.Xform.Define(st, '/Proto')
    root = '/Proto/Balls' if instanced else '/World/Balls'
    xf = UsdGeom.Xform.Define(st, root)
    xf.AddTranslateOp().Set(Gf.Vec3d(0.2, 0.1, -0.3))
    xf.AddRotateYOp().Set(25.0)
    xf.AddScaleOp().Set(Gf.Vec3f(1.3, 1.3, 1.3))
    if cloud:
        pts = UsdGeom.Points.Define(st, root + '/Cloud')
        pts.CreatePointsAttr(CENTRES)
        pts.CreateWidthsAttr(WIDTHS)
        pts.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
        if coloured:
            pts.CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex).Set(COLOURS)
    else:
        for k, (c, w) in enumerate(zip(CENTRES, WIDTHS)):
            s = UsdGeom.Sphere.Define(st, f'{root}/S{k}')
            s.CreateRadiusAttr(w / 2)
            s.AddTranslateOp().Set(Gf.Vec3d(*c))
            if coloured:
                s.CreateDisplayColorPrimvar(UsdGeom.Tokens.constant).Set([COLOURS[k]])
    if glow:
        mat = UsdShade.Material.Define(st, root + '/Glow')
        shader = UsdShade.Shader.Define(st, root + '/Glow/Surface')
        shader.CreateIdAttr('UsdPreviewSurface')
        shader.CreateInput('emissiveColor', Sdf.ValueTypeNames.Color3f).Set((4.0, 2.5, 1.0))
        mat.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), 'surface')
        for prim in st.GetPrimAtPath(root).GetChildren():
            if prim.IsA(UsdGeom.Gprim):
                UsdShade.MaterialBindingAPI.Apply(prim).Bind(mat)
    if instanced:
        for k, x in enumerate((-1.5, 1.5)):
            p = st.DefinePrim(f'/World/B{k}')
            p.GetReferences().AddInternalReference('/Proto')
            p.SetInstanceable(True)
            op = UsdGeom.Xformable(p).AddTranslateOp()
            op.Set(Gf.Vec3d(x, 0, 0))
            if moving and k:
                op.Set(Gf.Vec3d(x, 0, 0), 0.0)
                op.Set(Gf.Vec3d(x + 0.4, 0.3, 0), 1.0)
            if squash and k:
                UsdGeom.Xformable(p).AddScaleOp().Set(Gf.Vec3f(1.0, 0.6, 1.0))
    return st


def _points_stage(points, widths=None, interpolation=None):
    st = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(st, 'Y')
    pts = UsdGeom.Points.Define(st, '/P')
    pts.CreatePointsAttr(points)
    if widths is not None:
        pts.CreateWidthsAttr(widths)
    if interpolation:
        pts.SetWidthsInterpolation(interpolation)
    return st


def test_points_are_read_as_one_cloud_of_spheres():
    st = _stage(cloud=True)
    desc = read_stage(st)
    (cloud,) = [s for c in desc.containers for s in c.spheres]
    assert cloud.path == '/World/Balls/Cloud'
    f32 = lambda v: np.array(v, np.float32).astype(np.float64)          # (point3f[], float[] in the file)
    np.testing.assert_array_equal(cloud.balls(), np.column_stack([f32(CENTRES), f32(WIDTHS) / 2]))
    m = UsdGeom.Xformable(st.GetPrimAtPath('/World/Balls')).ComputeLocalToWorldTransform(0)
    np.testing.assert_allclose(cloud.matrix, np.array(m).T, atol=1e-12)      # (column vectors)
    assert 'spheres: 5 unique, 5 instanced' in _describe(desc)


def _describe(desc):
    from rtc.renderer.host.info import describe
    return describe(desc)


@pytest.mark.parametrize('widths, interpolation, radii', [
    (None, None, [0.5, 0.5, 0.5]),                         # unauthored: width 1
    ([0.4], UsdGeom.Tokens.constant, [0.2, 0.2, 0.2]),
    ([0.2, 0.4, 0.6], UsdGeom.Tokens.vertex, [0.1, 0.2, 0.3]),
])
def test_widths_constant_per_point_or_unauthored(widths, interpolation, radii):
    desc = read_stage(_points_stage([(0, 0, 0), (1, 0, 0), (2, 0, 0)], widths, interpolation))
    (cloud,) = desc.containers[0].spheres
    np.testing.assert_allclose(cloud.radii, radii, rtol=1e-7)
    assert not [w for w in desc.warnings if '/P' in w]


def test_bad_points_are_left_out_with_a_warning():
    desc = read_stage(_points_stage([(0, 0, 0), (float('nan'), 0, 0), (2, 0, 0), (3, 0, 0)], [1.0, 1.0, 0.0, -1.0],
                                    UsdGeom.Tokens.vertex))
    (cloud,) = desc.containers[0].spheres
    np.testing.assert_array_equal(cloud.centers, [[0, 0, 0]])
    assert any('/P: 3 of 4 points left out' in w for w in desc.warnings)
    desc = read_stage(_points_stage([(0, 0, 0), (1, 0, 0)], [0.5, 0.5, 0.5], UsdGeom.Tokens.vertex))
    np.testing.assert_allclose(desc.containers[0].spheres[0].radii, [0.25, 0.25], rtol=1e-7)
    assert any('/P: 3 widths for 2 points' in w for w in desc.warnings)
    desc = read_stage(_points_stage([(float('inf'), 0, 0)]))
    assert not any(c.spheres for c in desc.containers) and any('/P: no point to draw' in s for s in desc.skipped)


def test_point_colours_are_read_a_point():
    """A cloud's displayColor that varies is read a point (the points left out take theirs with them); a count
    that is not the points' is warned and its mean used; a constant one is the fallback material's colour (the first
    of several values, as Storm reads them: OpenUSD's testUsdImagingGLColorOpacityPrimvar)."""
    st = _points_stage([(0, 0, 0), (float('nan'), 0, 0), (2, 0, 0)], [1.0], UsdGeom.Tokens.constant)
    UsdGeom.Points(st.GetPrimAtPath('/P')).CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex).Set(COLOURS[:3])
    desc = read_stage(st)
    (cloud,) = desc.containers[0].spheres
    np.testing.assert_array_equal(cloud.colors, np.array([COLOURS[0], COLOURS[2]], np.float32))
    assert desc.materials[cloud.material].vertex_colors
    UsdGeom.Points(st.GetPrimAtPath('/P')).GetDisplayColorPrimvar().Set(COLOURS[:2])
    desc = read_stage(st)
    np.testing.assert_allclose(desc.containers[0].spheres[0].colors, [np.mean(COLOURS[:2], 0)] * 2, rtol=1e-6)
    assert any('/P: primvars:displayColor: 2 values for 3 points' in w for w in desc.warnings)
    UsdGeom.Points(st.GetPrimAtPath('/P')).GetDisplayColorPrimvar().SetInterpolation(UsdGeom.Tokens.constant)
    desc = read_stage(st)
    cloud = desc.containers[0].spheres[0]
    assert cloud.colors is None and desc.materials[cloud.material].diffuse == pytest.approx(COLOURS[0])   # (Storm's)


def test_a_cloud_of_one_point_left_keeps_its_colour():
    """Two points of two colours, one of them left out (not finite): the one left is drawn in its own colour
    (its row of the colour table), not the white of the fallback material it multiplies."""
    from rtc.renderer.host.build import build
    from rtc.renderer.kernel.records import Hit
    from rtc.renderer.kernel.shapes import corner_color
    st = _points_stage([(0, 0, 0), (float('nan'), 0, 0)], [1.0], UsdGeom.Tokens.constant)
    UsdGeom.Points(st.GetPrimAtPath('/P')).CreateDisplayColorPrimvar(UsdGeom.Tokens.vertex).Set(COLOURS[:2])
    desc = read_stage(st)
    (ball,) = [s for c in desc.containers for s in c.spheres]
    assert desc.materials[ball.material].vertex_colors and len(ball.centers) == 1
    built = build(desc)
    try:
        g = int(np.flatnonzero(built.data.gp_kind == 1)[0])
        np.testing.assert_allclose(corner_color(built.data, g, Hit(0, 0, 0, 0, 0.0, 0.0, 1.0)), COLOURS[0], rtol=1e-6)
    finally:
        built.close()


@pytest.mark.parametrize('integrator', ['path', 'cook'])
@pytest.mark.parametrize('instanced, coloured', [(False, False), (True, False), (False, True), (True, True)])
def test_a_point_cloud_renders_as_its_spheres(integrator, instanced, coloured):
    """The cloud's image equals that of the same balls as UsdGeom.Spheres (the same balls, only grouped in
    one Embree geometry, their centres placed by numpy instead of USD's matrix products: the pixels agree to
    float rounding, a ball moved by 1e-16 of its size); `coloured`: the cloud's displayColor a point (no
    material) against each sphere's own constant one."""
    images = []
    for cloud in (True, False):
        desc = read_stage(_stage(cloud, instanced, coloured=coloured))
        if coloured and cloud:
            for balls in (s for c in desc.containers for s in c.spheres):
                np.testing.assert_array_equal(balls.colors, np.array(COLOURS, np.float32))
        with Renderer(desc, threads=1) as r:
            images.append(r.render(RenderOptions(width=64, height=48, spp=4, integrator=integrator,
                                                 max_depth=3, threads=1)).image)
    a, b = images
    diff = np.abs(a.astype(np.float64) - b)
    assert b.mean() > 0.05 and diff.mean() <= 1e-6 * b.mean() and diff.max() <= 1e-4 * b.max()


def test_an_emissive_cloud_is_a_light_a_point():
    """Each point of an emissive cloud is a light of the path integrator, at each placement (a lone emissive
    sphere is one light): their centres and radii in the light table, the balls of a placement consecutive
    lights, and the hit map giving the cloud's first one (`light_of_hit` adds the primitive)."""
    from rtc.renderer import description as D
    from rtc.renderer.host.build import build
    from rtc.renderer.host.light_selection import path_lights
    from rtc.renderer.kernel.tables import SLF_CENTER, SLF_RADIUS
    from tests.renderer.handmade import look_at, quad, scene, translate
    glow = D.Material('/glow', model=D.LAMBERTIAN, emission=(1.0, 1.0, 1.0))
    centres = np.array([[0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 2.0, -1.0]])
    cloud = D.Sphere(path='/cloud', radius=0.2, matrix=translate(0.5, 0.0, 0.0), material=0,
                     centers=centres, radii=np.array([0.2, 0.1, 0.3]))
    lone = D.Sphere(path='/lone', radius=0.3, matrix=translate(-1.0, 1.0, 0.0), material=0)
    grey = D.Material('/grey', model=D.LAMBERTIAN)
    desc = scene([D.Container('/', meshes=[quad(6.0, material=1)], spheres=[cloud, lone])], [glow, grey], [],
                 D.Camera(path='/cam', matrix=look_at((0.0, 3.0, 8.0), (0.0, 0.0, 0.0))))
    built = build(desc)
    try:
        L, _ = path_lights(desc, built.data.li_f, built.top.bounds(), len(built.top.groups), data=built.data)
        assert L.n_surface == 4
        origin = desc.camera.matrix[:3, 3]
        got = sorted(map(tuple, np.round(np.column_stack([L.sl_f[:4, SLF_CENTER:SLF_CENTER + 3] + origin,
                                                          L.sl_f[:4, SLF_RADIUS]]), 9)))
        want = sorted(map(tuple, np.round(np.vstack([np.column_stack([centres + (0.5, 0, 0), [0.2, 0.1, 0.3]]),
                                                     [[-1.0, 1.0, 0.0, 0.3]]]), 9)))
        assert got == want
        cloud_light = L.sl_idx[L.sl_row[0] + 1] - L.surface_first          # (slots: the quad, the cloud, the lone)
        np.testing.assert_allclose(L.sl_f[cloud_light:cloud_light + 3, SLF_CENTER:SLF_CENTER + 3] + origin,
                                   centres + (0.5, 0, 0), atol=1e-12)
        assert not any('point cloud' in w for w in desc.warnings)
    finally:
        built.close()


@pytest.mark.parametrize('limit, warned', [(9, False), (8, True)])
def test_more_than_max_balls_emissive_spheres_are_warned(monkeypatch, limit, warned):
    """Emissive spheres are lights (~350 bytes and a leaf of the tree each): a scene with more than MAX_BALLS of
    them (here a 3-point cloud in a prototype placed twice, and itself: 9, against a limit lowered for the test)
    is warned about."""
    from rtc.renderer.host import surface_lights as SL
    from rtc.renderer.host.build import build
    from rtc.renderer.host.light_selection import path_lights
    monkeypatch.setattr(SL, 'MAX_BALLS', limit)
    desc = read_stage(_stage(True, instanced=True, glow=True))
    for c in desc.containers:
        for s in c.spheres:
            s.centers, s.radii = s.centers[:3], s.radii[:3]
    built = build(desc)
    try:
        with pytest.warns(RuntimeWarning, match='9 emissive spheres') if warned else contextlib.nullcontext():
            L, _ = path_lights(desc, built.data.li_f, built.top.bounds(), len(built.top.groups), data=built.data)
        assert L.n_surface == 9
        assert any('9 emissive spheres' in w for w in desc.warnings) == warned
    finally:
        built.close()


@pytest.mark.parametrize('case', ['once', 'instanced', 'squashed', 'moving'])
def test_an_emissive_cloud_lights_as_its_spheres(case):
    """Lit by emissive balls alone (no other light), the cloud's image equals that of the same balls as
    emissive UsdGeom.Spheres, each one light (sampled, and MIS-weighted where a BSDF ray finds it): placed
    once, instanced twice, the second placement squashed (ellipsoid lights), or moving (lights placed at a
    ray's time).  Drawn by BSDF rays alone (the cloud's light before), the image is far noisier."""
    kw = dict(instanced=case != 'once', squash=case == 'squashed', moving=case == 'moving', glow=True)
    images = []
    for cloud in (True, False):
        desc = read_stage(_stage(cloud, **kw))
        desc.lights = []                        # (the reader's default headlight and dome: no UsdLux light)
        with Renderer(desc, threads=1) as r:
            images.append(r.render(RenderOptions(width=64, height=48, spp=4, integrator='path', max_depth=3,
                                                 threads=1)).image)
    a, b = images
    diff = np.abs(a.astype(np.float64) - b)
    assert b.mean() > 0.05 and diff.mean() <= 1e-6 * b.mean() and diff.max() <= 1e-4 * b.max()


def test_the_points_example_scene():
    """scenes/points.usda: the two strings of fairy lights are 27 + 19 lights (a bulb each, of diameter 0.1) beside
    the DomeLight, the heap of 40 pebbles is placed three times (one prototype), the 14 bubbles keep a colour and an
    opacity a point, no warning; a small path render
    of it lit by the bulbs alone is finite and lit."""
    from pathlib import Path
    from rtc.renderer import description as D
    from rtc.renderer.host.build import build
    from rtc.renderer.host.light_selection import path_lights
    from rtc.renderer.kernel.tables import SLF_RADIUS
    desc = read_stage(str(Path(__file__).resolve().parents[2] / 'scenes' / 'points.usda'))
    assert [l.type for l in desc.lights] == [D.DOME] and not desc.warnings
    clouds = {s.path: s for c in desc.containers for s in c.spheres if s.centers is not None}
    assert {p: len(s.centers) for p, s in clouds.items()} == {
        '/World/FairyLights/Back': 27, '/World/FairyLights/Front': 19, '/__Prototype_1/Stones': 40,
        '/World/Bubbles': 14}
    bubbles = clouds['/World/Bubbles']                  # (no material: Storm's fallback, see-through bubbles)
    assert bubbles.colors.shape == (14, 4) and desc.materials[bubbles.material].vertex_opacity
    assert 0.2 <= bubbles.colors[:, 3].min() and bubbles.colors[:, 3].max() <= 0.6
    stones = [k for k, c in enumerate(desc.containers) if any(s.path.endswith('/Stones') for s in c.spheres)]
    assert len(stones) == 1 and np.count_nonzero(desc.instances.container == stones[0]) == 3
    built = build(desc)
    try:
        L, _ = path_lights(desc, built.data.li_f, built.top.bounds(), len(built.top.groups), data=built.data)
        assert L.n_surface == 46 and L.surface_first == 1 and L.depth[0] < 0 and (L.depth[1:47] >= 0).all()
        np.testing.assert_allclose(L.sl_f[:46, SLF_RADIUS], 0.05, rtol=1e-6)
    finally:
        built.close()
    desc.lights = []                                     # the bulbs alone (and the kernels of the tests above)
    with Renderer(desc, threads=1) as r:
        img = r.render(RenderOptions(width=48, height=36, spp=4, integrator='path', max_depth=2, threads=1)).image
    assert np.isfinite(img).all() and img.mean() > 0.02
