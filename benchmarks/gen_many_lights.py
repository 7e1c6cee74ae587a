"""USD stages of many lights for the A/B scripts (`ab_render.py`, `ab_noise.py`): the four stages of
`bench_many_lights.py` (diffuse and glossy, dominant and bright) and a *room* of another character: a closed
room (diffuse walls, one red, a glossy metal and a plastic sphere, a mirror-like metal box), lit by a 12 x 12
grid of small ceiling panels, 120 point lights of mixed brightness and 24 instanced wall sconces (a box and a
rect light each) - 289 lights in all, where light bounces off the walls, so later vertices matter as much as
the first.

    python benchmarks/gen_many_lights.py OUT_DIR [--lights 1000]

also writes the one-light stages of `bench_many_lights.py` (one.usda, gone.usda: the glossy one).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from benchmarks.bench_many_lights import stage  # noqa: E402
from benchmarks.bench_rect_images import _material  # noqa: E402  (a UsdPreviewSurface material)


def _quad(st, path, corners, mat):
    from pxr import UsdGeom, UsdShade
    m = UsdGeom.Mesh.Define(st, path)
    m.CreatePointsAttr([tuple(map(float, c)) for c in corners])
    m.CreateFaceVertexCountsAttr([4])
    m.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    m.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    UsdShade.MaterialBindingAPI.Apply(m.GetPrim()).Bind(mat)


def room():
    """The room stage (10 x 4 x 10, y up, the camera in a corner looking across it)."""
    from pxr import Gf, Usd, UsdGeom, UsdLux, UsdRender, UsdShade
    st = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(st, UsdGeom.Tokens.y)
    white = _material(st, '/Looks/White', (0.6, 0.6, 0.6), 0.7)
    red = _material(st, '/Looks/Red', (0.6, 0.1, 0.08), 0.7)
    gold = _material(st, '/Looks/Gold', (0.9, 0.7, 0.3), 0.2, 1.0)
    plastic = _material(st, '/Looks/Plastic', (0.1, 0.2, 0.6), 0.1)
    steel = _material(st, '/Looks/Steel', (0.8, 0.8, 0.8), 0.05, 1.0)
    a, h = 5.0, 4.0                                   # faces wound to face into the room
    _quad(st, '/World/Floor', [(-a, 0, -a), (-a, 0, a), (a, 0, a), (a, 0, -a)], white)
    _quad(st, '/World/Ceiling', [(-a, h, -a), (a, h, -a), (a, h, a), (-a, h, a)], white)
    _quad(st, '/World/Back', [(-a, 0, -a), (a, 0, -a), (a, h, -a), (-a, h, -a)], white)
    _quad(st, '/World/Front', [(-a, 0, a), (-a, h, a), (a, h, a), (a, 0, a)], white)
    _quad(st, '/World/Left', [(-a, 0, -a), (-a, h, -a), (-a, h, a), (-a, 0, a)], red)
    _quad(st, '/World/Right', [(a, 0, -a), (a, 0, a), (a, h, a), (a, h, -a)], white)
    for path, pos, r, mat in (('/World/Gold', (-1.5, 1.0, -1.5), 1.0, gold),
                              ('/World/Plastic', (1.8, 0.7, 0.5), 0.7, plastic)):
        s = UsdGeom.Sphere.Define(st, path)
        s.CreateRadiusAttr(r)
        UsdGeom.Xformable(s).AddTranslateOp().Set(Gf.Vec3d(*pos))
        UsdShade.MaterialBindingAPI.Apply(s.GetPrim()).Bind(mat)
    box = UsdGeom.Cube.Define(st, '/World/Box')
    box.CreateSizeAttr(1.2)
    UsdGeom.Xformable(box).AddTranslateOp().Set(Gf.Vec3d(1.0, 0.6, -2.5))
    UsdGeom.Xformable(box).AddRotateYOp().Set(30.0)
    UsdShade.MaterialBindingAPI.Apply(box.GetPrim()).Bind(steel)
    for i in range(12):                               # ceiling panels
        for j in range(12):
            l = UsdLux.RectLight.Define(st, f'/World/Panels/P{i}_{j}')
            l.CreateWidthAttr(0.25)
            l.CreateHeightAttr(0.25)
            l.CreateIntensityAttr(1.2)
            UsdGeom.Xformable(l).AddTranslateOp().Set(Gf.Vec3d(-4.4 + 0.8 * i, h - 0.01, -4.4 + 0.8 * j))
            UsdGeom.Xformable(l).AddRotateXOp().Set(-90.0)
    rng = np.random.default_rng(7)
    for k in range(120):                              # point lights of mixed brightness
        l = UsdLux.SphereLight.Define(st, f'/World/Points/L{k}')
        l.CreateTreatAsPointAttr(True)
        l.CreateIntensityAttr(float(rng.uniform(0.02, 0.4) ** 2 * 3))
        UsdGeom.Xformable(l).AddTranslateOp().Set(Gf.Vec3d(*rng.uniform([-4.5, 0.3, -4.5], [4.5, 3.7, 4.5])))
    UsdGeom.Xform.Define(st, '/Sconce')
    UsdShade.MaterialBindingAPI.Apply(UsdGeom.Cube.Define(st, '/Sconce/Box').GetPrim()).Bind(white)
    st.GetPrimAtPath('/Sconce/Box').GetAttribute('size').Set(0.15)
    lamp = UsdLux.RectLight.Define(st, '/Sconce/Light')
    lamp.CreateWidthAttr(0.12)
    lamp.CreateHeightAttr(0.12)
    lamp.CreateIntensityAttr(6.0)
    UsdGeom.Xformable(lamp).AddTranslateOp().Set(Gf.Vec3d(0, 0, 0.08))  # facing away from the wall (+Z)
    for k in range(24):                               # on the back and right walls
        p = st.DefinePrim(f'/World/Sconces/S{k}')
        p.GetReferences().AddInternalReference('/Sconce')
        p.SetInstanceable(True)
        xf = UsdGeom.Xformable(p)
        if k < 12:
            xf.AddTranslateOp().Set(Gf.Vec3d(-4.0 + 0.75 * k, 2.5, -a + 0.08))
        else:
            xf.AddTranslateOp().Set(Gf.Vec3d(a - 0.08, 2.5, -4.0 + 0.75 * (k - 12)))
            xf.AddRotateYOp().Set(-90.0)
    cam = UsdGeom.Camera.Define(st, '/World/Camera')
    cam.AddTranslateOp().Set(Gf.Vec3d(-3.8, 2.6, 4.6))
    cam.AddRotateYOp().Set(-35.0)
    cam.AddRotateXOp().Set(-12.0)
    cam.CreateFocalLengthAttr(18.0)
    rs = UsdRender.Settings.Define(st, '/Render/Settings')
    rs.CreateResolutionAttr(Gf.Vec2i(320, 240))
    return st


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('out', type=Path)
    ap.add_argument('--lights', type=int, default=1000)
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    for name, minor, glossy in (('dominant', 0.02, False), ('bright', 1.0, False), ('gdominant', 0.02, True),
                                ('gbright', 1.0, True)):
        st = stage(a.lights, minor, True, glossy)          # (kept: a layer lives as long as its stage)
        st.GetRootLayer().Export(str(a.out / f'{name}.usda'))
    for name, st in (('one', stage(1, 1.0, True, False)), ('gone', stage(1, 1.0, True, True)), ('room', room())):
        st.GetRootLayer().Export(str(a.out / f'{name}.usda'))
    print(f'wrote {", ".join(p.name for p in sorted(a.out.glob("*.usda")))} to {a.out}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
