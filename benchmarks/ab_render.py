"""In-process A/B of two versions of the renderer's kernels: the machine is shared and noisy, so two
versions are only compared by renders that alternate in one process.

    python benchmarks/ab_render.py scenes/dof.xml scenes/bunnies.xml --base HEAD --spp 8 --rounds 9
    python benchmarks/ab_render.py scenes/*.xml --base HEAD~3 --threads 1
    python benchmarks/ab_render.py scenes/gallery.xml --integrator path --max-depth 8

`--base REV` is a git revision whose `renderer/` (from `git archive`) is imported as a second package
beside the working tree's `renderer/`; `--base-tree DIR` takes a directory holding a `renderer/`
instead.  Each scene is read once (by the working tree's reader), built by both versions, and
rendered `--rounds` times by each, alternating A, B, B, A, A, B...  Reported per scene: median ns per sample
(per thread) of each, and the median of the per-round time ratios base/new (> 1: the new version is
faster), with the range.  The images of the two versions are compared: "identical" or the largest
difference (a kernel change meant to be exact must print "identical").
The version whose kernels are called first in a process is faster on its own (a fixed cost per kernel
call of the other one: `run_both_orders`), so by default the comparison runs twice, in two child processes,
once each way, and the geometric mean of the two ratios is reported (`--order base|new`: one way only).
"""
from __future__ import annotations

import argparse
import importlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def import_copy(tree: Path, name: str):
    """Import `tree/renderer` as package `name` (its kernels get their own numba cache)."""
    dst = tree.resolve() / '_ab_import'
    dst.mkdir(exist_ok=True)
    link = dst / name
    if not link.exists():
        link.symlink_to((tree / 'renderer').resolve(), target_is_directory=True)
    sys.path.insert(0, str(dst))            # the baseline's own copy, imported under another name
    layered = (tree / 'renderer' / 'host' / 'render.py').exists()      # the layout since the rtc namespace
    return importlib.import_module(name + ('.host.render' if layered else '.render'))


def base_tree(rev: str) -> Path:
    """`renderer/` of revision `rev`, extracted once per commit to a fixed place (so that its cached
    kernels are found again by the next run)."""
    sha = subprocess.run(['git', '-C', str(ROOT), 'rev-parse', rev], check=True, capture_output=True,
                         text=True).stdout.strip()
    out = Path(tempfile.gettempdir()) / 'rtc_ab' / sha
    if not (out / 'renderer').is_dir():
        archive = subprocess.run(['git', '-C', str(ROOT), 'archive', sha, 'renderer'], check=True,
                                 capture_output=True).stdout
        out.mkdir(parents=True, exist_ok=True)
        subprocess.run(['tar', '-x', '-C', str(out)], input=archive, check=True)
    return out


ORDERS = ('base', 'new')


def add_order_option(ap: argparse.ArgumentParser) -> None:
    ap.add_argument('--order', choices=('both',) + ORDERS, default='both',
                    help="whose kernels load first in the process (default both: one child process each way, "
                         "and the geometric mean of their ratios)")


def run_both_orders(script: str, argv: list[str]) -> int:
    """Run `script` twice in child processes, with `--order base` and `--order new`, echo their reports and
    print the geometric mean of the ratios they report (lines `@ratio <json [scene, name, ratio]>`).

    Why: a null A/B (2026-12-04: the working tree against a copy of itself, path, 1 thread) read 0.89-0.96x
    at 160 x 120 x 4 spp and 0.52-0.75x at 64 x 48 x 2 spp with the base's kernels loaded first, 1.05-1.09x
    and 1.27-1.87x the other way.  The cost is fixed per kernel call, not per sample: the second version's
    calls take numba's slow dispatch path (`Dispatcher._compile_for_args`, typing its ~75 argument arrays
    in Python, ~0.5 ms a call), because numba's C typeof fingerprints a tuple by its items, not its class,
    so the two versions' record namedtuples share a fingerprint whose type code is the first version's.
    One order alone biases every ratio by that much; the two orders' geometric mean cancels it (null A/B
    0.973-0.988x).  A single rtc process has one set of record classes and takes the fast path.
    """
    got: dict[tuple[str, str], list[float]] = {}
    for first in ORDERS:
        print(f'--- {first} kernels loaded first (child process)', flush=True)
        p = subprocess.run([sys.executable, script, *argv, '--order', first], capture_output=True, text=True,
                           env={**os.environ, 'RTC_AB_CHILD': '1'})
        sys.stderr.write(p.stderr)
        for line in p.stdout.splitlines():
            if line.startswith('@ratio '):
                scene, name, ratio = json.loads(line[len('@ratio '):])
                got.setdefault((scene, name), []).append(ratio)
            else:
                print(line, flush=True)
        if p.returncode:
            return p.returncode
    print('--- both orders: geometric mean of the two processes\' ratios')
    for (scene, name), rs in got.items():
        print(f'{scene:16s} {name} {float(np.exp(np.mean(np.log(rs)))):.3f}x  ({" / ".join(f"{r:.3f}" for r in rs)})')
    return 0


def report_ratio(scene: str, name: str, ratio: float) -> None:
    """A ratio for `run_both_orders` (printed only in its child processes)."""
    if os.environ.get('RTC_AB_CHILD'):
        print('@ratio ' + json.dumps([scene, name, float(ratio)]), flush=True)


def load(path: str):
    if path.lower().endswith('.xml'):
        from rtc.cli import load_scene
        return load_scene(path, quiet=True)
    from rtc.renderer.usd.stage import read_stage
    return read_stage(path)


def for_renderer(desc, render_module):
    """`desc` as the renderer of `render_module` reads it: one older than 8-bit textures kept as bytes
    (`description.BytePixels`) is given the textures' float32 values, which its kernels read as the new ones read
    the bytes (the same values, bit for bit); one that keeps bytes too, its own `BytePixels` (it tests the
    class of its own copy of the module)."""
    package = render_module.__name__.rsplit('.', 2)[0]
    own = getattr(importlib.import_module(package + '.description'), 'BytePixels', None)
    if not desc.textures:
        return desc
    from dataclasses import replace

    from rtc.renderer.description import BytePixels, float_textures
    if own is None:
        return float_textures(desc)
    if own is BytePixels:
        return desc

    def theirs(p):
        return own(p.data, p.srgb) if isinstance(p, BytePixels) else p
    return replace(desc, textures=[replace(t, pixels=theirs(t.pixels), tiles=tuple(
        None if p is None else theirs(p) for p in t.tiles)) for t in desc.textures])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('scenes', nargs='+')
    g = ap.add_mutually_exclusive_group()
    g.add_argument('--base', default='HEAD', help='git revision of the baseline (default HEAD)')
    g.add_argument('--base-tree', help='directory holding the baseline renderer/')
    ap.add_argument('--width', type=int, default=320)
    ap.add_argument('--height', type=int, default=240)
    ap.add_argument('--spp', type=int, default=8)
    ap.add_argument('--sampler', default='sobol')
    ap.add_argument('--filter', default='gaussian')
    ap.add_argument('--max-depth', type=int, default=4)
    ap.add_argument('--integrator', choices=['cook', 'path'], default='cook')
    ap.add_argument('--seed', type=int, default=7)
    ap.add_argument('--threads', type=int, default=1)
    ap.add_argument('--rounds', type=int, default=7)
    add_order_option(ap)
    a = ap.parse_args(argv)
    if a.order == 'both':
        return run_both_orders(__file__, sys.argv[1:] if argv is None else list(argv))

    tree = Path(a.base_tree) if a.base_tree else base_tree(a.base)
    base = import_copy(tree, 'rtc_ab_base')
    new = importlib.import_module('rtc.renderer.host.render')
    numba.set_num_threads(a.threads)
    print(f'base {a.base_tree or a.base} vs working tree; {a.width}x{a.height}, {a.spp} spp, {a.sampler}/{a.filter}, '
          f'{a.integrator}, max depth {a.max_depth}, {a.threads} thread(s), {a.rounds} rounds, '
          f'{a.order} kernels loaded first', flush=True)
    for path in a.scenes:
        desc = load(path)
        versions = {}
        for label, mod in sorted((('base', base), ('new', new)), key=lambda v: v[0] != a.order):
            opts = mod.RenderOptions(width=a.width, height=a.height, spp=a.spp, sampler=a.sampler, filter=a.filter,
                                     seed=a.seed, max_depth=a.max_depth, integrator=a.integrator)
            r = mod.Renderer(for_renderer(desc, mod))
            t0 = time.perf_counter()
            r.render(mod.RenderOptions(**{**opts.__dict__, 'spp': 1}))          # kernel load / compile
            versions[label] = (r, opts, time.perf_counter() - t0)
        secs = {'base': [], 'new': []}
        images = {}
        for i in range(a.rounds):
            for label in (('base', 'new') if i % 2 == 0 else ('new', 'base')):     # A B, B A: no order bias
                r, opts, _ = versions[label]
                res = r.render(opts)
                secs[label].append(res.stats.seconds)
                images[label] = res.image
        samples = a.width * a.height * a.spp
        ns = {k: statistics.median(v) * a.threads / samples * 1e9 for k, v in secs.items()}
        ratios = sorted(b / n for b, n in zip(secs['base'], secs['new']))
        diff = float(np.max(np.abs(images['base'].astype(np.float64) - images['new'])))
        same = 'identical' if np.array_equal(images['base'], images['new']) else f'max |diff| {diff:.3g}'
        print(f'{Path(path).name:16s} base {ns["base"]:7.1f} ns/sample  new {ns["new"]:7.1f} ns/sample  '
              f'speed-up {statistics.median(ratios):.3f}x (range {ratios[0]:.3f}-{ratios[-1]:.3f})  images {same}'
              f'   [first call: base {versions["base"][2]:.1f} s, new {versions["new"][2]:.1f} s]', flush=True)
        report_ratio(Path(path).name, 'time per sample', statistics.median(ratios))
        for r, _, _ in versions.values():
            r.close()
    return 0


if __name__ == '__main__':
    sys.exit(main())
