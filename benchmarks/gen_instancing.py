"""Write large instancing stages for timing `rtc.renderer.usd.stage.read_stage`, and time it.

    python benchmarks/gen_instancing.py native 100000 /tmp/native_1e5.usdc
    python benchmarks/gen_instancing.py pi 1000000 /tmp/pi_1e6.usdc
    python benchmarks/gen_instancing.py pi-mesh 1000000 /tmp/pim_1e6.usdc [--tris 100000]
    python benchmarks/gen_instancing.py time /tmp/native_1e5.usdc [more files] [--repeat 3] [--tree DIR ...]

``time``: `read_stage(path)` (open included) in a fresh process per measurement, then again split
into `Usd.Stage.Open` and `read_stage(stage)`; wall and CPU seconds, median of ``--repeat``
rounds.  Each ``--tree`` is a checkout whose ``renderer`` package is imported instead of this one
(e.g. ``git archive HEAD~1 renderer | tar -x -C /tmp/before``); trees alternate within every round
so that A/B comparisons share the machine's load.

``native``: N instanceable Xforms (``MakeMatrixXform`` placements) referencing one of two
prototypes in an ``over "Prototypes"`` library (the layout rtc's compiler writes); every tenth
instance overrides its material with ``strongerThanDescendants`` so the reader has to resolve
bindings per instance.  ``pi``: one PointInstancer with N instances of three prototypes
(positions, ``orientationsf``, scales, an ``invisibleIds`` mask on 1% of them).  ``pi-mesh``: the
render-at-scale case of benchmarks/bench_render.py - one PointInstancer with N instances of a single
torus mesh of ``--tris`` triangles (default 100 000) scattered over a 200 x 200 ground square, a
distant light and a ground plane; instances shrink as 1/sqrt(N) so the image covers the same
fraction of the square at every N (render time then measures the BVH, not the amount of surface).

The native instances are authored through the Sdf layer API, with no stage open on the layer:
going through ``UsdGeom`` per prim would make the generator, not the reader, the slow part.
"""
from __future__ import annotations

import os
import sys

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt


def _common(stage: Usd.Stage) -> None:
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, '/World')
    stage.SetDefaultPrim(world.GetPrim())
    cam = UsdGeom.Camera.Define(stage, '/World/Camera')
    cam.AddTransformOp().Set(Gf.Matrix4d().SetLookAt(Gf.Vec3d(0, 60, 160), Gf.Vec3d(0, 0, 0),
                                                     Gf.Vec3d(0, 1, 0)).GetInverse())
    for name, rgb in (('Red', (0.8, 0.1, 0.1)), ('Grey', (0.5, 0.5, 0.5))):
        mat = UsdShade.Material.Define(stage, f'/World/Looks/{name}')
        sh = UsdShade.Shader.Define(stage, f'/World/Looks/{name}/Surface')
        sh.CreateIdAttr('UsdPreviewSurface')
        sh.CreateInput('diffuseColor', Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*rgb))
        mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), 'surface')


def _prototype_meshes(stage: Usd.Stage, root: str) -> list[str]:
    """Two small prototypes: a tetrahedron mesh and a sphere."""
    UsdGeom.Xform.Define(stage, f'{root}/Tet')
    mesh = UsdGeom.Mesh.Define(stage, f'{root}/Tet/Geom')
    mesh.CreatePointsAttr([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)])
    mesh.CreateFaceVertexCountsAttr([3, 3, 3, 3])
    mesh.CreateFaceVertexIndicesAttr([0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3])
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(
        UsdShade.Material(stage.GetPrimAtPath('/World/Looks/Grey')))
    UsdGeom.Xform.Define(stage, f'{root}/Ball')
    UsdGeom.Sphere.Define(stage, f'{root}/Ball/Geom').CreateRadiusAttr(0.5)
    return [f'{root}/Tet', f'{root}/Ball']


def write_native(n: int, path: str) -> None:
    stage = Usd.Stage.CreateNew(path)
    _common(stage)
    protos = _prototype_meshes(stage, '/Prototypes')
    stage.GetPrimAtPath('/Prototypes').SetSpecifier(Sdf.SpecifierOver)
    UsdGeom.Xform.Define(stage, '/World/Instances')
    stage.GetRootLayer().Save()
    del stage          # edit the bare layer: no stage recomposing after every change
    layer = Sdf.Layer.FindOrOpen(path)
    rng = np.random.default_rng(1)
    pos = rng.uniform(-100, 100, (n, 3))
    red = Sdf.Path('/World/Looks/Red')
    with Sdf.ChangeBlock():
        parent = layer.GetPrimAtPath('/World/Instances')
        for i in range(n):
            spec = Sdf.PrimSpec(parent, f'I{i}', Sdf.SpecifierDef, 'Xform')
            spec.instanceable = True
            spec.referenceList.prependedItems.append(Sdf.Reference('', protos[i % 2]))
            op = Sdf.AttributeSpec(spec, 'xformOp:transform', Sdf.ValueTypeNames.Matrix4d)
            op.default = Gf.Matrix4d().SetTranslate(Gf.Vec3d(*pos[i]))
            order = Sdf.AttributeSpec(spec, 'xformOpOrder', Sdf.ValueTypeNames.TokenArray,
                                      Sdf.VariabilityUniform)
            order.default = Vt.TokenArray(['xformOp:transform'])
            if i % 10 == 0:
                spec.SetInfo('apiSchemas', Sdf.TokenListOp.Create(prependedItems=['MaterialBindingAPI']))
                rel = Sdf.RelationshipSpec(spec, 'material:binding')
                rel.targetPathList.explicitItems.append(red)
                rel.SetInfo('bindMaterialAs', 'strongerThanDescendants')
    layer.Save()


def write_point_instancer(n: int, path: str) -> None:
    stage = Usd.Stage.CreateNew(path)
    _common(stage)
    pi = UsdGeom.PointInstancer.Define(stage, '/World/Scatter')
    protos = _prototype_meshes(stage, '/World/Scatter/Prototypes')
    cube = UsdGeom.Cube.Define(stage, '/World/Scatter/Prototypes/Box')
    cube.CreateSizeAttr(0.8)
    pi.CreatePrototypesRel().SetTargets([*protos, cube.GetPath()])
    rng = np.random.default_rng(2)
    q = rng.normal(size=(n, 4)).astype(np.float32)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    pi.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(rng.integers(0, 3, n).astype(np.int32)))
    pi.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(rng.uniform(-100, 100, (n, 3)).astype(np.float32)))
    pi.CreateOrientationsfAttr(Vt.QuatfArray.FromNumpy(q))
    pi.CreateScalesAttr(Vt.Vec3fArray.FromNumpy(rng.uniform(0.5, 1.5, (n, 3)).astype(np.float32)))
    pi.CreateIdsAttr(Vt.Int64Array.FromNumpy(np.arange(n, dtype=np.int64)))
    pi.CreateInvisibleIdsAttr(Vt.Int64Array.FromNumpy(np.arange(0, n, 100, dtype=np.int64)))
    stage.GetRootLayer().Save()


def torus_mesh(stage: Usd.Stage, path: str, tris: int) -> UsdGeom.Mesh:
    """A torus (radii 1, 0.35, lying in the xz plane, resting on y = 0) of about `tris` triangles
    (quads split in two)."""
    nu = max(3, int(round(np.sqrt(tris / 2 * 2.5))))
    nv = max(3, int(round(tris / 2 / nu)))
    u = 2 * np.pi * np.arange(nu) / nu
    v = 2 * np.pi * np.arange(nv) / nv
    uu, vv = np.meshgrid(u, v, indexing='ij')
    rr = 1.0 + 0.35 * np.cos(vv)
    pts = np.stack([rr * np.cos(uu), 0.35 + 0.35 * np.sin(vv), rr * np.sin(uu)], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing='ij')
    a = i * nv + j
    b = ((i + 1) % nu) * nv + j
    c = ((i + 1) % nu) * nv + (j + 1) % nv
    d = i * nv + (j + 1) % nv
    quads = np.stack([a, d, c, b], -1).reshape(-1, 4)
    tri = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]], 1).reshape(-1, 3)
    mesh = UsdGeom.Mesh.Define(stage, path)
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts.astype(np.float32)))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(tri), 3, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(tri.astype(np.int32).ravel()))
    mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    return mesh


def write_point_instancer_mesh(n: int, path: str, tris: int = 100_000) -> None:
    from pxr import UsdLux
    stage = Usd.Stage.CreateNew(path)
    _common(stage)
    light = UsdLux.DistantLight.Define(stage, '/World/Sun')
    light.CreateIntensityAttr(3.0)
    light.CreateAngleAttr(2.0)
    light.CreateNormalizeAttr(True)          # irradiance 3 whatever the angle (un-normalised: 3 pi sin^2(1 deg))
    UsdGeom.Xformable(light).AddRotateXYZOp().Set(Gf.Vec3f(-50, 30, 0))
    ground = UsdGeom.Mesh.Define(stage, '/World/Ground')
    ground.CreatePointsAttr([(-150, 0, -150), (150, 0, -150), (150, 0, 150), (-150, 0, 150)])
    ground.CreateFaceVertexCountsAttr([4])
    ground.CreateFaceVertexIndicesAttr([0, 3, 2, 1])
    ground.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    UsdShade.MaterialBindingAPI.Apply(ground.GetPrim()).Bind(
        UsdShade.Material(stage.GetPrimAtPath('/World/Looks/Grey')))
    pi = UsdGeom.PointInstancer.Define(stage, '/World/Scatter')
    torus = torus_mesh(stage, '/World/Scatter/Prototypes/Torus', tris)
    UsdShade.MaterialBindingAPI.Apply(torus.GetPrim()).Bind(
        UsdShade.Material(stage.GetPrimAtPath('/World/Looks/Red')))
    pi.CreatePrototypesRel().SetTargets([torus.GetPath()])
    rng = np.random.default_rng(3)
    pos = np.zeros((n, 3), np.float32)
    pos[:, [0, 2]] = rng.uniform(-100, 100, (n, 2))
    yaw = rng.uniform(0, np.pi, n)
    # rotation about +y by 2 yaw.  Vt.QuatfArray.FromNumpy takes GfQuatf's memory layout, (i, j, k, real):
    # (real, i, j, k) columns gave a half-turn about a horizontal axis that buried every torus under the
    # ground (benchmarks before 2026-12-01 rendered the ground alone)
    q = np.zeros((n, 4), np.float32)
    q[:, 3] = np.cos(yaw)
    q[:, 1] = np.sin(yaw)
    s = np.float32(0.35 * 200.0 / np.sqrt(n))
    pi.CreateProtoIndicesAttr(Vt.IntArray.FromNumpy(np.zeros(n, np.int32)))
    pi.CreatePositionsAttr(Vt.Vec3fArray.FromNumpy(pos))
    pi.CreateOrientationsfAttr(Vt.QuatfArray.FromNumpy(q))
    pi.CreateScalesAttr(Vt.Vec3fArray.FromNumpy(np.full((n, 3), s, np.float32)))
    stage.GetRootLayer().Save()


_TIMER = r"""
import sys, time
sys.path.insert(0, sys.argv[1])
from pxr import Usd
from rtc.renderer.usd.stage import read_stage
w, c = time.perf_counter, time.process_time
t, tc = w(), c()
if sys.argv[3] == 'total':
    d = read_stage(sys.argv[2])
    print(w() - t, c() - tc, 0, 0, d.instances.count)
else:
    stage = Usd.Stage.Open(sys.argv[2])
    t1, tc1 = w(), c()
    d = read_stage(stage)
    print(t1 - t, tc1 - tc, w() - t1, c() - tc1, d.instances.count)
"""


def time_reads(files: list[str], trees: list[str], repeat: int) -> None:
    import statistics
    import subprocess
    runs: dict = {}
    for _ in range(repeat):
        for path in files:
            for tree in trees:
                for mode in ('total', 'split'):
                    out = subprocess.run([sys.executable, '-c', _TIMER, tree, path, mode], check=True,
                                         capture_output=True, text=True).stdout.split()
                    runs.setdefault((path, tree, mode), []).append([float(x) for x in out])
    print(f'{"file":28s} {"tree":24s} {"read_stage wall/cpu s":>22s} {"open wall/cpu":>14s} '
          f'{"read(stage) wall/cpu":>21s} placements')
    for path in files:
        for tree in trees:
            total = runs[(path, tree, 'total')]
            split = runs[(path, tree, 'split')]
            med = [statistics.median(r[i] for r in total) for i in (0, 1)] + \
                  [statistics.median(r[i] for r in split) for i in range(4)]
            print(f'{os.path.basename(path):28s} {tree[-24:]:24s} {med[0]:10.3f} {med[1]:10.3f} '
                  f'{med[2]:6.3f} {med[3]:6.3f} {med[4]:10.3f} {med[5]:9.3f} {int(total[0][4]):>11d}')


def main(argv: list[str]) -> int:
    if len(argv) > 2 and argv[1] == 'time':
        args, trees, repeat = argv[2:], [], 3
        while '--tree' in args:
            k = args.index('--tree')
            trees.append(os.path.abspath(args[k + 1]))
            args = args[:k] + args[k + 2:]
        if '--repeat' in args:
            k = args.index('--repeat')
            repeat = int(args[k + 1])
            args = args[:k] + args[k + 2:]
        time_reads(args, trees or [os.path.dirname(os.path.dirname(os.path.abspath(__file__)))], repeat)
        return 0
    tris = 100_000
    if '--tris' in argv:
        k = argv.index('--tris')
        tris = int(argv[k + 1])
        argv = argv[:k] + argv[k + 2:]
    if len(argv) != 4 or argv[1] not in ('native', 'pi', 'pi-mesh'):
        print(__doc__)
        return 2
    kind, n, path = argv[1], int(argv[2]), argv[3]
    if kind == 'pi-mesh':
        write_point_instancer_mesh(n, path, tris)
    else:
        (write_native if kind == 'native' else write_point_instancer)(n, path)
    print(f'wrote {path}: {n} {kind} instances')
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
