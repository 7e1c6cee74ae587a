"""What posing skinned gprims costs a stage read (`renderer/usd/skinning.py`): a grid mesh of N points bound to a chain
of J joints (4 influences a point, linear or dual-quaternion skinning), read at a frame of its animation, against
the same stage with its skeleton binding removed (the bind pose, what rtc drew before).  Each variant is read
`--rounds` times, alternating, in this process; medians.

    python benchmarks/bench_skinning.py [--points 100000 400000] [--joints 32] [--rounds 5]
"""
from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np
from pxr import Gf, Usd, UsdGeom, UsdSkel, Vt

from rtc.renderer.usd.stage import read_stage


def skinned_stage(n_points: int, n_joints: int, method: str) -> Usd.Stage:
    st = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(st, 'Y')
    root = UsdSkel.Root.Define(st, '/Model')
    skel = UsdSkel.Skeleton.Define(st, '/Model/Skel')
    names = ['/'.join(f'j{k}' for k in range(i + 1)) for i in range(n_joints)]
    skel.CreateJointsAttr(names)
    step = Gf.Matrix4d().SetTranslate(Gf.Vec3d(0, 1, 0))
    world = [Gf.Matrix4d().SetTranslate(Gf.Vec3d(0, i, 0)) for i in range(n_joints)]
    skel.CreateBindTransformsAttr(world)
    skel.CreateRestTransformsAttr([Gf.Matrix4d(1)] + [step] * (n_joints - 1))
    anim = UsdSkel.Animation.Define(st, '/Model/Skel/Anim')
    anim.CreateJointsAttr(names)
    anim.CreateTranslationsAttr([Gf.Vec3f(0, 0, 0)] + [Gf.Vec3f(0, 1, 0)] * (n_joints - 1))
    anim.CreateScalesAttr([Gf.Vec3h(1, 1, 1)] * n_joints)
    a = math.radians(40.0 / n_joints) / 2
    anim.CreateRotationsAttr().Set([Gf.Quatf(math.cos(a), 0, 0, math.sin(a))] * n_joints, 1.0)
    UsdSkel.BindingAPI.Apply(skel.GetPrim()).CreateAnimationSourceRel().SetTargets([anim.GetPath()])
    UsdSkel.BindingAPI.Apply(root.GetPrim()).CreateSkeletonRel().SetTargets([skel.GetPath()])
    side = int(math.sqrt(n_points))
    x, y = np.meshgrid(np.linspace(-1, 1, side), np.linspace(0, n_joints - 1, side))
    pts = np.stack([x.ravel(), y.ravel(), np.zeros(side * side)], 1)
    quads = (np.arange(side - 1)[:, None] * side + np.arange(side - 1)[None, :]).ravel()
    mesh = UsdGeom.Mesh.Define(st, '/Model/Body')
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts.astype(np.float32)))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(quads), 4, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(
        np.stack([quads, quads + 1, quads + side + 1, quads + side], 1).ravel().astype(np.int32)))
    j0 = np.clip(np.floor(pts[:, 1]).astype(np.int32) - 1, 0, n_joints - 4)
    idx = (j0[:, None] + np.arange(4)[None, :]).astype(np.int32)
    w = np.exp(-(pts[:, 1:2] - idx) ** 2)
    w = (w / w.sum(1, keepdims=True)).astype(np.float32)
    binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
    binding.CreateJointIndicesPrimvar(False, 4).Set(Vt.IntArray.FromNumpy(idx.ravel()))
    binding.CreateJointWeightsPrimvar(False, 4).Set(Vt.FloatArray.FromNumpy(w.ravel()))
    binding.CreateGeomBindTransformAttr(Gf.Matrix4d(1))
    binding.CreateSkinningMethodAttr(method)
    return st


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--points', type=int, nargs='+', default=[100_000, 400_000])
    ap.add_argument('--joints', type=int, default=32)
    ap.add_argument('--rounds', type=int, default=5)
    a = ap.parse_args()
    print(f'{"points":>8} {"method":>15} {"bind pose s":>12} {"posed s":>9} {"ratio":>6}')
    for n in a.points:
        for method in ('classicLinear', 'dualQuaternion'):
            posed = skinned_stage(n, a.joints, method)
            unposed = skinned_stage(n, a.joints, method)
            UsdSkel.BindingAPI(unposed.GetPrimAtPath('/Model')).GetSkeletonRel().ClearTargets(True)
            times = {'bind': [], 'posed': []}
            for _ in range(a.rounds):
                for name, st in (('bind', unposed), ('posed', posed)):
                    t0 = time.perf_counter()
                    read_stage(st, time=1.0)
                    times[name].append(time.perf_counter() - t0)
            b, p = statistics.median(times['bind']), statistics.median(times['posed'])
            print(f'{n:>8} {method:>15} {b:>12.3f} {p:>9.3f} {p / b:>6.2f}')


if __name__ == '__main__':
    main()
