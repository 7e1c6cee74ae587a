"""Reading a UsdLux CylinderLight (length, radius, normalize, the transform's scale); the light tree
holds a cylinder light with the box of the cylinder as its bounds."""
import math

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdLux

from rtc.renderer import description as D
from rtc.renderer.host.build import build
from rtc.renderer.host.light_selection import path_lights
from rtc.renderer.kernel.light_tree import light_pmf
from rtc.renderer.host.light_tree import leaf_record
from rtc.renderer.kernel.tables import T_C, T_RADIUS
from rtc.renderer.usd.stage import read_stage
from tests.renderer.handmade import look_at, quad, scene, translate


def _stage():
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, 'Y')
    UsdGeom.Xform.Define(stage, '/World')
    return stage


def test_cylinder_light_is_read_with_its_scale_and_normalize():
    stage = _stage()
    cyl = UsdLux.CylinderLight.Define(stage, '/World/Tube')
    cyl.CreateLengthAttr(2.0); cyl.CreateRadiusAttr(0.25); cyl.CreateIntensityAttr(3.0)
    cyl.CreateColorAttr((1.0, 0.5, 0.25))
    cyl.AddTranslateOp().Set(Gf.Vec3d(1, 2, 3))
    cyl.AddRotateZOp().Set(90.0)                        # its axis (local X) along world +Y
    cyl.AddScaleOp().Set(Gf.Vec3f(2, 3, 3))
    norm = UsdLux.CylinderLight.Define(stage, '/World/TubeN')
    norm.CreateNormalizeAttr(True); norm.CreateIntensityAttr(3.0)
    norm.AddScaleOp().Set(Gf.Vec3f(2, 3, 3))
    default = UsdLux.CylinderLight.Define(stage, '/World/Default')
    desc = read_stage(stage)
    lights = {l.path: l for l in desc.lights}
    t = lights['/World/Tube']
    assert t.type == D.CYLINDER and (t.length, t.radius) == pytest.approx((4.0, 0.75))
    assert t.radiance == pytest.approx((3.0, 1.5, 0.75))
    np.testing.assert_allclose(t.matrix[:3, 0], (0, 1, 0), atol=1e-12)
    np.testing.assert_allclose(t.matrix[:3, 3], (1, 2, 3), atol=1e-12)
    np.testing.assert_allclose(t.matrix[:3, :3] @ t.matrix[:3, :3].T, np.eye(3), atol=1e-12)
    assert lights['/World/TubeN'].radiance == pytest.approx((3.0 / (2 * math.pi * 0.75 * 4.0),) * 3)
    d = lights['/World/Default']
    assert (d.length, d.radius) == pytest.approx((1.0, 0.5))          # UsdLux defaults
    assert not any('not supported' in w for w in desc.warnings)


def test_cylinder_light_with_unequal_y_and_z_scales_is_warned():
    stage = _stage()
    cyl = UsdLux.CylinderLight.Define(stage, '/World/Tube')
    cyl.AddScaleOp().Set(Gf.Vec3f(1, 1, 4))
    desc = read_stage(stage)
    assert desc.lights[0].radius == pytest.approx(0.5 * 2.0)                # 0.5 sqrt(1 x 4)
    assert any('CylinderLight' in w and 'mean radius' in w for w in desc.warnings)


def _path_lights(desc):
    built = build(desc)
    L, _ = path_lights(desc, built.data.li_f, built.top.bounds(), len(built.top.groups))
    return built, L


def _scene(meshes, materials, instances=None, lights=()):
    cam = D.Camera(path='/cam', matrix=look_at((0.0, 3.0, 8.0), (0.0, 0.0, 0.0)))
    return scene([D.Container('/', meshes=meshes)], materials, list(lights), cam, instances=instances)


def test_the_light_tree_bounds_a_cylinder_by_its_box():
    m = translate(1.0, 2.0, 3.0)
    light = D.Light(path='/c', type=D.CYLINDER, matrix=m, radiance=(1.0,) * 3, radius=0.5, length=4.0)
    desc = _scene([quad(10.0)], [D.Material('/m')], lights=[light])
    built, L = _path_lights(desc)
    try:
        assert L.depth[0] == 1 and L.n_bounded == 1 and list(L.shapes) == [0]
        origin = desc.camera.matrix[:3, 3]
        leaf = leaf_record(L.tree_f, L.tree_i, 0)
        np.testing.assert_allclose(leaf[T_C:T_C + 3] + origin, (1.0, 2.0, 3.0), atol=1e-5)   # (float32)
        assert leaf[T_RADIUS] == pytest.approx(0.5 * math.sqrt(4.0 ** 2 + 1.0 + 1.0), rel=1e-6)
        for p in ((1.0, 2.0, 5.0), (1.0, 0.0, 3.0), (5.0, 2.0, 3.0), (1.0, 4.0, 3.0)):   # every side sees it
            n = (np.array([1.0, 2.0, 3.0]) - p) / np.linalg.norm(np.array([1.0, 2.0, 3.0]) - p)
            assert light_pmf(L, tuple(np.array(p) - origin), tuple(n), 0) == 1.0
    finally:
        built.close()
