"""Embree's fixed cost per query: the path integrator's own rays traced bare against top levels that hold
next to nothing, beside the scene's own top level.

    python benchmarks/bench_query_cost.py scenes/ellipsoids.xml /tmp/glossy.usda --threads 1

For each scene the working tree renders it (path, `--spp` samples of `--width` x `--height`, recording
every ray: `bench_render.recorded_rays`); the camera, shadow and BSDF ("secondary") rays are then traced,
one by one and in 16-ray packets, `--rounds` times alternating, against:

* *empty*: a top level with no geometry (the replay loop and Embree's API, no BVH);
* *1 far triangle*: one triangle no ray meets, in the top level itself (one BVH, rejected at its root);
* *instance of it*: the same triangle as the one placement of a prototype (an instance array of one);
* *both*: the triangle and its instance (two BVHs in the top level);
* *scene*: the scene's own path top level (`Renderer.path_scene()`).

Reported: ns per ray (median).  The differences are what a query pays before it meets any geometry: per
BVH it traverses and per instance it enters; a 16-ray packet pays them once for its rays.

Then, against the scene's own top level, the BSDF rays as a wavefront could trace them: reordered within
consecutive groups of `--group` rays (the recorded order is tile by tile, so a group is one tile's
bounces), by direction octant and then by the Morton code of the origin in the group's box, and traced
one by one and in 16-ray packets, in Embree's default and coherent modes
(`RTC_RAY_QUERY_FLAG_COHERENT`), beside the recorded order.
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
import bench_render as BR                                          # noqa: E402
from ab_render import load                                         # noqa: E402

from benchmarks.embree_loops import trace_packets, trace_packets_coherent, trace_rays  # noqa: E402
from rtc.renderer.host.embree import InstanceGroup                 # noqa: E402
from rtc.renderer.host.render import RenderOptions, Renderer      # noqa: E402


def _tops(r):
    """{name: Embree scene} of the near-empty top levels and the scene's own, and the objects to keep."""
    dev = r.built.device
    far = [(np.array([[1e4, 1e4, 1e4], [1e4 + 1, 1e4, 1e4], [1e4, 1e4 + 1, 1e4]], np.float32),
            np.array([[0, 1, 2]], np.uint32))]
    proto = dev.prototype_scene(far, [])
    once = InstanceGroup(np.zeros(1, np.uint32), np.eye(4, dtype=np.float32)[None, None, :3])
    keep = [proto,
            dev.top_scene([], [], direct=[(0, None, [], [], ())]),
            dev.top_scene([], [], direct=[(0, None, far, [], ())]),
            dev.top_scene([proto], [once]),
            dev.top_scene([proto], [once], direct=[(1, None, far, [], ())])]
    names = ['empty', '1 far triangle', 'instance of it', 'both']
    tops = {n: s.handle for n, s in zip(names, keep[1:])}
    tops['scene'] = r.path_scene()
    return tops, keep


def _spread10(x):
    """The bits of 10-bit integers x spread to every third bit (for a 30-bit Morton code)."""
    x = x.astype(np.uint64) & np.uint64(0x3FF)
    for shift, mask in ((16, 0x30000FF), (8, 0x300F00F), (4, 0x30C30C3), (2, 0x9249249)):
        x = (x | (x << np.uint64(shift))) & np.uint64(mask)
    return x


def sorted_in_groups(rays, group: int):
    """`rays` reordered within consecutive groups of `group`: by direction octant, then by the Morton
    code of the origin in the group's bounding box."""
    o, d = rays[0], rays[1]
    order = np.empty(len(o), np.int64)
    for g0 in range(0, len(o), group):
        og, dg = o[g0:g0 + group], d[g0:g0 + group]
        lo = og.min(0)
        q = ((og - lo) / np.maximum(og.max(0) - lo, 1e-30) * 1023).astype(np.int64)
        morton = _spread10(q[:, 0]) | (_spread10(q[:, 1]) << np.uint64(1)) | (_spread10(q[:, 2]) << np.uint64(2))
        octant = ((dg < 0) @ np.array([1, 2, 4])).astype(np.uint64)
        order[g0:g0 + group] = g0 + np.argsort((octant << np.uint64(30)) | morton, kind='stable')
    return tuple(np.ascontiguousarray(x[order]) for x in rays)


def _trace(handle, rays, mode: str, width: int) -> float:
    """Seconds to trace closest hits of `rays`: mode 'single', 'packets' or 'coherent' (packets of 16
    traced `width` at a time)."""
    o, d, tn, tf, tm = rays
    n = len(o)
    t_out, ids = np.empty(n, np.float32), np.empty((n, 4), np.uint32)
    t0 = time.perf_counter()
    if mode == 'single':
        trace_rays(handle, o, d, tn, tf, tm, t_out, ids)
    else:
        (trace_packets if mode == 'packets' else trace_packets_coherent)(handle, rays, t_out, ids, width)
    return time.perf_counter() - t0


def wavefront_order(handle, rays, group: int, rounds: int, width: int = 16) -> dict:
    """{(order, mode): ns per ray} of the BSDF rays against the top level `handle`, alternating."""
    orders = {'recorded': rays, f'sorted in {group}s': sorted_in_groups(rays, group)}
    runs = [(name, mode) for name in orders for mode in ('single', 'packets', 'coherent')]
    for name, mode in runs:
        _trace(handle, tuple(x[:64] for x in orders[name]), mode, width)
    times = {run: [] for run in runs}
    for _ in range(rounds):
        for name, mode in runs:
            times[name, mode].append(_trace(handle, orders[name], mode, width))
    return {k: statistics.median(v) / len(rays[0]) * 1e9 for k, v in times.items()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('scenes', nargs='+')
    ap.add_argument('--width', type=int, default=320)
    ap.add_argument('--height', type=int, default=240)
    ap.add_argument('--spp', type=int, default=4)
    ap.add_argument('--max-depth', type=int, default=8)
    ap.add_argument('--threads', type=int, default=1)
    ap.add_argument('--rounds', type=int, default=5)
    ap.add_argument('--group', type=int, default=1024, help='BSDF rays reordered within groups of this many')
    a = ap.parse_args(argv)
    numba.set_num_threads(a.threads)
    print(f'ns per ray, median of {a.rounds} rounds, {a.threads} thread(s); single / packets of 16 (traced as '
          f'Embree runs them here: `Device.packet_width`)')
    for path in a.scenes:
        r = Renderer(load(path))
        o = RenderOptions(width=a.width, height=a.height, spp=a.spp, sampler='sobol', filter='box',
                          max_depth=a.max_depth, integrator='path')
        r.render(RenderOptions(**{**o.__dict__, 'spp': 1}))
        rays = {k: rk for k, rk in BR.recorded_rays(r, o, a.spp, 1 << 16).items() if len(rk[0])}
        tops, keep = _tops(r)
        print(f'== {Path(path).name}')
        for kind, rk in rays.items():
            runs = [(name, h, packets) for name, h in tops.items() for packets in (False, True)]
            for _, h, packets in runs:
                BR.replay(h, kind, tuple(x[:64] for x in rk), packets, width=r.packet_width)
            times = {run[0::2]: [] for run in runs}
            for _ in range(a.rounds):                          # alternating: the machine is shared and noisy
                for name, h, packets in runs:
                    times[name, packets].append(BR.replay(h, kind, rk, packets, width=r.packet_width))
            ns = {k: statistics.median(v) / len(rk[0]) * 1e9 for k, v in times.items()}
            print(f'  {kind:10s} n={len(rk[0]):8d}  ' + '  '.join(
                f'{name} {ns[name, False]:5.1f} / {ns[name, True]:5.1f}' for name in tops))
        if 'secondary' in rays:
            ns = wavefront_order(tops['scene'], rays['secondary'], a.group, a.rounds, r.packet_width)
            print('  BSDF rays against the scene, single / packets / coherent packets: ' + '  '.join(
                f'{name} {ns[name, "single"]:5.1f} / {ns[name, "packets"]:5.1f} / {ns[name, "coherent"]:5.1f}'
                for name in dict.fromkeys(k[0] for k in ns)))
        for s in keep[1:] + keep[:1]:                          # the top levels, then the prototype they place
            s.close()
        r.close()
    return 0


if __name__ == '__main__':
    sys.exit(main())
