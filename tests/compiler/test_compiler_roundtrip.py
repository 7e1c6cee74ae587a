"""Read compiled USD back with pxr (not the renderer) and recover what the XML says."""
from __future__ import annotations

import math

import numpy as np
import pytest
from pxr import Gf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade

from rtc.compiler.api import compile_to_stage
from rtc.compiler.diagnostics import Diagnostics
from rtc.compiler.transforms import compose
from rtc.compiler.xml_reader import read_scene
from tests.compiler.compiler_helpers import SCENES

ROUND_TRIP = ["ellipsoids", "bunnies", "shaders", "gallery", "motion", "dof", "cylinder", "orthographic"]


def _np(m: Gf.Matrix4d) -> np.ndarray:
    return np.array(m).T                         # Gf is row-vector; the compiler uses column vectors


def _close(a, b, rtol=1e-9):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert np.abs(a - b).max() <= rtol * max(1.0, np.abs(b).max()), (a, b)


@pytest.fixture(scope="module", params=ROUND_TRIP)
def compiled(request):
    path = SCENES / f"{request.param}.xml"
    scene = read_scene(path, Diagnostics(str(path)))
    stage, _ = compile_to_stage(path, width=400, height=300, spp=9)
    return scene, stage


def test_objects_and_instances(compiled):
    scene, stage = compiled
    geometry = stage.GetPrimAtPath("/World/Geometry").GetChildren() if scene.shapes else []
    assert len(geometry) == len(scene.shapes)
    instances = stage.GetPrimAtPath("/World/Instances").GetChildren() if scene.placements else []
    assert len(instances) == len(scene.placements)
    assert all(p.IsInstance() for p in instances)
    # one USD prototype per (prototype, shader) pair: an overriding shader gets its own copy
    pairs = {(id(p.prototype), id(p.effective_shader)) for p in scene.placements}
    assert len(stage.GetPrototypes()) == len(pairs)
    for shape, prim in zip(scene.shapes, geometry):
        kind = type(shape.geometry).__name__
        # every gprim is a Mesh (for tools that bind materials to meshes only); a sphere, box or
        # cylinder also names its exact UsdGeom shape in rtc:implicit, which rtc renders
        assert prim.GetTypeName() == "Mesh"
        implicit = prim.GetAttribute("rtc:implicit").Get() if prim.HasAttribute("rtc:implicit") else None
        flat = kind == "Box" and min(np.subtract(shape.geometry.max, shape.geometry.min)) == 0
        assert implicit == {"Sphere": "Sphere", "Box": None if flat else "Cube", "Triangle": None,
                            "Cylinder": "Cylinder", "MeshFile": None}[kind]
        if kind in ("Sphere", "Cylinder"):
            assert prim.GetAttribute("rtc:radius").Get() == shape.geometry.radius


def test_instance_world_matrices_match_the_xml(compiled):
    scene, stage = compiled
    instances = stage.GetPrimAtPath("/World/Instances").GetChildren() if scene.placements else []
    for placement, prim in zip(scene.placements, instances):
        for sample in placement.motion.samples or [None]:
            time = Usd.TimeCode.Default() if sample is None or sample.time is None else Usd.TimeCode(sample.time)
            world = _np(UsdGeom.XformCache(time).GetLocalToWorldTransform(prim))
            expected = compose(sample.ops) if sample is not None else np.eye(4)
            _close(world, expected)
        # the prototype's gprim, seen through the instance proxy: world = placement x geometry
        geom = stage.GetPrimAtPath(prim.GetPath().AppendChild("Geom"))
        assert geom.IsInstanceProxy()
        local = np.eye(4)
        if type(placement.prototype.geometry).__name__ in ("Sphere", "Cylinder"):
            local[:3, 3] = placement.prototype.geometry.center
        t0 = placement.motion.samples[0] if placement.motion.samples else None
        start = Usd.TimeCode.Default() if t0 is None or t0.time is None else Usd.TimeCode(t0.time)
        if type(placement.prototype.geometry).__name__ != "Box":
            _close(_np(UsdGeom.XformCache(start).GetLocalToWorldTransform(geom)),
                   (compose(t0.ops) if t0 else np.eye(4)) @ local)


def test_materials_carry_the_exact_course_parameters(compiled):
    scene, stage = compiled
    bound = {}
    for prim in Usd.PrimRange(stage.GetPseudoRoot(), Usd.TraverseInstanceProxies()):
        if prim.IsA(UsdGeom.Gprim):
            material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
            bound[str(prim.GetPath())] = material
    # every shader something renders with (a prototype's default that every placement overrides is
    # not written: each (prototype, shader) pair has its own prototype)
    rendered = {id(s): s for s in [o.shader for o in scene.shapes] + [p.effective_shader for p in scene.placements]}
    for shader in rendered.values():
        material = next(m for m in bound.values() if m and m.GetPrim().GetAttribute("rtc:model")
                        and _matches(m.GetPrim(), shader))
        assert material.GetPrim().GetAttribute("rtc:model").Get() == shader.model
    placements = stage.GetPrimAtPath("/World/Instances").GetChildren() if scene.placements else []
    for placement, prim in zip(scene.placements, placements):
        material = bound[str(prim.GetPath().AppendChild("Geom"))]
        assert _matches(material.GetPrim(), placement.effective_shader)


def _matches(prim, shader) -> bool:
    fields = {"diffuse": shader.diffuse, "specular": shader.specular, "phongExp": shader.phong_exp,
              "mirrorCoef": shader.mirror_coef, "roughness": shader.roughness,
              "refractiveIndex": shader.refractive_index, "attenuationCoef": shader.attenuation}
    if prim.GetAttribute("rtc:model").Get() != shader.model:
        return False
    for name, value in fields.items():
        attr = prim.GetAttribute(f"rtc:{name}")       # declared by RtcCourseMaterialAPI: test authored
        if value is None:
            if attr.HasAuthoredValue():
                return False
        elif not attr or not np.allclose(np.array(attr.Get(), float), value, rtol=0, atol=0):
            return False
    for name, texture in (("diffuseTexture", shader.diffuse_texture), ("specularTexture", shader.specular_texture)):
        attr = prim.GetAttribute(f"rtc:{name}")
        if (texture is None) != (not attr.HasAuthoredValue()):
            return False
        if texture is not None and attr.Get().resolvedPath != str(texture.path):
            return False
    return True


def test_camera_and_render_settings(compiled):
    scene, stage = compiled
    c = scene.camera
    cam = UsdGeom.Camera(stage.GetPrimAtPath("/World/Camera"))
    gf = cam.GetCamera(Usd.TimeCode.Default())
    _close(gf.transform.ExtractTranslation(), c.position)
    gaze = np.asarray(c.gaze) / np.linalg.norm(c.gaze)
    _close(np.array(gf.frustum.ComputeViewDirection()), gaze, 1e-6)
    assert cam.GetPrim().GetAttribute("rtc:focalLength").Get() == c.focal_length
    assert cam.GetPrim().GetAttribute("rtc:imagePlaneWidth").Get() == c.image_plane_width
    fov = gf.GetFieldOfView(Gf.Camera.FOVHorizontal)
    if c.projection == "perspective":
        assert fov == pytest.approx(math.degrees(2 * math.atan(c.image_plane_width / (2 * c.focal_length))), rel=1e-6)
    assert gf.projection == (Gf.Camera.Perspective if c.projection == "perspective" else Gf.Camera.Orthographic)
    assert gf.verticalAperture == pytest.approx(gf.horizontalAperture * 300 / 400, rel=1e-6)
    if c.lens_radius > 0:
        assert 0.1 * gf.focalLength / (2 * gf.fStop) == pytest.approx(c.lens_radius, rel=1e-6)
        assert gf.focusDistance == pytest.approx(c.focus_distance, rel=1e-6)
    settings = UsdRender.Settings(stage.GetPrimAtPath(stage.GetMetadata("renderSettingsPrimPath")))
    assert tuple(settings.GetResolutionAttr().Get()) == (400, 300)
    assert settings.GetPrim().GetAttribute("rtc:samplesPerPixel").Get() == 9
    # the background: a constant DomeLight other tools read as the world colour (none with an
    # environment map, which replaces it)
    dome = UsdLux.DomeLight(stage.GetPrimAtPath("/World/Lights/Background"))
    assert bool(dome) == (scene.environment is None)
    if dome:
        _close(dome.GetColorAttr().Get(), scene.background, 1e-7)
        assert dome.GetIntensityAttr().Get() == 1.0 and dome.GetPrim().GetAttribute("rtc:background").Get() is True


def test_lights_keep_the_course_values_and_the_reference_irradiance(compiled):
    scene, stage = compiled
    lights = [p for p in stage.GetPrimAtPath("/World/Lights").GetChildren() if not p.IsA(UsdLux.DomeLight)]
    assert len(lights) == len(scene.lights)
    for light, prim in zip(scene.lights, lights):
        lux = UsdLux.LightAPI(prim)
        world = _np(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(Usd.TimeCode.Default()))
        _close(world[:3, 3], light.position)
        _close(prim.GetAttribute("rtc:intensity").Get(), light.intensity)
        d = prim.GetAttribute("rtc:referenceDistance").Get()
        color = np.array(lux.GetColorAttr().Get(), float)
        if light.kind == "point":
            assert prim.IsA(UsdLux.SphereLight)
            irradiance = color * lux.GetIntensityAttr().Get() / 4 / d ** 2      # normalized point light
        else:
            assert prim.IsA(UsdLux.RectLight)
            area = light.width * light.length
            irradiance = color * lux.GetIntensityAttr().Get() * area / d ** 2   # small-source on axis
            n = np.asarray(light.normal) / np.linalg.norm(light.normal)
            _close(world[:3, :3] @ [0, 0, -1], n, 1e-12)
            assert UsdLux.RectLight(prim).GetWidthAttr().Get() == pytest.approx(light.width)
        _close(irradiance, light.intensity, 1e-6)
