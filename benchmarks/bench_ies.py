"""What an IES profile costs a render: the same stage with its lights' profiles and without them (the lights
otherwise the same), rendered alternately in one process (`--rounds`, both orders), path and cook.

    python benchmarks/bench_ies.py [--rounds 5] [--spp 16]

Scenes: `scenes/lights.usda` (one profiled sconce among five lights and two emissive surfaces) and a wall and floor
lit by an 8 x 8 grid of downlights, each with `scenes/ies/downlight.ies` (many profiled lights).  Reported per scene
and integrator: the render time of each (medians) and their ratio, with the range of the rounds' ratios.  The
kernels are the general ones (`RTC_KERNELS=general`), so that both renders run the same code and the ratio is the
profile's own cost: its lookups, and the light samples its zeros save.
"""
from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def grid_stage(path: Path) -> list[str]:
    """The 8 x 8 grid of downlights before a wall, over a floor; the lights' paths."""
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdShade
    st = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(st, UsdGeom.Tokens.y)
    mat = UsdShade.Material.Define(st, '/Looks/M')
    sh = UsdShade.Shader.Define(st, '/Looks/M/S')
    sh.CreateIdAttr('UsdPreviewSurface')
    sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(0.6, 0.6, 0.6))
    sh.CreateInput('roughness', Sdf.ValueTypeNames.Float).Set(0.35)
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    for name, pts, order in (('Floor', [(-10, 0, -10), (10, 0, -10), (10, 0, 10), (-10, 0, 10)], [0, 3, 2, 1]),
                             ('Wall', [(-10, 0, -4), (10, 0, -4), (10, 6, -4), (-10, 6, -4)], [0, 1, 2, 3])):
        m = UsdGeom.Mesh.Define(st, f'/World/{name}')
        m.CreatePointsAttr(pts)
        m.CreateFaceVertexCountsAttr([4])
        m.CreateFaceVertexIndicesAttr(order)
        UsdShade.MaterialBindingAPI.Apply(m.GetPrim()).Bind(mat)
    names = []
    for i in range(8):
        for j in range(8):
            light = UsdLux.SphereLight.Define(st, f'/World/L{i}_{j}')
            light.CreateRadiusAttr(0.03)
            light.CreateIntensityAttr(400.0)
            x = UsdGeom.Xformable(light)
            x.AddTranslateOp().Set(Gf.Vec3d(-7 + 2 * i, 2.5, -3.7 + 1.0 * j))
            x.AddRotateXOp().Set(-90.0)
            api = UsdLux.ShapingAPI.Apply(light.GetPrim())
            api.CreateShapingIesFileAttr(Sdf.AssetPath(str(ROOT / 'scenes' / 'ies' / 'downlight.ies')))
            api.CreateShapingIesNormalizeAttr(True)
            names.append(str(light.GetPath()))
    cam = UsdGeom.Camera.Define(st, '/World/Cam')
    cam.CreateFocalLengthAttr(24.0)
    UsdGeom.Xformable(cam).AddTranslateOp().Set(Gf.Vec3d(0, 3, 9))
    UsdGeom.Xformable(cam).AddRotateXOp().Set(-12.0)
    st.GetRootLayer().Save()
    return names


def compare(path: Path, prims: list[str], integrators: list[str], rounds: int, spp: int) -> None:
    from pxr import Usd
    from rtc.renderer.host.render import Renderer
    from rtc.renderer.options import RenderOptions
    from rtc.renderer.usd.stage import read_stage
    renderers = {}
    for profiled in (True, False):
        st = Usd.Stage.Open(str(path))
        if not profiled:
            for p in prims:
                st.GetPrimAtPath(p).RemoveProperty('inputs:shaping:ies:file')
        desc = read_stage(st)
        assert all((l.ies is not None) == profiled for l in desc.lights if l.path in prims)
        renderers[profiled] = Renderer(desc, threads=1)
    try:
        for integ in integrators:
            opts = RenderOptions(width=320, height=240, spp=spp, integrator=integ,
                                 max_depth=3 if integ == 'path' else 4, threads=1)
            for r in renderers.values():
                r.render(RenderOptions(width=32, height=24, spp=1, integrator=integ, threads=1))
            t = {True: [], False: []}
            for k in range(rounds):
                for m in ((True, False) if k % 2 == 0 else (False, True)):
                    t0 = time.perf_counter()
                    renderers[m].render(opts)
                    t[m].append(time.perf_counter() - t0)
            ratios = [a / b for a, b in zip(t[True], t[False])]
            print(f'{path.name:16s} {integ:5s} profiled {statistics.median(t[True]):.3f} s, without '
                  f'{statistics.median(t[False]):.3f} s: {statistics.median(ratios):.3f}x '
                  f'(rounds {min(ratios):.3f}-{max(ratios):.3f})', flush=True)
    finally:
        for r in renderers.values():
            r.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--rounds', type=int, default=5)
    ap.add_argument('--spp', type=int, default=16)
    a = ap.parse_args()
    os.environ['RTC_KERNELS'] = 'general'
    compare(ROOT / 'scenes' / 'lights.usda', ['/World/Sconce'], ['path', 'cook'], a.rounds, a.spp)
    with tempfile.TemporaryDirectory() as tmp:
        grid = Path(tmp) / 'downlights.usda'
        compare(grid, grid_stage(grid), ['path', 'cook'], a.rounds, a.spp)


if __name__ == '__main__':
    main()
