"""Write an animated, instanced, moving shot for `rtc render --frames` (tests and benchmarks/bench_shot.py).

    python benchmarks/gen_shot.py /tmp/shot.usda [--frames 24] [--instances 64] [--tris 20000]

One PointInstancer of `--instances` tori (one prototype mesh of about `--tris` triangles, from
benchmarks/gen_instancing.torus_mesh) whose positions are authored at every frame (they orbit the
origin), a camera dollying in, a distant sun and a ground square; the stage's time codes are
1..`--frames` at 24 fps, and the camera's shutter is [-0.25, 0.25] of a frame: the tori are
motion-blurred around every frame.  Only placements and the camera move: the prototype BVH is the
same in every frame (what the shot renderer reuses).
"""
from __future__ import annotations

import argparse

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade, Vt

try:
    from benchmarks.gen_instancing import torus_mesh
except ImportError:                              # run as a script from the benchmarks folder
    from gen_instancing import torus_mesh


def _material(stage, path, rgb):
    mat = UsdShade.Material.Define(stage, path)
    sh = UsdShade.Shader.Define(stage, path + '/Surface')
    sh.CreateIdAttr('UsdPreviewSurface')
    sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*rgb))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    return mat


def orbit_positions(n: int, frame: float, frames: int) -> np.ndarray:
    """float32 (n, 3): instance positions at `frame` (rings of tori turning about +y)."""
    k = np.arange(n)
    radius = 4.0 + 3.0 * (k % 3)
    angle = 2 * np.pi * k / n + 2 * np.pi * (frame - 1) / max(frames, 1) * (1.0 + 0.5 * (k % 3))
    return np.stack([radius * np.cos(angle), np.zeros(n), radius * np.sin(angle)], -1).astype(np.float32)


def write_shot(path: str, frames: int = 24, instances: int = 64, tris: int = 20_000,
               width: int = 320, height: int = 240, spp: int = 8) -> None:
    stage = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    stage.SetStartTimeCode(1)
    stage.SetEndTimeCode(frames)
    stage.SetTimeCodesPerSecond(24)
    stage.SetFramesPerSecond(24)
    world = UsdGeom.Xform.Define(stage, '/World')
    stage.SetDefaultPrim(world.GetPrim())
    red = _material(stage, '/World/Looks/Red', (0.8, 0.15, 0.1))
    grey = _material(stage, '/World/Looks/Grey', (0.5, 0.5, 0.5))

    cam = UsdGeom.Camera.Define(stage, '/World/Camera')
    cam.CreateShutterOpenAttr(-0.25)
    cam.CreateShutterCloseAttr(0.25)
    op = cam.AddTransformOp()
    for f in range(1, frames + 1):               # a dolly in and up
        u = (f - 1) / max(frames - 1, 1)
        eye = Gf.Vec3d(0, 9 - 3 * u, 26 - 8 * u)
        op.Set(Gf.Matrix4d().SetLookAt(eye, Gf.Vec3d(0, 0, 0), Gf.Vec3d(0, 1, 0)).GetInverse(), f)

    sun = UsdLux.DistantLight.Define(stage, '/World/Sun')
    sun.CreateIntensityAttr(3.0)
    sun.CreateAngleAttr(2.0)
    sun.CreateNormalizeAttr(True)
    UsdGeom.Xformable(sun).AddRotateXYZOp().Set(Gf.Vec3f(-50, 30, 0))

    ground = UsdGeom.Mesh.Define(stage, '/World/Ground')
    ground.CreatePointsAttr([(-30, 0, -30), (30, 0, -30), (30, 0, 30), (-30, 0, 30)])
    ground.CreateFaceVertexCountsAttr([4])
    ground.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    ground.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    UsdShade.MaterialBindingAPI.Apply(ground.GetPrim()).Bind(grey)

    pi = UsdGeom.PointInstancer.Define(stage, '/World/Tori')
    torus = torus_mesh(stage, '/World/Tori/Prototypes/Torus', tris)
    UsdShade.MaterialBindingAPI.Apply(torus.GetPrim()).Bind(red)
    pi.CreatePrototypesRel().SetTargets([torus.GetPath()])
    pi.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(np.zeros(instances, np.int32)))
    positions = pi.CreatePositionsAttr()
    for f in range(1, frames + 1):
        positions.Set(Vt.Vec3fArray.FromNumpy(orbit_positions(instances, f, frames)), f)

    from pxr import UsdRender
    settings = UsdRender.Settings.Define(stage, '/Render/Settings')
    settings.CreateResolutionAttr(Gf.Vec2i(width, height))
    settings.CreateCameraRel().SetTargets([cam.GetPath()])
    settings.GetPrim().CreateAttribute('rtc:samplesPerPixel', Sdf.ValueTypeNames.Int).Set(spp)
    stage.GetRootLayer().Save()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('path')
    ap.add_argument('--frames', type=int, default=24)
    ap.add_argument('--instances', type=int, default=64)
    ap.add_argument('--tris', type=int, default=20_000)
    a = ap.parse_args(argv)
    write_shot(a.path, a.frames, a.instances, a.tris)


if __name__ == '__main__':
    main()
