"""In-process A/B of two versions of the renderer's kernels by noise and time: each version renders
a reference (its own, `--ref-spp`) and then `--seeds` renders of `--spp` samples, alternating; reported
per scene: the relative RMSE (RMSE / reference mean) of the low-sample renders against the version's own reference (mean over
seeds), the median time per sample, and the efficiency ratio (relRMSE^2 x time, base / new: > 1, the new
version reaches equal error sooner).  For sampling changes that move the noise, not the converged image
(the two references' means are printed side by side: they must agree within their noise).  Like
`ab_render.py`, it runs once with each version's kernels loaded first (`--order`) and reports both.

    python benchmarks/ab_noise.py glossy.usda cornell.usda --base HEAD --integrator path --max-depth 3
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from benchmarks.ab_render import (ROOT, add_order_option, base_tree, for_renderer, import_copy, load,  # noqa: E402
                                  report_ratio, run_both_orders)


def rel_rmse(img, ref):
    """RMSE over the reference's mean (as `bench_mitsuba.py`)."""
    return float(np.sqrt(np.mean((img - ref) ** 2)) / max(ref.mean(), 1e-12))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('scenes', nargs='+')
    ap.add_argument('--base', default='HEAD')
    ap.add_argument('--width', type=int, default=320)
    ap.add_argument('--height', type=int, default=240)
    ap.add_argument('--spp', type=int, default=16)
    ap.add_argument('--ref-spp', type=int, default=1024)
    ap.add_argument('--seeds', type=int, default=4)
    ap.add_argument('--max-depth', type=int, default=3)
    ap.add_argument('--integrator', choices=['cook', 'path'], default='path')
    ap.add_argument('--threads', type=int, default=2)
    add_order_option(ap)
    a = ap.parse_args(argv)
    if a.order == 'both':
        return run_both_orders(__file__, sys.argv[1:] if argv is None else list(argv))
    from rtc.renderer.host import render as new_mod
    base_mod = import_copy(base_tree(a.base), 'rtc_ab_base')
    print(f'base {a.base} vs working tree; {a.width}x{a.height}, {a.spp} spp against {a.ref_spp} spp, '
          f'{a.integrator}, max depth {a.max_depth}, {a.threads} thread(s), {a.seeds} seeds, '
          f'{a.order} kernels loaded first', flush=True)
    for path in a.scenes:
        desc = load(path)
        out = {}
        with base_mod.Renderer(for_renderer(desc, base_mod)) as rb, new_mod.Renderer(desc) as rn:
            rs = {'base': (rb, base_mod), 'new': (rn, new_mod)}
            rs = {n: rs[n] for n in sorted(rs, key=lambda n: n != a.order)}      # its kernels load first

            def render(name, spp, seed):
                r, mod = rs[name]
                opts = mod.RenderOptions(width=a.width, height=a.height, spp=spp, seed=seed, filter='box',
                                         integrator=a.integrator, max_depth=a.max_depth, threads=a.threads)
                t = time.perf_counter()
                img = r.render(opts).image.astype(np.float64)
                return img, time.perf_counter() - t
            refs = {n: render(n, a.ref_spp, 1000)[0] for n in rs}
            errs = {n: [] for n in rs}
            times = {n: [] for n in rs}
            for seed in range(a.seeds):
                for n in rs:
                    img, dt = render(n, a.spp, seed)
                    errs[n].append(rel_rmse(img, refs[n]))
                    times[n].append(dt)
            for n in rs:
                out[n] = (float(np.mean(errs[n])), statistics.median(times[n]), float(refs[n].mean()))
        (eb, tb, mb), (en, tn, mn) = out['base'], out['new']
        print(f'{Path(path).name:16s} relRMSE base {eb:.4f} new {en:.4f} ({en / eb:.3f}x)   time base {tb:.3f} s '
              f'new {tn:.3f} s ({tn / tb:.3f}x)   efficiency base/new {eb * eb * tb / (en * en * tn):.3f}   '
              f'reference means {mb:.5f} / {mn:.5f}', flush=True)
        report_ratio(Path(path).name, 'relRMSE new/base', en / eb)
        report_ratio(Path(path).name, 'time new/base', tn / tb)
        report_ratio(Path(path).name, 'efficiency base/new', eb * eb * tb / (en * en * tn))
    return 0


if __name__ == '__main__':
    sys.exit(main())
