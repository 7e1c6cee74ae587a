"""Where a path render's error lives: the per-pixel variance of the path integrator over seeds, split into
direct light (D = 1) and the rest (D = max depth), and, in the pixels where the direct light's variance
is worst, each light strategy's share (MIS, light samples only, BSDF samples only).

    python benchmarks/error_budget.py [--case glossy|cornell] [--width 320] [--height 240] [--spp 16] [--seeds 8]

The case's stage is `bench_mitsuba_path.py`'s (the glossy scene of the Mitsuba comparison by default).  No
reference is needed: the variance of one pixel is estimated from `--seeds` renders of `--spp` samples each
(unbiased, ddof 1), so the figures are what any reference would measure, less its own error.  Printed:

* for D = 1 and D = max depth: the relative RMSE the variance amounts to (sqrt(mean variance) / image mean,
  as `bench_mitsuba.rel_rmse`) and the share of the whole image's variance in its worst 1 % / 10 % of pixels;
* the variance that D = max depth adds to D = 1 (paths of two bounces or more: indirect light), with the same
  shares;
* in the worst 1 % of pixels of D = 1 under MIS (on the glossy scene: the gold sphere's highlight of the rect
  light), the summed variance of each strategy there and elsewhere.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_mitsuba_path import DEPTH, rtc_stage  # noqa: E402


def variance(renderer, opts, depth: int, strategy: str, seeds: int, spp: int):
    """(per-pixel variance summed over RGB, mean image) of `seeds` renders."""
    from rtc.renderer.host.render import RenderOptions
    imgs = np.array([np.asarray(renderer.render(RenderOptions(spp=spp, seed=1 + s, max_depth=depth, strategy=strategy,
                                                              **opts)).image, np.float64) for s in range(seeds)])
    return imgs.var(axis=0, ddof=1).sum(-1), imgs.mean(0)


def worst_share(v: np.ndarray, fraction: float) -> float:
    k = max(1, int(round(v.size * fraction)))
    return float(np.sort(v.ravel())[::-1][:k].sum() / max(v.sum(), 1e-300))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--case', default='glossy', choices=sorted(DEPTH))
    ap.add_argument('--width', type=int, default=320)
    ap.add_argument('--height', type=int, default=240)
    ap.add_argument('--spp', type=int, default=16)
    ap.add_argument('--seeds', type=int, default=8)
    a = ap.parse_args(argv)
    if a.seeds < 2:
        ap.error('--seeds must be at least 2 (a variance needs two renders)')
    from rtc.renderer.host.render import Renderer
    from rtc.renderer.usd.stage import read_stage
    r = Renderer(read_stage(rtc_stage(a.case, a.width, a.height), camera_path='/World/Camera'))
    opts = dict(width=a.width, height=a.height, sampler='sobol', filter='box', integrator='path')
    depth = DEPTH[a.case]
    print(f'{a.case}: {a.width}x{a.height}, {a.spp} spp, variance over {a.seeds} seeds, path, D = {depth}')
    v = {}
    for d in (1, depth):
        v[d], mean = variance(r, opts, d, 'mis', a.seeds, a.spp)
        rel = np.sqrt(v[d].sum() / 3 / v[d].size) / mean.mean()
        print(f'  D = {d}: relRMSE {rel:.4f} (mean {mean.mean():.4f}); worst 1 % of pixels {worst_share(v[d], 0.01):.0%} '
              f'of the variance, worst 10 % {worst_share(v[d], 0.1):.0%}')
    extra = np.clip(v[depth] - v[1], 0.0, None)
    print(f'  added by bounces 2..{depth}: {extra.sum() / v[depth].sum():.0%} of the variance at D = {depth}; its worst 1 % of '
          f'pixels {worst_share(extra, 0.01):.0%}, worst 10 % {worst_share(extra, 0.1):.0%}')
    worst = v[1] >= np.sort(v[1].ravel())[::-1][max(1, v[1].size // 100) - 1]
    print(f'  D = 1 in its worst 1 % of pixels ({int(worst.sum())}) / elsewhere, summed variance per strategy:')
    for s in ('mis', 'nee', 'bsdf'):
        vs = v[1] if s == 'mis' else variance(r, opts, 1, s, a.seeds, a.spp)[0]
        print(f'    {s:4s}: {vs[worst].sum():10.3f} / {vs[~worst].sum():10.3f}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
