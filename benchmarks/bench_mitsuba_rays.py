"""Ray queries alone, rtc against Mitsuba 3, on the same rays: where the per-sample gap of the path
integrator against Mitsuba lies (tracing or shading).

    python benchmarks/bench_mitsuba_rays.py glossy cornell --threads 1

For each case of `bench_mitsuba_path.py` rtc renders its stage (path, 4 spp, 640 x 480) recording every
ray; the camera, shadow and BSDF ("secondary") rays are then traced bare by rtc's path top level
(`Renderer.path_scene()`, one ray at a time and in 16-wide packets) and by Mitsuba's scene of the same case
(`llvm_ad_rgb`: `ray_intersect_preliminary`, `ray_test` for shadow rays, on arrays of the same rays moved
back from rtc's camera-relative space).  Both report their hit counts (they must agree to a few rays in
10^5: the scenes are the same), and Mrays/s, median of `--rounds`.  Setup as bench_mitsuba.py.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_render as BR                                                  # noqa: E402
from bench_mitsuba_path import CAM, DEPTH, PathMitsuba, rtc_stage          # noqa: E402

from rtc.renderer.host.render import RenderOptions, Renderer               # noqa: E402
from rtc.renderer.usd.stage import read_stage                              # noqa: E402


def mitsuba_rates(case, rays, width, height, rounds, threads):
    import drjit as dr
    import mitsuba as mi
    dr.set_thread_count(threads)
    scene = PathMitsuba(case, width, height)._scene(4)
    eye = np.array(CAM[case][0], np.float32)
    out = {}
    for kind, (o, d, tn, tf, _) in rays.items():
        start = o + d * tn[:, None] + eye                     # Mitsuba's rays have no tnear
        maxt = np.where(np.isfinite(tf), tf - tn, np.inf).astype(np.float32)
        times, hits = [], 0
        for _ in range(rounds + 1):
            ray = mi.Ray3f(mi.Point3f(*[mi.Float(np.ascontiguousarray(start[:, i])) for i in range(3)]),
                           mi.Vector3f(*[mi.Float(np.ascontiguousarray(d[:, i])) for i in range(3)]))
            ray.maxt = mi.Float(maxt)
            dr.eval(ray)
            dr.sync_thread()
            t0 = time.perf_counter()
            if kind.startswith('shadow'):
                hits = int(np.array(scene.ray_test(ray)).sum())
            else:
                hits = int(np.isfinite(np.array(scene.ray_intersect_preliminary(ray).t)).sum())
            times.append(time.perf_counter() - t0)
        out[kind] = (len(o) / statistics.median(times[1:]) / 1e6, hits)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('cases', nargs='+', choices=['glossy', 'cornell'])
    ap.add_argument('--width', type=int, default=640)
    ap.add_argument('--height', type=int, default=480)
    ap.add_argument('--threads', type=int, default=1)
    ap.add_argument('--rounds', type=int, default=5)
    a = ap.parse_args(argv)
    numba.set_num_threads(a.threads)
    for case in a.cases:
        r = Renderer(read_stage(rtc_stage(case, a.width, a.height), camera_path='/World/Camera'))
        o = RenderOptions(width=a.width, height=a.height, spp=4, sampler='sobol', filter='box', max_depth=DEPTH[case],
                          integrator='path')
        r.render(RenderOptions(**{**o.__dict__, 'spp': 1}))
        rays = {k: rk for k, rk in BR.recorded_rays(r, o, 4, 1 << 16).items() if len(rk[0])}
        h = r.path_scene()
        rtc = {}
        for kind, rk in rays.items():
            for packets in (False, True):
                BR.replay(h, kind, tuple(x[:64] for x in rk), packets, width=r.packet_width)
                secs = statistics.median(BR.replay(h, kind, rk, packets, width=r.packet_width)
                                         for _ in range(a.rounds))
                rtc[kind, packets] = len(rk[0]) / secs / 1e6
            rtc[kind, 'hits'] = _rtc_hits(h, kind, rk)
        mi = mitsuba_rates(case, rays, a.width, a.height, a.rounds, a.threads)
        print(f'== {case} ({a.threads} thread(s), {a.width}x{a.height}, 4 spp of rays; rtc packets of 16 traced '
              f'{r.packet_width} at a time)')
        for kind, rk in rays.items():
            print(f'  {kind:10s} n={len(rk[0]):8d}  rtc {rtc[kind, False]:6.1f} single / {rtc[kind, True]:6.1f} '
                  f'packets  Mitsuba {mi[kind][0]:6.1f} Mrays/s   hits rtc {rtc[kind, "hits"]} Mitsuba {mi[kind][1]}')
        r.close()
    return 0


def _rtc_hits(handle, kind, rays) -> int:
    o, d, tn, tf, tm = rays
    n = len(o)
    if kind.startswith('shadow'):
        out = np.empty(n, np.bool_)
        BR.occlude_rays(handle, o, d, tn, tf, tm, out)
        return int(out.sum())
    t, ids = np.empty(n, np.float32), np.empty((n, 4), np.uint32)
    BR.trace_rays(handle, o, d, tn, tf, tm, t, ids)
    return int((ids[:, 1] != 0xFFFFFFFF).sum())


if __name__ == '__main__':
    sys.exit(main())
