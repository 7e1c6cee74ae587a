"""Pieces of small USD stages built by hand for the renderer's tests, and their render."""
import numpy as np
from pxr import Gf, UsdGeom, UsdLux

from rtc.renderer.host.render import Renderer
from rtc.renderer.options import RenderOptions
from rtc.renderer.usd.stage import read_stage


def light_and_camera(st, at=(0.4, 2.0, 0.3), size=1.0, intensity=20.0):
    """Stage st, +Y up, lit by a square RectLight facing down at `at` and seen by a camera at (0, 3, 3) looking 45
    degrees down at the origin; returns st."""
    UsdGeom.SetStageUpAxis(st, 'Y')
    light = UsdLux.RectLight.Define(st, '/Light')
    light.CreateIntensityAttr(intensity)
    light.CreateWidthAttr(size)
    light.CreateHeightAttr(size)
    light.AddTranslateOp().Set(Gf.Vec3d(*at))
    light.AddRotateXOp().Set(-90.0)
    cam = UsdGeom.Camera.Define(st, '/Cam')
    cam.AddTranslateOp().Set(Gf.Vec3d(0.0, 3.0, 3.0))
    cam.AddRotateXOp().Set(-45.0)
    return st


def render(st, integrator, spp=4, max_depth=3):
    """Stage st rendered at 48 x 36 on one thread, as float64."""
    with Renderer(read_stage(st), threads=1) as r:
        return r.render(RenderOptions(width=48, height=36, spp=spp, integrator=integrator, max_depth=max_depth,
                                      threads=1)).image.astype(np.float64)
