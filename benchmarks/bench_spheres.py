"""Embree's own spheres (RTC_GEOMETRY_TYPE_SPHERE_POINT, the cook integrator's) against rtc's user-geometry
spheres (`rtc.renderer.host.user_geometry`, the path integrator's): the same rays traced bare, alternating.

    python benchmarks/bench_spheres.py --threads 1

Scenes: one unit sphere; three spheres in a row; a floor quad under three spheres (the glossy scene's
kind); 10,000 small spheres in a box (a point cloud) in one geometry (as many sphere lights are) and as a
geometry each (as sphere gprims are); 1,000 and 100 of them (radii 3x and 6x) in one geometry.  Rays: from a camera 5 units away towards the
spheres (hit and miss), random directions.  Reported per scene and query (rtcIntersect1, rtcOccluded1, and
16-ray packets of rtcIntersect16 / rtcOccluded16): ns a ray of each representation (medians of `--rounds`
alternating rounds) and their ratio, the hits checked equal.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # the repository root: numba caches the loops under
from benchmarks import embree_loops as EL                         # noqa: E402  # the tests' module name

from rtc.renderer.host.embree import Device                       # noqa: E402

QUAD = (np.array([[-6, -1, -6], [6, -1, -6], [6, -1, 6], [-6, -1, 6]], np.float32),
        np.array([[0, 1, 2], [0, 2, 3]], np.uint32))


def scenes(rng):
    cloud = np.concatenate([rng.uniform(-3, 3, (10_000, 3)), np.full((10_000, 1), 0.05)], 1)
    row = np.array([[-2.5, 0, 0, 1.0], [0, 0, 0, 1.0], [2.5, 0, 0, 1.0]])
    return {'one sphere': ([], [row[1:2]]), 'three spheres': ([], [row[k:k + 1] for k in range(3)]),
            'floor and three spheres': ([QUAD], [row[k:k + 1] for k in range(3)]),
            '10,000 spheres (one geometry)': ([], [cloud]),
            '10,000 spheres (a geometry each)': ([], [cloud[k:k + 1] for k in range(len(cloud))]),
            '1,000 spheres (one geometry)': ([], [cloud[:1000] * [1, 1, 1, 3]]),
            '100 spheres (one geometry)': ([], [cloud[:100] * [1, 1, 1, 6]])}


def rays(rng, n):
    o = np.tile(np.array([0.0, 0.5, -5.0], np.float32), (n, 1))
    target = rng.uniform([-4, -1.5, -1], [4, 1.5, 1], (n, 3))
    d = (target - o).astype(np.float32)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return o, d, np.zeros(n, np.float32), np.full(n, np.inf, np.float32), np.zeros(n, np.float32)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--rays', type=int, default=1_000_000)
    ap.add_argument('--rounds', type=int, default=7)
    ap.add_argument('--threads', type=int, default=1)
    a = ap.parse_args(argv)
    numba.set_num_threads(a.threads)
    rng = np.random.default_rng(5)
    r = rays(rng, a.rays)
    n = a.rays
    queries = {
        'intersect1': lambda h, out: EL.trace_rays(h, *r, out[0], out[1]),
        'intersect16': lambda h, out: EL.trace_packets(h, r, out[0], out[1], 16),
        'intersect8x2': lambda h, out: EL.trace_packets(h, r, out[0], out[1], 8),
        'occluded1': lambda h, out: EL.occlude_rays(h, *r, out[2]),
        'occluded16': lambda h, out: EL.occlude_packets(h, r, out[2], False, 16),
        'occluded8x2': lambda h, out: EL.occlude_packets(h, r, out[2], False, 8),
    }
    print(f'{n} rays, {a.threads} thread(s), medians of {a.rounds} alternating rounds: ns a ray, SPHERE_POINT / user')
    with Device(threads=a.threads) as dev:
        for name, (meshes, spheres) in scenes(rng).items():
            built = {kind: dev.prototype_scene(meshes, [s if kind == 'user' else s.astype(np.float32) for s in spheres],
                                               user_shapes=kind == 'user') for kind in ('point', 'user')}
            for q, run in queries.items():
                times = {k: [] for k in built}
                outs = {k: (np.empty(n, np.float32), np.empty((n, 4), np.uint32), np.empty(n, bool)) for k in built}
                for rnd in range(a.rounds + 1):
                    for k, scene in built.items():
                        t0 = time.perf_counter()
                        run(scene.handle, outs[k])
                        if rnd:
                            times[k].append(time.perf_counter() - t0)
                if q.startswith('intersect'):
                    agree = (outs['point'][1][:, 1] == outs['user'][1][:, 1]).mean()
                else:
                    agree = (outs['point'][2] == outs['user'][2]).mean()
                tp, tu = (statistics.median(times[k]) / n * 1e9 for k in ('point', 'user'))
                print(f'{name:32s} {q:12s} {tp:7.1f} {tu:7.1f}  ratio {tp / tu:5.2f}x   same hits {agree:.5f}')
            for scene in built.values():
                scene.close()
    return 0


if __name__ == '__main__':
    sys.exit(main())
