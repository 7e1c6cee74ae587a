"""UsdGeom.BasisCurves as Embree's round curves (rtc) against the same curves tessellated into triangle tubes, as a
renderer without native curves draws them: build time, peak memory, time a sample, and the difference of the images.

    python benchmarks/bench_curves.py [--curves 2000 20000] [--sides 6] [--steps 4] [--spp 16] [--rounds 3]
    python benchmarks/bench_curves.py --scene scenes/curves.usda      # a stage of one's own instead of the patch

The scene: a patch of N hair-like curves (pinned bspline of 5 points: 4 segments, tapering from width 0.02 to
0.004, leaning at random) on a floor, lit by a RectLight and a DomeLight, read by `read_stage`.  The tessellated
variant replaces the curves gprim by a mesh: each Bezier segment cut into `--steps` rings of `--sides` vertices
around the curve, at the curve's radius (2 x sides x steps triangles a segment), the same material.  With `--scene`,
that stage's tubes instead (its ribbons and linear curves stay as they are in both variants).

Each variant renders in a process of its own (so that its peak resident memory is its own), alternating native,
tessellated, tessellated, native, ... `--rounds` times; reported: the medians of the build's seconds (description
-> Embree scenes and tables), the time a sample of a path render (320 x 240, `--spp`, after a warm-up render that
loads the kernels), the process's peak RSS, and the mean |difference| of the two images relative to the native
image's mean, beside that of two native renders of different seeds (noise alone).
"""
from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

W, H = 320, 240


def hair_stage(n: int, seed: int = 3):
    """The patch of n curves (in memory)."""
    from pxr import Gf, Usd, UsdGeom, UsdLux, Vt
    rng = np.random.default_rng(seed)
    st = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(st, 'Y')
    floor = UsdGeom.Mesh.Define(st, '/Floor')
    floor.CreatePointsAttr([(-4, 0, -4), (-4, 0, 4), (4, 0, 4), (4, 0, -4)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    base = np.column_stack([rng.uniform(-1.5, 1.5, n), np.zeros(n), rng.uniform(-1.0, 1.0, n)])
    lean = rng.uniform(0, 2 * np.pi, n)
    height = rng.uniform(0.4, 0.8, n)
    t = np.linspace(0.0, 1.0, 5)
    bend = rng.uniform(0.1, 0.3, n)[:, None] * t ** 2
    pts = np.stack([base[:, 0:1] + bend * np.cos(lean)[:, None], height[:, None] * t,
                    base[:, 2:3] + bend * np.sin(lean)[:, None]], axis=2).reshape(-1, 3)
    hair = UsdGeom.BasisCurves.Define(st, '/Hair')
    hair.CreateBasisAttr('bspline')
    hair.CreateWrapAttr('pinned')
    hair.CreateCurveVertexCountsAttr([5] * n)
    hair.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pts.astype(np.float32)))
    hair.CreateWidthsAttr(Vt.FloatArray.FromNumpy(np.tile(0.02 - 0.016 * t, n).astype(np.float32)))
    hair.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
    hair.CreateDisplayColorPrimvar().Set([Gf.Vec3f(0.6, 0.45, 0.3)])
    key = UsdLux.RectLight.Define(st, '/Key')
    key.CreateWidthAttr(2.0)
    key.CreateHeightAttr(1.0)
    key.CreateIntensityAttr(12.0)
    key.AddTranslateOp().Set(Gf.Vec3d(1.0, 3.0, 2.0))
    key.AddRotateXYZOp().Set(Gf.Vec3f(-55, 20, 0))
    UsdLux.DomeLight.Define(st, '/Sky').CreateIntensityAttr(0.3)
    cam = UsdGeom.Camera.Define(st, '/Camera')
    cam.CreateFocalLengthAttr(35.0)
    cam.AddTranslateOp().Set(Gf.Vec3d(0, 1.2, 4.0))
    cam.AddRotateXOp().Set(-14.0)
    return st


def tube_mesh(curves, sides: int, steps: int):
    """The Bezier segments of a `Curves` record as one triangle mesh of tubes: rings of `sides` vertices at
    `steps` + 1 parameters of each segment (a frame carried from the segment's start), at the curve's radius."""
    from rtc.renderer import description as D
    rows = curves.segment_rows()                                   # (k, 4, 4)
    u = np.linspace(0.0, 1.0, steps + 1)
    s = 1.0 - u
    w = np.stack([s ** 3, 3 * s * s * u, 3 * s * u * u, u ** 3], axis=1)
    dw = np.stack([-3 * s * s, 3 * s * s - 6 * s * u, 6 * s * u - 3 * u * u, 3 * u * u], axis=1)
    c = np.einsum('nj,kjc->knc', w, rows)                           # (k, n, 4): centre and radius
    d = np.einsum('nj,kjc->knc', dw, rows[:, :, :3])
    t = d / np.maximum(np.linalg.norm(d, axis=2, keepdims=True), 1e-12)
    up = np.where(np.abs(t[:, :1, 1:2]) < 0.9, [0.0, 1.0, 0.0], [1.0, 0.0, 0.0])
    a = np.cross(t, up)
    a /= np.maximum(np.linalg.norm(a, axis=2, keepdims=True), 1e-12)
    b = np.cross(t, a)
    th = 2 * np.pi * np.arange(sides) / sides
    ring = (np.cos(th)[None, None, :, None] * a[:, :, None] + np.sin(th)[None, None, :, None] * b[:, :, None])
    pts = c[:, :, None, :3] + c[:, :, None, 3:] * ring                # (k, n, sides, 3)
    k, n = pts.shape[:2]
    idx = np.arange(k * n * sides).reshape(k, n, sides)
    q0, q1 = idx[:, :-1], np.roll(idx[:, :-1], -1, axis=2)
    q2, q3 = np.roll(idx[:, 1:], -1, axis=2), idx[:, 1:]
    tris = np.concatenate([np.stack([q0, q1, q2], -1).reshape(-1, 3), np.stack([q0, q2, q3], -1).reshape(-1, 3)])
    return D.Mesh(path=curves.path, points=pts.reshape(-1, 3), triangles=tris.astype(np.int32),
                  material=curves.material)


def child(args) -> None:
    from rtc.renderer.host.render import Renderer
    from rtc.renderer.options import RenderOptions
    from rtc.renderer.usd.stage import read_stage
    desc = read_stage(args.scene or hair_stage(args.curves[0]))
    if args.child == 'tess':
        for c in desc.containers:
            tubes = [x for x in c.curves if not x.linear and x.normals is None]
            c.meshes += [tube_mesh(x, args.sides, args.steps) for x in tubes]
            c.curves = [x for x in c.curves if x.linear or x.normals is not None]
    tris = sum(len(m.triangles) for c in desc.containers for m in c.meshes)
    t = time.perf_counter()
    r = Renderer(desc)
    build_s = time.perf_counter() - t
    opts = RenderOptions(width=W, height=H, spp=args.spp, integrator='path', max_depth=4, seed=args.seed)
    r.render(RenderOptions(width=W, height=H, spp=1, integrator='path', max_depth=4))           # kernels, lights
    res = r.render(opts)
    r.close()
    np.save(args.out, res.image)
    print(json.dumps({'build_s': build_s, 'sample_ns': res.stats.seconds / (W * H * args.spp) * 1e9,
                      'rss_mb': resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 'triangles': tris}))


def run(kind: str, n: int, a, out: str, seed: int = 0) -> dict:
    cmd = [sys.executable, __file__, '--child', kind, '--curves', str(n), '--sides', str(a.sides), '--steps',
           str(a.steps), '--spp', str(a.spp), '--seed', str(seed), '--out', out]
    cmd += ['--scene', a.scene] if a.scene else []
    return json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--curves', type=int, nargs='+', default=[2000, 20000])
    ap.add_argument('--sides', type=int, default=6)
    ap.add_argument('--steps', type=int, default=4)
    ap.add_argument('--spp', type=int, default=16)
    ap.add_argument('--rounds', type=int, default=3)
    ap.add_argument('--seed', type=int, default=0)
    ap.add_argument('--scene', help='a USD stage to measure instead of the patch of curves')
    ap.add_argument('--child', choices=['native', 'tess'])
    ap.add_argument('--out')
    a = ap.parse_args()
    if a.child:
        child(a)
        return
    tmp = Path(tempfile.mkdtemp())
    print(f'{W}x{H}, path, {a.spp} spp, max depth 4; tubes of {a.sides} sides x {a.steps} steps a segment; '
          f'{a.rounds} rounds alternating, medians')
    for n in ([0] if a.scene else a.curves):
        runs = {'native': [], 'tess': []}
        for k in range(a.rounds):
            for kind in (('native', 'tess') if k % 2 == 0 else ('tess', 'native')):
                runs[kind].append(run(kind, n, a, str(tmp / f'{kind}.npy')))
        run('native', n, a, str(tmp / 'native2.npy'), seed=1)
        img = {k: np.load(tmp / f'{k}.npy') for k in ('native', 'tess', 'native2')}
        m = {k: {f: statistics.median(r[f] for r in v) for f in v[0]} for k, v in runs.items()}
        geo = np.abs(img['tess'] - img['native']).mean() / img['native'].mean()
        noise = np.abs(img['native2'] - img['native']).mean() / img['native'].mean()
        print(f'{a.scene}: tubes {int(m["tess"]["triangles"] - m["native"]["triangles"])} triangles' if a.scene else
              f'{n} curves ({4 * n} segments; tubes: {int(m["tess"]["triangles"] - 2)} triangles)')
        for f, label in (('build_s', 'build s'), ('sample_ns', 'time a sample ns'), ('rss_mb', 'peak RSS MB')):
            print(f'  {label:18s} native {m["native"][f]:10.3f}  tessellated {m["tess"][f]:10.3f}  '
                  f'ratio {m["tess"][f] / m["native"][f]:.2f}x')
        print(f'  image |tessellated - native| / mean {geo:.4f}  (noise: two native seeds {noise:.4f})')


if __name__ == '__main__':
    main()
