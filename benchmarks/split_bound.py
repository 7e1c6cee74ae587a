"""What splitting a path after its first bounce could gain: a bound for efficiency-aware splitting and
Russian roulette of the continuation, per tile (in the spirit of Rath et al. 2022, "EARS"), computed from
the path integrator's variance by path length and its ray counts, before building anything.

    python benchmarks/split_bound.py [--case glossy|cornell] [--width 320] [--height 240] [--spp 8]
                                     [--seeds 16] [--fit 4]

The case's stage is `bench_mitsuba_path.py`'s.  Each seed is rendered twice with the same random numbers,
at D = 1 (the camera vertex's light) and at the case's depth: their difference is, sample for sample, the
light of the continuation (bounces 2..D; the camera vertex's dimensions are the same in both).  Per
pixel: VA the direct part's variance, VB the continuation's, their covariance, all per sample (variance
over seeds x spp).  A tile whose continuation is traced n times (n > 1: split, each weighted 1/n; n < 1:
roulette) has variance VA + 2 cov + VB / n (n < 1: (VB + m^2) / n - m^2, m the continuation's mean) at
cost C1 + n C2 rays per sample, C1 the camera vertex's (camera ray, light samples), C2 the continuation's
(its first BSDF ray onwards), both counted per tile from a recorded render (`ray_record`).  The n of
every tile minimises (summed variance) x (summed cost) (iterated: each tile minimises lambda V + C).
The tile factors are fitted on the first `--fit` seeds (pooled over each 8 x 8 tile) and evaluated on
the second half of the seeds: the fitted estimate would flatter itself on its own noise.  Printed:
the predicted efficiency (variance x time, base / split) with splitting only (n >= 1) and with roulette
too (n >= 1/4), and the tile factors' histogram.  What it leaves out: the fitting pass's own cost, the
split's bookkeeping, and a branch's rays costing more than the average ray (single queries).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_mitsuba_path import DEPTH, rtc_stage  # noqa: E402

FACTORS = np.array([0.25, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1, 2, 3, 4, 6, 8, 12, 16], float)


def tile_means(x: np.ndarray, tile: int) -> np.ndarray:
    """Per-tile means of a (h, w) array (edge tiles over their pixels)."""
    h, w = x.shape
    ty, tx = -(-h // tile), -(-w // tile)
    p = np.full((ty * tile, tx * tile), np.nan)
    p[:h, :w] = x
    return np.nanmean(p.reshape(ty, tile, tx, tile), axis=(1, 3))


def moments(direct: np.ndarray, cont: np.ndarray, spp: int, tile: int):
    """Per-tile (VA, VB, 2 cov, m^2) per sample, summed over RGB: from (seeds, h, w, 3) pixel means of
    `spp` samples each."""
    k = direct.shape[0]
    da, db = direct - direct.mean(0), cont - cont.mean(0)
    va = (da ** 2).sum(0).sum(-1) / (k - 1) * spp
    vb = (db ** 2).sum(0).sum(-1) / (k - 1) * spp
    cv = 2 * (da * db).sum(0).sum(-1) / (k - 1) * spp
    m2 = (cont.mean(0) ** 2).sum(-1)
    return tuple(tile_means(x, tile) for x in (va, vb, cv, m2))


def cont_variance(vb, m2, n):
    return np.where(n >= 1, vb / n, (vb + m2) / n - m2)


def allocate(mom, c1, c2, factors):
    """Per-tile factors minimising (sum V) x (sum C).  Such an allocation minimises lambda V + C tile by
    tile for lambda = (sum C) / (sum V) at the optimum, so lambda is searched on a log grid (a fixed-point
    iteration on lambda stalls on a grid of factors: a tile may need a step of 2 to see a gain)."""
    va, vb, cv, m2 = mom
    lam0 = np.sum(c1 + c2) / max(np.sum(va + cv + vb), 1e-300)
    cvar = np.array([cont_variance(vb, m2, f) for f in factors])
    cost = np.array([f * c2 for f in factors])
    best, best_n = np.inf, np.ones(va.shape)
    for lam in lam0 * np.logspace(-4, 4, 321):
        n = factors[np.argmin(lam * cvar + cost, 0)]
        f = np.sum(va + cv + cont_variance(vb, m2, n)) * np.sum(c1 + n * c2)
        if f < best:
            best, best_n = f, n
    return best_n


def evaluate(mom, c1, c2, n):
    """(efficiency base / split, variance ratio, cost ratio) of factors n on moments `mom`."""
    va, vb, cv, m2 = mom
    v0, c0 = np.sum(va + cv + vb), np.sum(c1 + c2)
    v, c = np.sum(va + cv + cont_variance(vb, m2, n)), np.sum(c1 + n * c2)
    return v0 * c0 / (v * c), v / v0, c / c0


def tile_rays(renderer, opts, depth, spp, tile_count, by_kind):
    """Rays per tile of one recorded render, and with `by_kind` its secondary rays too (else None).  The
    record counts every ray whatever its room, so only a render whose kinds are read keeps the rays."""
    from rtc.renderer.host.render import RenderOptions
    from rtc.renderer.kernel.integrator import RAYS_SECONDARY
    from rtc.renderer.kernel.ray_record import new_ray_record
    rec = new_ray_record(tile_count, 64 * spp * 8 if by_kind else 1)
    renderer.render(RenderOptions(spp=spp, seed=1, max_depth=depth, **opts), ray_record=rec)
    if not by_kind:
        return rec.count.astype(float), None
    if (rec.count > rec.kind.shape[1]).any():
        raise SystemExit('ray record too small')
    return rec.count.astype(float), (rec.kind == RAYS_SECONDARY).sum(1).astype(float)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--case', default='glossy', choices=sorted(DEPTH))
    ap.add_argument('--width', type=int, default=320)
    ap.add_argument('--height', type=int, default=240)
    ap.add_argument('--spp', type=int, default=8)
    ap.add_argument('--seeds', type=int, default=16)
    ap.add_argument('--fit', type=int, default=4)
    a = ap.parse_args(argv)
    if a.seeds < 4 or not 2 <= a.fit <= a.seeds // 2:
        ap.error('--seeds must be at least 4 and --fit between 2 and half the seeds')
    from rtc.renderer.host.render import RenderOptions, Renderer
    from rtc.renderer.kernel.tiles import TILE, n_tiles
    from rtc.renderer.usd.stage import read_stage
    r = Renderer(read_stage(rtc_stage(a.case, a.width, a.height), camera_path='/World/Camera'))
    opts = dict(width=a.width, height=a.height, sampler='sobol', filter='box', integrator='path')
    depth = DEPTH[a.case]
    imgs = {d: np.array([np.asarray(r.render(RenderOptions(spp=a.spp, seed=1 + s, max_depth=d, **opts)).image,
                                    np.float64) for s in range(a.seeds)]) for d in (1, depth)}
    cont = imgs[depth] - imgs[1]
    neg = float((cont.sum(-1) < -1e-6 * max(imgs[depth].max(), 1e-30)).mean())
    nt = n_tiles(a.width, a.height)
    all1, sec1 = tile_rays(r, opts, 1, a.spp, nt, True)
    alld, _ = tile_rays(r, opts, depth, a.spp, nt, False)
    shape = (-(-a.height // TILE), -(-a.width // TILE))
    c1 = ((all1 - sec1) / a.spp).reshape(shape)                  # rays per tile and sample
    c2 = ((alld - all1 + sec1) / a.spp).reshape(shape)
    half = a.seeds // 2
    fit = moments(imgs[1][:a.fit], cont[:a.fit], a.spp, TILE)
    held = moments(imgs[1][half:], cont[half:], a.spp, TILE)
    whole = moments(imgs[1], cont, a.spp, TILE)
    print(f'{a.case}: {a.width}x{a.height}, {a.spp} spp, {a.seeds} seeds, D = {depth}; pixels whose continuation '
          f'came out negative {neg:.1%} (0: the two depths share their first vertex\'s numbers)')
    print(f'  the continuation (bounces 2..{depth}): {whole[1].sum() / (whole[0] + whole[1] + whole[2]).sum():.0%} '
          f'of the variance; rays per sample C1 {c1.sum() / (a.width * a.height):.2f}, '
          f'C2 {c2.sum() / (a.width * a.height):.2f} (per pixel)')
    for label, lo in (('splitting only (n >= 1)', 1.0), ('splitting and roulette (n >= 1/4)', 0.25)):
        n = allocate(fit, c1, c2, FACTORS[FACTORS >= lo])
        g, vr, cr = evaluate(held, c1, c2, n)
        gs, _, _ = evaluate(fit, c1, c2, n)
        hist = ', '.join(f'{f:g}: {int((n == f).sum())}' for f in FACTORS if (n == f).any())
        print(f'  {label}: efficiency {g:.3f} on held-out seeds (variance {vr:.3f}x, rays {cr:.3f}x; '
              f'{gs:.3f} on the fitted seeds); tiles per factor {hist}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
