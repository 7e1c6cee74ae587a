"""Shots on Dask: what a frame costs, what a task costs, what crosses the network, what reuse saves.

    python benchmarks/bench_shot.py [--rounds 3] [--only shot,overhead,bytes,reuse,tiles,events] [--dir /tmp/bench-shot]

shot      the 24-frame shot of benchmarks/gen_shot.py (64 moving tori of 20 000 triangles, camera dolly,
          motion blur; 320x240, 8 spp): `rtc render --frames 1:24` as whole processes, one process with
          2 threads (`--threads 2`) against `--workers 2` (a local cluster, 1 thread per worker),
          alternating, median wall of --rounds; the efficiency is one-process wall / cluster wall.
overhead  a local cluster of 2 workers: no-op Dask tasks (submitted together, and one after another),
          then the same 24 tiny frames (8x6, 1 spp) in this process and on the cluster.
bytes     task arguments (pickled) and results (arrays) of whole frames, sample ranges, tiles and tiles
          x sample ranges (320x240 8 spp, and one 1280x720 frame).
reuse     read + build per frame, in this process, on two shots: one 300 000-triangle prototype x 16,
          and a 2 000-triangle prototype x 4 096 (top level dominated), with everything reused (static
          gprims kept by the stage reader, prototype BVHs kept), without the reader's reuse, and
          without either; alternating rounds.
tiles     time per pixel sample of a tile task (worker.render_tile) by tile size against the whole
          frame (worker.render_frame), in this process with 2 threads and with 1: the rule for
          plan.MIN_TILE_PIXELS; and the peak memory allocated during each task (tracemalloc).
events    what a progress report costs: Report calls on a worker (log_event), received by the client
          (subscribe_topic), and how many a shot of 24 small frames sends per task.
Then a projection for 10 and 100 machines from those figures.
"""
from __future__ import annotations

import argparse
import logging
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

from rtc.renderer.host import film as film_mod
from rtc.renderer.host.render import RenderOptions
from rtc.renderer.host.shots.run import run_shot
from rtc.renderer.host.shots.worker import Job

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))   # the repository root
from benchmarks.gen_shot import write_shot  # noqa: E402

RTC = [sys.executable, '-m', 'rtc.cli']


def med(xs):
    return statistics.median(xs) if xs else float('nan')


def _shot(d, name, **kw):
    path = os.path.join(d, name)
    if not os.path.exists(path):
        write_shot(path, **kw)
    return path


def bench_shot(d, rounds):
    path = _shot(d, 'shot24.usda', frames=24, instances=64, tris=20_000, width=320, height=240, spp=8)
    runs = {'one process, --threads 2': ['--threads', '2'], '--workers 2': ['--workers', '2']}
    walls = {k: [] for k in runs}
    notes = {}
    for r in range(rounds + 1):                       # round 0 warms the kernel cache (not counted)
        for name, extra in runs.items():
            with tempfile.TemporaryDirectory(dir=d) as out:
                t = time.perf_counter()
                p = subprocess.run([*RTC, 'render', path, '-o', os.path.join(out, 'f.####.exr'), '--frames', '1:24',
                                    *extra], capture_output=True, text=True)
                wall = time.perf_counter() - t
                if p.returncode:
                    raise SystemExit(p.stderr)
                if r:
                    walls[name].append(wall)
                    notes[name] = [ln for ln in p.stderr.splitlines() if ln.startswith('rtc: ')][-2:]
    print('## shot: 24 frames 320x240 8 spp, whole process (median of %d, s)' % rounds)
    for name in runs:
        print(f'  {name}: wall {med(walls[name]):.2f} (runs {", ".join(f"{w:.2f}" for w in walls[name])})')
        for ln in notes[name]:
            print('     ', ln)
    a, b = med(walls['one process, --threads 2']), med(walls['--workers 2'])
    print(f'  efficiency (one process / cluster): {a / b:.2f}')
    return {'one_process': a, 'cluster': b, 'notes': notes}


def _noop(i):
    return i


def bench_overhead(d, rounds):
    from distributed import Client, LocalCluster
    path = _shot(d, 'shot24.usda', frames=24, instances=64, tris=20_000, width=320, height=240, spp=8)
    out = {}
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host='127.0.0.1', dashboard_address=None,
                      silence_logs=logging.CRITICAL) as lc, Client(lc) as client:
        batch, serial = [], []
        for _ in range(rounds):
            t = time.perf_counter()
            client.gather(client.map(_noop, range(1000), pure=False))
            batch.append((time.perf_counter() - t) / 1000)
            t = time.perf_counter()
            for i in range(100):
                client.submit(_noop, i, pure=False).result()
            serial.append((time.perf_counter() - t) / 100)
        job = Job(shot='', scene=path, options=RenderOptions(width=8, height=6, spp=1))
        tiny = {'this process': [], 'cluster of 2': []}
        for _ in range(rounds):
            for name in tiny:
                with tempfile.TemporaryDirectory(dir=d) as o:
                    res = run_shot(job, list(range(1, 25)), os.path.join(o, 't.####.exr'),
                                   client=client if name != 'this process' else None)
                tiny[name].append((res.wall_seconds - res.probe_seconds) / 24)
    print('## per-task overhead (local cluster of 2 worker processes, median of %d)' % rounds)
    print(f'  no-op tasks submitted together: {med(batch) * 1e3:.2f} ms of wall per task')
    print(f'  no-op tasks one after another (submit, wait): {med(serial) * 1e3:.2f} ms per round trip')
    for name, v in tiny.items():
        print(f'  tiny frames (8x6, 1 spp: read, build, render, write) {name}: {med(v) * 1e3:.1f} ms of wall per frame')
    out.update(batch=med(batch), serial=med(serial), tiny={k: med(v) for k, v in tiny.items()})
    return out


def bench_bytes(d):
    from distributed import Client, LocalCluster
    path = _shot(d, 'shot24.usda', frames=24, instances=64, tris=20_000, width=320, height=240, spp=8)
    res = {}
    cases = (('whole frames', [1, 2], 1, 1, None),
             ('one frame in 4 sample ranges', [3], 1, 4, None),
             ('one frame in 4 tiles', [3], 4, 1, None),
             ('one frame in 4 tiles x 2 sample ranges', [3], 4, 2, None),
             ('one 1280x720 1-spp frame whole', [3], 1, 1, (1280, 720, 1)),
             ('one 1280x720 1-spp frame in 4 tiles', [3], 4, 1, (1280, 720, 1)))
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host='127.0.0.1', dashboard_address=None,
                      silence_logs=logging.CRITICAL) as lc, Client(lc) as client:
        for name, frames, tiles, split, size in cases:
            opts = RenderOptions() if size is None else RenderOptions(width=size[0], height=size[1], spp=size[2])
            job = Job(shot='', scene=path, options=opts)
            with tempfile.TemporaryDirectory(dir=d) as o:
                r = run_shot(job, frames, os.path.join(o, 'b.####.exr'), client=client, split=split, tiles=tiles)
                t = time.perf_counter()
                film_mod.write_image(os.path.join(o, 'w.exr'), np.random.default_rng(0).random((240, 320, 3)))
                write = time.perf_counter() - t
            res[name] = (med(r.bytes_to_worker), med(r.bytes_from_worker), write, sum(r.bytes_from_worker) / len(frames),
                         r.tasks / len(frames))
    print('## bytes per task (320x240, 8 spp unless said)')
    for name, (to, frm, write, per_frame, tasks) in res.items():
        print(f'  {name}: to the worker {to:.0f} B (pickled arguments), back {frm / 1e6:.3f} MB per task (arrays), '
              f'{per_frame / 1e6:.2f} MB per frame in {tasks:.0f} task(s)')
    print(f'  writing one 320x240 EXR on the client: {res["whole frames"][2] * 1e3:.1f} ms')
    return res


def bench_reuse(d, rounds):
    scenes = {'1 prototype of 300k triangles x 16': dict(instances=16, tris=300_000),
              '1 prototype of 2k triangles x 4096': dict(instances=4096, tris=2_000)}
    print('## scene per frame with and without prototype reuse (this process, 24 frames, 32x24 1 spp; '
          'median over frames and %d rounds, ms)' % rounds)
    out = {}
    for label, kw in scenes.items():
        path = _shot(d, f'reuse_{kw["instances"]}_{kw["tris"]}.usda', frames=24, width=32, height=24, spp=1, **kw)
        modes = {'reads and BVHs reused': dict(reuse=True, reuse_reads=True),
                 'BVHs reused, reads not': dict(reuse=True, reuse_reads=False),
                 'nothing reused': dict(reuse=False, reuse_reads=False)}
        got = {m: ([], [], []) for m in modes}
        for _ in range(rounds):
            for mode, kw in modes.items():
                job = Job(shot='', scene=path, options=RenderOptions(), **kw)
                with tempfile.TemporaryDirectory(dir=d) as o:
                    r = run_shot(job, list(range(1, 25)), os.path.join(o, 'r.####.exr'))
                got[mode][0].extend(r.load_seconds[1:])            # frame 1 is read and built from scratch
                got[mode][1].extend(r.build_seconds[1:])
                got[mode][2].append((r.wall_seconds - r.probe_seconds) / 23)
        for mode in modes:
            lo, bu, wa = got[mode]
            print(f'  {label}, {mode}: read {med(lo) * 1e3:.1f}, build {med(bu) * 1e3:.1f}, frame wall {med(wa) * 1e3:.1f}')
        m = out[label] = {k: tuple(med(x) for x in v) for k, v in got.items()}
        a, b, c = m['reads and BVHs reused'], m['BVHs reused, reads not'], m['nothing reused']
        print(f'  {label}: read {b[0] / a[0]:.1f}x faster with the reader\'s reuse, build {c[1] / b[1]:.1f}x faster '
              f'with BVH reuse; frame wall {c[2] / a[2]:.2f}x (all reuse against none)')
    return out


def bench_tiles(d, rounds):
    from rtc.renderer.host.shots import worker
    path = _shot(d, 'shot24.usda', frames=24, instances=64, tris=20_000, width=320, height=240, spp=8)
    w, h, spp = 512, 384, 4
    sizes = (16, 32, 64, 128)
    print(f'## tile tasks against the whole frame ({w}x{h}, {spp} spp, this process; ns per pixel sample of '
          f'the render, and of the whole task incl. its fixed costs; median of {rounds})')
    out = {}
    for threads in (2, 1):
        job = Job(shot=f'tiles{threads}', scene=path, options=RenderOptions(width=w, height=h, spp=spp), threads=threads)
        o = worker.probe(job, 1, 1)['options']
        whole, tiles = [], {n: ([], []) for n in sizes}
        for _ in range(rounds):
            r = worker.render_frame(job, 1, 1, o)
            whole.append(r['render_seconds'] / (w * h * spp))
            for n in sizes:
                x0 = (w - n) // 2 // 8 * 8                       # a tile in the middle of the frame
                box = (x0, 64, x0 + n, 64 + n)
                t = worker.render_tile(job, 1, 1, o, box, 0, spp)
                tiles[n][0].append(t['render_seconds'] / (n * n * spp))
                tiles[n][1].append(t['wall_seconds'] / (n * n * spp))
        peaks = _peaks(job, o, sizes) if threads == 2 else None
        worker.close()
        print(f'  {threads} thread(s): whole frame {med(whole) * 1e9:.0f} ns')
        for n in sizes:
            print(f'    tile {n}x{n} ({n * n // 64} kernel tiles): render {med(tiles[n][0]) * 1e9:.0f} ns '
                  f'({med(tiles[n][0]) / med(whole):.2f}x the whole frame), task {med(tiles[n][1]) * 1e9:.0f} ns')
        if peaks:
            print('  peak memory allocated during a task (tracemalloc: numpy arrays and Python objects): '
                  + ', '.join(f'{k} {v / 1e6:.2f} MB' for k, v in peaks.items()))
        out[threads] = (med(whole), {n: tuple(med(x) for x in v) for n, v in tiles.items()}, peaks)
    return out


def _peaks(job, o, sizes) -> dict:
    """Peak traced allocation of a whole-frame task and of each tile task (the worker's accumulator
    is the task's pixels: Renderer.render(window=))."""
    import tracemalloc
    from rtc.renderer.host.shots import worker
    calls = {'whole frame': lambda: worker.render_frame(job, 1, 1, o)}
    for n in sizes:
        calls[f'{n}x{n}'] = lambda n=n: worker.render_tile(job, 1, 1, o, (0, 0, n, n), 0, o.spp)
    out = {}
    for name, call in calls.items():
        tracemalloc.start()
        try:
            call()
            out[name] = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
    return out


def _report_many(n):
    from rtc.renderer.host.shots.events import Report
    rep = Report('rtc-bench-events', 'k')
    rep.interval = 0.0
    t = time.perf_counter()
    for i in range(n):
        rep(i, i)
    return (time.perf_counter() - t) / n


def bench_events(d, rounds):
    from distributed import Client, LocalCluster
    path = _shot(d, 'shot24.usda', frames=24, instances=64, tris=20_000, width=320, height=240, spp=8)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host='127.0.0.1', dashboard_address=None,
                      silence_logs=logging.CRITICAL) as lc, Client(lc) as client:
        got = []
        client.subscribe_topic('rtc-bench-events', lambda e: got.append(e))
        per = []
        for _ in range(rounds):
            per.append(client.submit(_report_many, 2000, pure=False).result())
        deadline = time.monotonic() + 30
        while len(got) < 2000 * rounds and time.monotonic() < deadline:
            time.sleep(0.05)
        job = Job(shot='', scene=path, options=RenderOptions(width=64, height=48, spp=16))
        shots = []
        for _ in range(rounds):
            with tempfile.TemporaryDirectory(dir=d) as o:
                r = run_shot(job, list(range(1, 25)), os.path.join(o, 'e.####.exr'), client=client)
            shots.append((r.events, r.tasks, (r.wall_seconds - r.probe_seconds) / 24))
    print(f'## progress events (local cluster of 2 workers, median of {rounds})')
    print(f'  one report on a worker (Worker.log_event, the task\'s own cost): {med(per) * 1e6:.1f} us; '
          f'{len(got)} of {2000 * rounds} received by the client')
    ev, tasks, wall = (med([x[i] for x in shots]) for i in range(3))
    print(f'  24 frames 64x48 16 spp on the cluster: {ev:.0f} events for {tasks:.0f} tasks, {wall * 1e3:.0f} ms of wall '
          f'per frame; reports cost {ev / tasks * med(per) * 1e3:.3f} ms per task on the workers')
    return {'per_event': med(per), 'received': len(got), 'shots': shots}


def project(shot, overhead, nbytes):
    """Wall time of F frames on M machines like this one (2 cores), from the figures above."""
    if not (shot and overhead and nbytes):
        return
    m = re.search(r'([\d.]+) s wall and ([\d.]+) s CPU per frame', ' '.join(shot['notes']['--workers 2']))
    cpu = float(m.group(2))                      # CPU seconds of one frame (1 thread)
    frame_bytes = nbytes['whole frames'][1]
    write = nbytes['whole frames'][2]
    per_task = overhead['batch']
    link = 1e9 / 8                               # 1 Gb/s into the client
    start = 10.0                                 # cluster start + probe with a warm kernel cache (measured ~6-8 s here)
    print('## projection (machines like this one: 2 cores each, 2 workers of 1 thread; 1 Gb/s into the client)')
    print(f'  inputs: {cpu:.2f} CPU s per frame, {frame_bytes / 1e6:.2f} MB per frame back, '
          f'{write * 1e3:.1f} ms to write a frame, {per_task * 1e3:.2f} ms scheduler time per task')
    for frames in (24, 2400):
        for machines in (1, 10, 100):
            workers = 2 * machines
            compute = np.ceil(frames / workers) * cpu
            client = frames * (write + frame_bytes / link + per_task)      # serial on the client
            wall = start + max(compute, client)
            print(f'  {frames} frames on {machines:3d} machines: {wall:7.1f} s (compute {compute:.1f} s, '
                  f'client {client:.1f} s, start {start:.0f} s)')


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--rounds', type=int, default=3)
    ap.add_argument('--only', default='shot,overhead,bytes,reuse,tiles,events')
    ap.add_argument('--dir', default=os.path.join(tempfile.gettempdir(), 'bench-shot'))
    a = ap.parse_args(argv)
    os.makedirs(a.dir, exist_ok=True)
    only = set(a.only.split(','))
    print(f'# bench_shot {time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}, {os.cpu_count()} cores, '
          f'load {os.getloadavg()[0]:.1f}')
    shot = bench_shot(a.dir, a.rounds) if 'shot' in only else None
    overhead = bench_overhead(a.dir, a.rounds) if 'overhead' in only else None
    nbytes = bench_bytes(a.dir) if 'bytes' in only else None
    if 'reuse' in only:
        bench_reuse(a.dir, a.rounds)
    if 'tiles' in only:
        bench_tiles(a.dir, a.rounds)
    if 'events' in only:
        bench_events(a.dir, a.rounds)
    project(shot, overhead, nbytes)


if __name__ == '__main__':
    main()
