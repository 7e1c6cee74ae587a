"""A stage lit by a rect light close above a floor (0.3 above it, 1.2 x 0.6): the case where sampling a
rect light uniformly in its solid angle (`kernel/light_sampling.spherical_rect`) beats sampling it by
area, with a wall behind lit only indirectly; `--glossy`: the floor a rough metal (metallic 1,
roughness 0.3) instead of a diffuse grey.

    python benchmarks/near_light.py near.usda
    python benchmarks/near_light.py near_glossy.usda --glossy
    python benchmarks/ab_noise.py near.usda --base HEAD~1 --spp 8 --ref-spp 256
"""
from __future__ import annotations

import sys


def near_light_stage(path: str, glossy: bool = False):
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade
    st = Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(st, UsdGeom.Tokens.y)
    mat = UsdShade.Material.Define(st, '/Looks/Grey')
    sh = UsdShade.Shader.Define(st, '/Looks/Grey/Surface')
    sh.CreateIdAttr('UsdPreviewSurface')
    sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.7, 0.7, 0.7))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    floor_mat = mat
    if glossy:
        floor_mat = UsdShade.Material.Define(st, '/Looks/Metal')
        sh = UsdShade.Shader.Define(st, '/Looks/Metal/Surface')
        sh.CreateIdAttr('UsdPreviewSurface')
        sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.9, 0.7, 0.4))
        sh.CreateInput('metallic', Sdf.ValueTypeNames.Float).Set(1.0)
        sh.CreateInput('roughness', Sdf.ValueTypeNames.Float).Set(0.3)
        floor_mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    for name, pts, order in (('Floor', [(-4, 0, -4), (4, 0, -4), (4, 0, 4), (-4, 0, 4)], [0, 3, 2, 1]),
                             ('Wall', [(-4, 0, -1), (4, 0, -1), (4, 3, -1), (-4, 3, -1)], [0, 1, 2, 3])):
        mesh = UsdGeom.Mesh.Define(st, f'/World/{name}')
        mesh.CreatePointsAttr(pts)
        mesh.CreateFaceVertexCountsAttr([4])
        mesh.CreateFaceVertexIndicesAttr(order)
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(floor_mat if name == 'Floor' else mat)
    light = UsdLux.RectLight.Define(st, '/World/Light')
    light.CreateWidthAttr(1.2)
    light.CreateHeightAttr(0.6)
    light.CreateIntensityAttr(8.0)
    UsdGeom.Xformable(light).AddTranslateOp().Set(Gf.Vec3d(0, 0.3, 0))
    UsdGeom.Xformable(light).AddRotateXOp().Set(-90.0)
    cam = UsdGeom.Camera.Define(st, '/World/Camera')
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 2.2, 4.5))
    cam.AddRotateXOp().Set(-22.0)
    st.Save()
    return st


if __name__ == '__main__':
    args = [a for a in sys.argv[1:] if a != '--glossy']
    near_light_stage(args[0] if args else 'near.usda', glossy='--glossy' in sys.argv[1:])
