"""What reading primvars through materials costs the stage reader on many native instances.

    python benchmarks/bench_primvar_materials.py [--instances 10000] [--rounds 5]

A stage of N instanceable references to one prototype (a sphere bound to a UsdPreviewSurface), in three
cases: *plain* (no primvars on the instances), *primvars, unread* (each instance root authors its own
`primvars:tint`, which no material reads: before 2026-12-06 the reader did not look at such instances; now it
marks them as needing material resolution, and siblings that bind alike share one query), *primvars, read*
(the material's diffuseColor reads `tint` through a UsdPrimvarReader_float3: each instance its own
material, resolved on its own).  Reported: the median seconds of `read_stage` over `--rounds` (cases
alternating within each round), the materials and material sets read.  Run it at two commits to compare them
(the stages are built the same way at each).  Then one PointInstancer of 10 N instances whose material
reads `tint`, which it gives each instance from 0 (none), 35 or 5,000 distinct values.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def stage(n: int, primvars: bool, read: bool):
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade
    st = Usd.Stage.CreateInMemory()
    mat = UsdShade.Material.Define(st, '/Looks/M')
    sh = UsdShade.Shader.Define(st, '/Looks/M/Surface')
    sh.CreateIdAttr('UsdPreviewSurface')
    if read:
        rd = UsdShade.Shader.Define(st, '/Looks/M/Tint')
        rd.CreateIdAttr('UsdPrimvarReader_float3')
        rd.CreateInput('varname', Sdf.ValueTypeNames.String).Set('tint')
        sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).ConnectToSource(
            rd.CreateOutput('result', Sdf.ValueTypeNames.Float3))
    else:
        sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).Set((0.5, 0.5, 0.5))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    proto = UsdGeom.Xform.Define(st, '/Proto')
    proto.GetPrim().SetSpecifier(Sdf.SpecifierClass)
    ball = UsdGeom.Sphere.Define(st, '/Proto/Ball')
    UsdShade.MaterialBindingAPI.Apply(ball.GetPrim()).Bind(mat)
    side = int(n ** 0.5) + 1
    for k in range(n):
        inst = UsdGeom.Xform.Define(st, f'/World/I{k}')
        inst.GetPrim().GetReferences().AddInternalReference('/Proto')
        inst.GetPrim().SetInstanceable(True)
        inst.AddTranslateOp().Set(Gf.Vec3d(3.0 * (k % side), 0.0, 3.0 * (k // side)))
        if primvars:
            UsdGeom.PrimvarsAPI(inst.GetPrim()).CreatePrimvar('tint', Sdf.ValueTypeNames.Color3fArray).Set(
                [((k % 7) / 7.0, 0.5, 1.0 - (k % 5) / 5.0)])
    return st


def instancer(n: int, distinct: int):
    """One PointInstancer of n spheres whose material reads `tint`, which the instancer gives each instance from
    `distinct` values (0: it gives none)."""
    from pxr import Sdf, Usd, UsdGeom, UsdShade
    st = Usd.Stage.CreateInMemory()
    mat = UsdShade.Material.Define(st, '/Looks/M')
    sh = UsdShade.Shader.Define(st, '/Looks/M/Surface')
    sh.CreateIdAttr('UsdPreviewSurface')
    rd = UsdShade.Shader.Define(st, '/Looks/M/Tint')
    rd.CreateIdAttr('UsdPrimvarReader_float3')
    rd.CreateInput('varname', Sdf.ValueTypeNames.String).Set('tint')
    sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).ConnectToSource(
        rd.CreateOutput('result', Sdf.ValueTypeNames.Float3))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')
    pi = UsdGeom.PointInstancer.Define(st, '/World/PI')
    side = int(n ** 0.5) + 1
    k = np.arange(n)
    pi.CreatePositionsAttr(np.column_stack([3.0 * (k % side), np.zeros(n), 3.0 * (k // side)]).astype(np.float32))
    pi.CreateProtoIndicesAttr(np.zeros(n, np.int32))
    ball = UsdGeom.Sphere.Define(st, '/World/PI/Protos/Ball')
    pi.CreatePrototypesRel().SetTargets([ball.GetPath()])
    UsdShade.MaterialBindingAPI.Apply(ball.GetPrim()).Bind(mat)
    if distinct:
        j = k % distinct
        values = np.column_stack([j / distinct, np.full(n, 0.5), 1.0 - j / distinct]).astype(np.float32)
        UsdGeom.PrimvarsAPI(pi.GetPrim()).CreatePrimvar('tint', Sdf.ValueTypeNames.Color3fArray,
                                                        UsdGeom.Tokens.varying).Set(values)
    return st


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--instances', type=int, default=10_000)
    ap.add_argument('--rounds', type=int, default=5)
    a = ap.parse_args(argv)
    from rtc.renderer.usd.stage import read_stage
    cases = {'plain': (False, False), 'primvars, unread': (True, False), 'primvars, read': (True, True)}
    stages = {name: stage(a.instances, *c) for name, c in cases.items()}
    n_pi = a.instances * 10
    for distinct in (0, 35, 5000):
        stages[f'PI, {distinct} values'] = instancer(n_pi, distinct)
    times = {name: [] for name in stages}
    counts = {}
    for _ in range(a.rounds):
        for name, st in stages.items():
            t0 = time.perf_counter()
            desc = read_stage(st)
            times[name].append(time.perf_counter() - t0)
            counts[name] = (len(desc.materials), len(desc.instances.material_sets))
    for name in stages:
        base = statistics.median(times['plain' if name in cases else 'PI, 0 values'])
        t = statistics.median(times[name])
        print(f'{name:>18}: read_stage {t:.3f} s (median of {a.rounds}; {t / base:.2f}x '
              f'{"plain" if name in cases else "no primvars"}), {counts[name][0]} materials, {counts[name][1]} '
              f'material sets, {a.instances if name in cases else n_pi} instances')
    return 0


if __name__ == '__main__':
    sys.exit(main())
