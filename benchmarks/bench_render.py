"""Renderer throughput against its own rays replayed on bare Embree, phase times and peak memory.

    python benchmarks/bench_render.py scenes/gallery.xml --width 320 --height 240 --spp 64
    python benchmarks/bench_render.py scenes/*.xml --spp 64 --rounds 5 --scaling
    python benchmarks/bench_render.py big.usdc --width 640 --height 480 --spp 16 --no-replay

Per scene (USD, or course XML compiled in memory with `rtc.cli.load_scene`):

* phases: load (XML compile + USD read), build (Embree BVHs + shading tables), first pass (1 spp of
  the whole image: the first-pixel latency of a warm process), full render, image output (PNG);
* rays traced by kind (camera, shadow, secondary: the integrator's per-tile counters) and the
  renderer's rate in Mrays/s;
* the **bare-Embree replay**: the integrator's recording mode stores every ray of `--record-spp`
  samples per pixel, traced as one pass as in the passes of a long render (origin, direction, tnear,
  tfar, time, kind: camera, first-hit shadow, deeper shadow, secondary); they are replayed in the same
  process with `embree_loops.trace_rays` / `occlude_rays` (single rays) and `trace_packets` /
  `occlude_packets` (packets of 16 in recorded order, traced 16 or 8 at a time as the renderer traces
  them, `Renderer.packet_width`: the renderer's own packets for camera and first-hit shadow rays).  The bare time of the full render is sum_k N_k / rate_k over the kinds k,
  and **ratio = bare time / render time** (1.0 = the renderer costs nothing but Embree), against
  three replays: *single* (every ray alone, `rtcIntersect1`/`rtcOccluded1`: the plain bare loop),
  *as traced* (the kinds the renderer traces in packets - camera and first-hit shadow rays - as
  packets, the others alone: the renderer's own Embree calls, so 1 - ratio is exactly its time outside
  Embree) and *packets* (every kind in packets: the fastest Embree could trace these rays).  Render
  and replays alternate in every round (the machine is shared and noisy); medians over rounds are
  reported, ratios are medians of per-round ratios.  The as-traced replay time is the "tracing"
  share of the render; "shading" is the rest (sampling, shading, film);
* peak RSS (`resource.getrusage`, high-water mark of the process) after each phase;
* `--scaling`: the same render with 1 and 2 numba threads, interleaved.

`--threads N` sets the render's threads and numba's, so that the replays run on as many threads as the
render (before, `--threads 1` replayed on every core and halved the ratios).
"""
from __future__ import annotations

import argparse
import os
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np


from rtc.renderer.host import film as film_mod  # noqa: E402
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # the repository root: numba caches the loops under
from benchmarks.embree_loops import (occlude_packets, occlude_rays, ray_masks, trace_packets,  # noqa: E402
                                     trace_rays, trace_rays_masked)
from rtc.renderer.host.render import RenderOptions, Renderer  # noqa: E402
from rtc.renderer.kernel.integrator import (RAYS_CAMERA, RAYS_SECONDARY, RAYS_SHADOW, RAYS_SHADOW_PACKET,  # noqa: E402
                                            N_COUNTERS)
from rtc.renderer.kernel.tiles import n_tiles  # noqa: E402
from rtc.renderer.kernel.ray_record import R_DX, R_OX, R_TFAR, R_TIME, R_TNEAR, new_ray_record  # noqa: E402
from rtc.renderer.options import resolve  # noqa: E402

KINDS = {'camera': RAYS_CAMERA, 'shadow0': RAYS_SHADOW_PACKET, 'shadow': RAYS_SHADOW, 'secondary': RAYS_SECONDARY}
PACKETED = ('camera', 'shadow0')            # the kinds the renderer itself traces in packets


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def load(path: str):
    if path.lower().endswith('.xml'):
        from rtc.cli import load_scene
        return load_scene(path, quiet=True)
    from rtc.renderer.usd.stage import read_stage
    return read_stage(path)


def recorded_rays(r: Renderer, opts: RenderOptions, spp: int, cap: int) -> dict:
    """The rays of samples [0, spp) of every pixel, traced as one pass (so that the packets hold 16
    samples of one pixel, as in a long render's passes), by kind, each as float32 arrays in traced order."""
    o = resolve(opts, r.desc.settings)
    ntiles = n_tiles(o.width, o.height)
    rec = new_ray_record(ntiles, cap)
    r.run_pass(o, r.setup(o), 0, spp, np.zeros((o.height, o.width, 3)), np.zeros((ntiles, N_COUNTERS), np.int64), rec)
    rays, kind, count = rec
    if np.any(count > cap):
        print(f'  note: {int((count - cap).clip(0).sum())} rays beyond the record capacity were not recorded')
    n = np.minimum(count, cap)
    keep = np.arange(cap)[None, :] < n[:, None]
    flat, flat_kind = rays[keep], kind[keep]
    out = {}
    for name, k in KINDS.items():
        sel = flat[flat_kind == k]
        out[name] = (np.ascontiguousarray(sel[:, R_OX:R_OX + 3]), np.ascontiguousarray(sel[:, R_DX:R_DX + 3]),
                     np.ascontiguousarray(sel[:, R_TNEAR]), np.ascontiguousarray(sel[:, R_TFAR]),
                     np.ascontiguousarray(sel[:, R_TIME]))
    return out


def replay(handle: int, kind: str, rays, packets: bool, path: bool = True, masks=None, width: int = 16) -> float:
    """Seconds to trace `rays` on bare Embree (closest hit for camera/secondary, occlusion for shadow);
    path: the path integrator's rays, whose shadow rays carry its ray mask (`trace.MASK_SURFACES`: the
    light shapes in its top level occlude nothing, and its traversal skips them), as the renderer traces
    them; masks: the camera and secondary rays' masks (`embree_loops.ray_masks`: the one-sided light
    shapes a ray cannot see the emitting side of), None: every geometry; width: how many rays of a packet
    of 16 one query takes (`Renderer.packet_width`)."""
    o, d, tn, tf, tm = rays
    n = len(o)
    if n == 0:
        return 0.0
    t0 = time.perf_counter()
    if kind.startswith('shadow'):
        if packets:
            occlude_packets(handle, rays, np.empty(n, np.bool_), path, width)
        else:
            occlude_rays(handle, o, d, tn, tf, tm, np.empty(n, np.bool_), path)
    elif masks is not None:
        trace_rays_masked(handle, rays, masks, np.empty(n, np.float32), np.empty((n, 4), np.uint32),
                          width if packets else 0)
    elif packets:
        trace_packets(handle, rays, np.empty(n, np.float32), np.empty((n, 4), np.uint32), width)
    else:
        trace_rays(handle, o, d, tn, tf, tm, np.empty(n, np.float32), np.empty((n, 4), np.uint32))
    return time.perf_counter() - t0


def path_masks(r: Renderer, rays: dict) -> dict:
    """{kind: uint32 ray masks} of the recorded camera and secondary rays of a path render, as the
    renderer gives them (`embree_loops.ray_masks`)."""
    masks = {}
    for kind in ('camera', 'secondary'):
        masks[kind] = np.empty(len(rays[kind][1]), np.uint32)
        ray_masks(r.path_lights(), rays[kind][1], masks[kind])
    return masks


def warm_replays(handle: int, rays: dict, is_path: bool, masks: dict, width: int = 16) -> None:
    """Load or compile the replay kernels (a few rays of each kind, single and in packets)."""
    for packets in (False, True):
        for kind, rk in rays.items():
            m = masks.get(kind)
            replay(handle, kind, tuple(x[:64] for x in rk), packets, is_path, None if m is None else m[:64], width)


def bench_scene(path: str, a) -> dict:
    row = {'scene': Path(path).name}
    t0 = time.perf_counter()
    desc = load(path)
    row['load_s'] = time.perf_counter() - t0
    row['rss_load_mb'] = peak_rss_mb()
    opts = RenderOptions(width=a.width, height=a.height, spp=a.spp, seed=a.seed, sampler=a.sampler,
                         max_depth=a.max_depth, integrator=a.integrator, filter=a.filter)
    opts = resolve(opts, desc.settings)
    t0 = time.perf_counter()
    r = Renderer(desc, threads=a.threads)
    row['build_s'] = time.perf_counter() - t0
    row['rss_build_mb'] = peak_rss_mb()
    row['instances'] = r.built.n_instances
    t0 = time.perf_counter()
    r.render(RenderOptions(**{**opts.__dict__, 'spp': 1}))          # JIT load/compile of the kernel
    row['warmup_s'] = time.perf_counter() - t0

    rays = None if a.no_replay else recorded_rays(r, opts, a.record_spp, a.record_cap)
    is_path = opts.integrator == 'path'
    handle = r.path_scene() if is_path else r.built.handle             # what the renderer traces
    masks = path_masks(r, rays) if rays is not None and is_path else {}
    if rays is not None:
        warm_replays(handle, rays, is_path, masks, r.packet_width)
    render_s, first_s, res = [], [], None
    ratios = {'single': [], 'traced': [], 'packets': []}
    traced_s = []
    rates = {(k, p): [] for k in KINDS for p in (False, True)}
    for _ in range(a.rounds):
        res = r.render(opts)
        render_s.append(res.stats.seconds)
        first_s.append(res.stats.first_pass_seconds)
        if rays is None:
            continue
        st = res.stats
        n_of = {'camera': st.rays_camera, 'shadow0': st.rays_shadow_packet,
                'shadow': st.rays_shadow - st.rays_shadow_packet, 'secondary': st.rays_secondary}
        rate = {}
        for packets in (False, True):
            for kind, rk in rays.items():
                if len(rk[0]):
                    rate[kind, packets] = len(rk[0]) / max(replay(handle, kind, rk, packets, is_path,
                                                                  masks.get(kind), r.packet_width), 1e-12)
                    rates[kind, packets].append(rate[kind, packets])
        bare = {name: sum(n_of[k] / rate[k, p(k)] for k in KINDS if (k, False) in rate)
                for name, p in (('single', lambda k: False), ('traced', lambda k: k in PACKETED),
                                ('packets', lambda k: True))}
        for name in ratios:
            ratios[name].append(bare[name] / res.stats.seconds)
        traced_s.append(bare['traced'])
    st = res.stats
    row.update(first_pass_s=statistics.median(first_s), render_s=statistics.median(render_s),
               render_min_s=min(render_s), rays_camera=st.rays_camera, rays_shadow=st.rays_shadow,
               rays_shadow_packet=st.rays_shadow_packet, rays_secondary=st.rays_secondary, rays=st.rays,
               bad_samples=st.bad_samples, mrays_s=st.rays / statistics.median(render_s) / 1e6)
    if rays is not None:
        row.update(ratio_single=statistics.median(ratios['single']), ratio_traced=statistics.median(ratios['traced']),
                   ratio_packet=statistics.median(ratios['packets']), tracing_s=statistics.median(traced_s),
                   shading_s=statistics.median(render_s) - statistics.median(traced_s),
                   recorded={k: len(v[0]) for k, v in rays.items()},
                   bare_mrays={f'{k}{"16" if p else ""}': statistics.median(v) / 1e6
                               for (k, p), v in rates.items() if v})
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        film_mod.write_image(os.path.join(tmp, 'out.png'), res.image)
        row['output_s'] = time.perf_counter() - t0
    if a.scaling:
        sc = {1: [], 2: []}
        for _ in range(a.rounds):
            for nt in (1, 2):
                r.threads = nt
                sc[nt].append(r.render(opts).stats.seconds)
        r.threads = a.threads
        row['scaling'] = statistics.median(t1 / t2 for t1, t2 in zip(sc[1], sc[2]))
        row['render_1t_s'] = statistics.median(sc[1])
        row['render_2t_s'] = statistics.median(sc[2])
    row['rss_peak_mb'] = peak_rss_mb()
    r.close()
    return row


def report(row: dict) -> None:
    print(f"== {row['scene']}  ({row['instances']} placements)")
    print(f"  load {row['load_s']:.3f} s   build {row['build_s']:.3f} s   first call (kernel load/compile, 1 spp) "
          f"{row['warmup_s']:.2f} s   first pass {row['first_pass_s']:.3f} s   render {row['render_s']:.3f} s "
          f"(min {row['render_min_s']:.3f})   output {row['output_s']:.3f} s")
    print(f"  rays: camera {row['rays_camera']}  shadow {row['rays_shadow']} (first hit, in packets: "
          f"{row['rays_shadow_packet']})  secondary {row['rays_secondary']}  total {row['rays']}   "
          f"renderer {row['mrays_s']:.2f} Mrays/s")
    if 'ratio_single' in row:
        bare = '  '.join(f'{k} {v:.2f}' for k, v in row['bare_mrays'].items())
        print(f"  bare Embree replay (Mrays/s, recorded {row['recorded']}): {bare}")
        print(f"  tracing {row['tracing_s']:.3f} s  shading/sampling {row['shading_s']:.3f} s   "
              f"ratio renderer/bare: {row['ratio_single']:.2f} (single-ray replay)  "
              f"{row['ratio_traced']:.2f} (as traced)  {row['ratio_packet']:.2f} (packet replay)")
    if 'scaling' in row:
        print(f"  threads: 1 -> {row['render_1t_s']:.3f} s, 2 -> {row['render_2t_s']:.3f} s, "
              f"speed-up {row['scaling']:.2f}")
    print(f"  peak RSS: after load {row['rss_load_mb']:.0f} MB, after build {row['rss_build_mb']:.0f} MB, "
          f"end {row['rss_peak_mb']:.0f} MB", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('scenes', nargs='+')
    ap.add_argument('--width', type=int, default=320)
    ap.add_argument('--height', type=int, default=240)
    ap.add_argument('--spp', type=int, default=64)
    ap.add_argument('--sampler', default='sobol')
    ap.add_argument('--seed', type=int, default=7)
    ap.add_argument('--max-depth', type=int, default=4)
    ap.add_argument('--integrator', choices=['cook', 'path'], default=None, help="default: the stage's")
    ap.add_argument('--filter', default='gaussian')
    ap.add_argument('--threads', type=int, default=None)
    ap.add_argument('--rounds', type=int, default=3)
    ap.add_argument('--record-spp', type=int, default=16, help='samples per pixel recorded for the replay')
    ap.add_argument('--record-cap', type=int, default=6144, help='rays recorded per 8x8 tile at most')
    ap.add_argument('--no-replay', action='store_true')
    ap.add_argument('--scaling', action='store_true', help='also time 1 vs 2 threads')
    a = ap.parse_args(argv)
    if a.threads:
        numba.set_num_threads(a.threads)     # the replays' prange loops too: they run on the render's threads
    print(f'numba threads {a.threads or numba.config.NUMBA_NUM_THREADS}, {a.width}x{a.height}, {a.spp} spp, '
          f'sampler {a.sampler}, max depth {a.max_depth}, {a.rounds} rounds', flush=True)
    for path in a.scenes:
        report(bench_scene(path, a))
    return 0


if __name__ == '__main__':
    sys.exit(main())
