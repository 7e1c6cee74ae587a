"""First image on a fresh machine: the kernel compile of every gallery scene, cold and warm.

    python benchmarks/bench_cold_start.py                        # every scenes/*.xml, cook, 1 cold + 3 warm runs
    python benchmarks/bench_cold_start.py scenes/gallery.xml --integrators cook path --cold 3

For each scene and integrator, whole `rtc render` processes as a user runs them (the README's first
command renders scenes/gallery.xml at 480x360, 64 spp): *cold* with an empty kernel cache
(`XDG_CACHE_HOME` a new temporary directory, so every kernel the render needs is compiled, as on a
fresh machine) and *warm* (the same command again: the kernels load from that cache).  Reported: the
compile time the CLI prints ("compiled the rendering kernels ... in N s"), the process's wall and CPU
seconds, medians over the runs.  `--general` sets RTC_KERNELS=general (one kernel with every feature:
what every scene compiled before kernels were specialised).  Markdown table on stdout.
"""
from __future__ import annotations

import argparse
import os
import platform
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RTC = [sys.executable, '-m', 'rtc.cli']
COMPILED = re.compile(r'compiled the rendering kernels[^0-9]* in (\d+) s')


def run(cmd, env) -> tuple[float, float, float | None]:
    """(wall s, CPU s of the process, kernel compile s printed or None) of one command."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise SystemExit(f'{" ".join(map(str, cmd))} failed:\n{p.stderr}')
    m = COMPILED.search(p.stderr)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, float(m.group(1)) if m else None


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('scenes', nargs='*', default=sorted(str(p) for p in (ROOT / 'scenes').glob('*.xml')))
    ap.add_argument('--integrators', nargs='+', default=['cook'], choices=['cook', 'path'])
    ap.add_argument('--width', type=int, default=480)
    ap.add_argument('--height', type=int, default=360)
    ap.add_argument('--spp', type=int, default=64)
    ap.add_argument('--cold', type=int, default=1, help='cold runs per scene (each compiles from scratch)')
    ap.add_argument('--warm', type=int, default=3)
    ap.add_argument('--general', action='store_true', help='RTC_KERNELS=general: the one general kernel')
    a = ap.parse_args(argv)
    print(f'{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC, {platform.node()}, {os.cpu_count()} CPUs, '
          f'load {os.getloadavg()[0]:.1f}; {a.width}x{a.height}, {a.spp} spp; '
          f'{"general kernels" if a.general else "specialised kernels"}', flush=True)
    print('| scene | integrator | cold: compile s | cold: wall s | cold: CPU s | warm: wall s |')
    print('|---|---|---|---|---|---|')
    with tempfile.TemporaryDirectory() as out:
        for scene in a.scenes:
            for integ in a.integrators:
                cmd = RTC + ['render', scene, '-o', str(Path(out) / 'image.png'), '--width', str(a.width),
                             '--height', str(a.height), '--spp', str(a.spp), '--integrator', integ]
                colds, warms = [], []
                for _ in range(a.cold):
                    with tempfile.TemporaryDirectory() as cache:
                        env = {k: v for k, v in os.environ.items() if k != 'NUMBA_CACHE_DIR'}
                        env.update(XDG_CACHE_HOME=cache, RTC_KERNELS='general' if a.general else 'specialized')
                        colds.append(run(cmd, env))
                        warms += [run(cmd, env)[0] for _ in range(a.warm)]
                med = [statistics.median(x) for x in zip(*[(w, c, k or 0.0) for w, c, k in colds])]
                print(f'| {Path(scene).name} | {integ} | {med[2]:.0f} | {med[0]:.1f} | {med[1]:.1f} | '
                      f'{statistics.median(warms):.2f} |', flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
