"""The light tree's build on the host (`host/light_tree.build_tree`), against a base revision's, alternating in
one process; and the whole light set-up of the path integrator for a large emissive point cloud.

    python benchmarks/bench_light_build.py --base HEAD~1 [--sizes 1000 10000 50000 200000] [--rounds 5]

For each size n, two sets of light bounds, as `light_tree.light_bounds` and `surface_lights` give them:
  points  n point and sphere lights at random (every cone the whole sphere of directions);
  rects   n rect lights facing every way, a fifth of them two-sided (cones that the build must unite).
Both versions build a tree of the same bounds, `--rounds` times each, alternating (base, new, new, base, ...);
reported: the median seconds of each, their ratio, and whether the trees are identical (tree_f, tree_i and
every light's trail and depth).  Then `light_selection.path_lights` (the tree, the emissive surfaces' tables)
of a scene whose only light is an emissive UsdGeom.Points cloud of n points (a light each), new version only
(before this build, such a cloud was no light).
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.ab_render import base_tree, import_copy  # noqa: E402
from rtc.renderer.host import light_tree as new_tree  # noqa: E402

ENTIRE = (np.array([0.0, 0.0, 1.0]), -1.0)


def bounds_of(kind: str, n: int, seed: int = 1) -> list:
    rng = np.random.default_rng(seed)
    c = rng.uniform(-50.0, 50.0, (n, 3))
    phi = rng.uniform(0.1, 2.0, n)
    if kind == 'points':
        r = np.where(rng.random(n) < 0.5, 0.0, rng.uniform(0.05, 0.3, n))
        return [(c[k] - r[k], c[k] + r[k], float(phi[k]), ENTIRE, False) for k in range(n)]
    w = rng.normal(size=(n, 3))
    w /= np.linalg.norm(w, axis=1)[:, None]
    return [(c[k] - 0.25, c[k] + 0.25, float(phi[k]), (w[k], 1.0), k % 5 == 0) for k in range(n)]


def time_build(build, bounds: list) -> tuple[float, tuple]:
    t = time.perf_counter()
    out = build(list(range(len(bounds))), bounds)
    return time.perf_counter() - t, out


def same(a: tuple, b: tuple) -> bool:
    return np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1]) and a[2] == b[2]


def cloud_stage(n: int):
    """A floor under an emissive UsdGeom.Points cloud of n points (diameter 0.04), its only light."""
    from pxr import Sdf, Usd, UsdGeom, UsdShade
    st = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(st, 'Y')
    floor = UsdGeom.Mesh.Define(st, '/World/Floor')
    floor.CreatePointsAttr([(-6, 0, -6), (-6, 0, 6), (6, 0, 6), (6, 0, -6)])
    floor.CreateFaceVertexCountsAttr([4])
    floor.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    pts = UsdGeom.Points.Define(st, '/World/Sparks')
    pts.CreatePointsAttr(np.random.default_rng(2).uniform((-3, 1, -3), (3, 5, 3), (n, 3)).astype(np.float32))
    pts.CreateWidthsAttr([0.04])
    mat = UsdShade.Material.Define(st, '/World/Glow')
    shader = UsdShade.Shader.Define(st, '/World/Glow/Surface')
    shader.CreateIdAttr('UsdPreviewSurface')
    shader.CreateInput('emissiveColor', Sdf.ValueTypeNames.Color3f).Set((5.0, 3.0, 1.0))
    mat.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), 'surface')
    UsdShade.MaterialBindingAPI.Apply(pts.GetPrim()).Bind(mat)
    UsdGeom.Camera.Define(st, '/World/Cam').AddTranslateOp().Set((0.0, 3.0, 12.0))
    return st


def cloud_setup(n: int) -> float:
    """Seconds of `path_lights` for the scene of `cloud_stage(n)`."""
    from rtc.renderer.host.build import build
    from rtc.renderer.host.light_selection import path_lights
    from rtc.renderer.usd.stage import read_stage
    desc = read_stage(cloud_stage(n))
    built = build(desc)
    try:
        t = time.perf_counter()
        L, _ = path_lights(desc, built.data.li_f, built.top.bounds(), len(built.top.groups), data=built.data)
        dt = time.perf_counter() - t
        assert L.n_surface == n, L.n_surface
        return dt
    finally:
        built.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--base', default='HEAD')
    ap.add_argument('--sizes', type=int, nargs='+', default=[1000, 10000, 50000, 200000])
    ap.add_argument('--rounds', type=int, default=5)
    a = ap.parse_args()
    base = import_copy(base_tree(a.base), 'rtc_ab_base')
    base_build = sys.modules[base.__name__.rsplit('.', 1)[0] + '.light_tree'].build_tree
    print(f'base {a.base} vs working tree; medians of {a.rounds} rounds, alternating')
    for kind in ('points', 'rects'):
        for n in a.sizes:
            bounds = bounds_of(kind, n)
            tb, tn, ok = [], [], True
            for r in range(a.rounds):
                pair = [('base', base_build), ('new', new_tree.build_tree)]
                outs = {}
                for name, fn in (pair if r % 2 == 0 else pair[::-1]):
                    dt, outs[name] = time_build(fn, bounds)
                    (tb if name == 'base' else tn).append(dt)
                ok &= same(outs['base'], outs['new'])
            mb, mn = statistics.median(tb), statistics.median(tn)
            print(f'{kind:7s} n={n:7d}  base {mb:8.3f} s  new {mn:7.3f} s  speed-up {mb / mn:6.1f}x  '
                  f'trees {"identical" if ok else "DIFFERENT"}', flush=True)
    for n in a.sizes:
        print(f'emissive cloud of {n} points: path_lights {statistics.median(cloud_setup(n) for _ in range(3)):.3f} s',
              flush=True)


if __name__ == '__main__':
    main()
