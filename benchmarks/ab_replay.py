"""Embree's time alone on the path integrator's own rays: the top level of a base revision against the
working tree's, replayed bare (no shading), alternating in one process.

    python benchmarks/ab_replay.py scenes/gallery.xml scenes/ellipsoids.xml --base 21482e0 --threads 1

Each scene is read once; the working tree renders it (path, `--spp` samples of a `--width` x `--height`
image) recording every ray it traces (`bench_render.recorded_rays`), then both versions' path top levels
(`Renderer.path_scene()`) trace those rays `--rounds` times, alternating: camera rays in 16-wide packets
as the renderer traces them, shadow and BSDF rays one by one.  Rays are camera-relative in both
versions, so the same rays meet the same scene.  Reported: Mrays/s of each and the median of the
per-round time ratios base / new (> 1: the new top level is faster), with the range.
"""
from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

import numba

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_render as BR                                          # noqa: E402
from ab_render import base_tree, for_renderer, import_copy, load  # noqa: E402

from rtc.renderer.host.render import RenderOptions, Renderer      # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('scenes', nargs='+')
    ap.add_argument('--base', default='HEAD', help='git revision of the baseline (default HEAD)')
    ap.add_argument('--width', type=int, default=320)
    ap.add_argument('--height', type=int, default=240)
    ap.add_argument('--spp', type=int, default=4)
    ap.add_argument('--max-depth', type=int, default=8)
    ap.add_argument('--threads', type=int, default=1, help='replay threads')
    ap.add_argument('--rounds', type=int, default=9)
    a = ap.parse_args(argv)
    base = import_copy(base_tree(a.base), 'rtc_base_renderer')
    numba.set_num_threads(a.threads)
    print(f'base {a.base} vs working tree: Embree replay of the path integrator\'s rays, {a.width}x{a.height}, '
          f'{a.spp} spp, max depth {a.max_depth}, {a.threads} thread(s), {a.rounds} rounds')
    for path in a.scenes:
        desc = load(path)
        o = RenderOptions(width=a.width, height=a.height, spp=a.spp, sampler='sobol', filter='box',
                          max_depth=a.max_depth, integrator='path')
        with Renderer(desc) as new:
            new.render(RenderOptions(**{**o.__dict__, 'spp': 1}))
            rays = {k: rk for k, rk in BR.recorded_rays(new, o, a.spp, 1 << 15).items() if len(rk[0])}
            old = base.Renderer(for_renderer(desc, base))
            try:
                old.path_lights()
                handles = {'base': old.path_scene(), 'new': new.path_scene()}
                for h in handles.values():                            # compile / load the replay kernels
                    for k, rk in rays.items():
                        BR.replay(h, k, tuple(x[:64] for x in rk), k == 'camera')
                t = {n: [] for n in handles}
                for _ in range(a.rounds):
                    for n, h in handles.items():
                        t[n].append(sum(BR.replay(h, k, rk, k == 'camera') for k, rk in rays.items()))
            finally:
                old.close()
        ratios = [tb / tn for tb, tn in zip(t['base'], t['new'])]
        n = sum(len(rk[0]) for rk in rays.values())
        print(f'{Path(path).name:16s} rays {n:8d}  base {n / statistics.median(t["base"]) / 1e6:5.1f}  '
              f'new {n / statistics.median(t["new"]) / 1e6:5.1f} Mrays/s   base/new time '
              f'{statistics.median(ratios):.3f} (range {min(ratios):.3f}-{max(ratios):.3f})', flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
