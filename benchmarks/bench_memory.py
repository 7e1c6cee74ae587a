"""Peak memory of instancing: N placements of one 100k-triangle mesh, course XML -> USD -> render.

    python benchmarks/bench_memory.py [--counts 1 100000] [--width 320 --height 240 --spp 4]

For each N the scene of `bench_compile.py` (the course dragon, or a generated 100k-triangle grid,
placed N times with translate / rotateY / scale / rotateX) is compiled to .usdc, then read, built and
rendered in a fresh process; the peak RSS of that process (`resource.getrusage`) is reported.  The
difference between N placements and one placement is the cost of the placements themselves: the
mesh is held once whatever N is.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

CHILD = r'''
import json, resource, sys, time
from rtc.renderer.usd.stage import read_stage
from rtc.renderer.host.render import Renderer, RenderOptions
def rss():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
out = {{}}
t0 = time.perf_counter(); desc = read_stage({usd!r}); out['load_s'] = time.perf_counter() - t0
out['rss_load_mb'] = rss()
t0 = time.perf_counter(); r = Renderer(desc); out['build_s'] = time.perf_counter() - t0
out['rss_build_mb'] = rss()
t0 = time.perf_counter()
res = r.render(RenderOptions(width={w}, height={h}, spp={spp}))
out['render_s'] = time.perf_counter() - t0
out['rss_peak_mb'] = rss()
out['placements'] = r.built.n_instances
out['triangles'] = desc.triangle_counts()
print(json.dumps(out))
'''


def measure(usd: Path, width: int, height: int, spp: int) -> dict:
    code = CHILD.format(repo=str(REPO), usd=str(usd), w=width, h=height, spp=spp)
    done = subprocess.run([sys.executable, '-c', code], check=True, capture_output=True, text=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    from bench_compile import mesh_file, scene_file
    from rtc.compiler import api
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--counts', type=int, nargs='+', default=[1, 100000])
    ap.add_argument('--width', type=int, default=320)
    ap.add_argument('--height', type=int, default=240)
    ap.add_argument('--spp', type=int, default=4)
    a = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        mesh = mesh_file(work)
        for n in a.counts:
            usd = work / f'placements_{n}.usdc'
            api.compile_file(scene_file(work, mesh, n), usd)
            row = measure(usd, a.width, a.height, a.spp)
            rows.append((n, row))
            print(f'{n:>8} placements: {row["triangles"][0]} unique / {row["triangles"][1]} instanced triangles, '
                  f'load {row["load_s"]:.2f} s, build {row["build_s"]:.2f} s, render {row["render_s"]:.2f} s, '
                  f'peak RSS load {row["rss_load_mb"]:.0f} MB, build {row["rss_build_mb"]:.0f} MB, '
                  f'end {row["rss_peak_mb"]:.0f} MB', flush=True)
    base = rows[0][1]['rss_peak_mb']
    for n, row in rows[1:]:
        print(f'{n} placements cost {row["rss_peak_mb"] - base:.0f} MB of peak RSS more than {rows[0][0]}')


if __name__ == '__main__':
    main()
