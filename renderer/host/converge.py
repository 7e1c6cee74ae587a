"""Speed against error: convergence of each sampler towards a reference image.

A convergence study renders one scene at a sequence of sample counts (1, 2, 4, ... ``max_spp``)
with each sampler and each of K seeds, and measures every image against a reference:

* **RMSE** = sqrt(mean over pixels and channels of (x - ref)^2), linear RGB, numpy
  (`rtc.renderer.host.metrics.rmse`; absolute, dominated by bright pixels);
* **relMSE** = mean((x - ref)^2 / (ref^2 + 0.01)) (`rtc.renderer.host.metrics.rel_mse`; the usual HDR metric).

Over K seeds a point's error is the root of the *mean MSE* (an RMS over seeds, as in
/work/shared/peers-and-sampling.md) and its spread is the min/max over seeds.  The convergence rate
is the least-squares slope of log(error) against log(spp) (-0.5 for independent Monte Carlo, about
-0.75 for stratified / QMC sampling of 2D integrands with an edge) and against log(seconds).

Each point is a fresh render of exactly ``spp`` samples (stratified and CMJ samples are point sets of
size spp), timed without the scene build (`RenderStats.seconds`), after one untimed warm-up render
so that numba's cache loading is not billed to the first point.

The reference is the average of ``chunks`` renders of ``spp / chunks`` samples each with seeds that
no measured render uses (otherwise the Owen scrambles of reference and measurement would coincide
and the error would be underestimated).  Its own residual error adds ``ref_mse`` to every measured
MSE; with the default 16 x max_spp samples that is about 1/16 of the smallest measured MSE.

This module takes a `SceneDescription`; it never imports the compiler.  The command line front end
is `rtc/converge_cmd.py`.
"""
from __future__ import annotations

import csv
import hashlib
import os
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from .. import description as D
from .film import read_image, write_image
from .metrics import rel_mse, rmse
from ..kernel.samplers import SAMPLER_NAMES
from ..options import RenderOptions, resolve
from .render import Renderer

SAMPLERS = tuple(SAMPLER_NAMES)
REFERENCE_SEED_BASE = 0x5EF00000      # reference seeds: never used by measured renders (0..K-1)
CSV_COLUMNS = ('sampler', 'spp', 'seed', 'seconds', 'rmse', 'relmse')


@dataclass
class Point:
    """One measured render."""
    sampler: str
    spp: int
    seed: int
    seconds: float          # render time, scene build excluded
    rmse: float
    relmse: float


@dataclass
class Summary:
    """All seeds of one (sampler, spp)."""
    sampler: str
    spp: int
    seconds: float          # mean over seeds
    rmse: float             # sqrt(mean MSE over seeds)
    rmse_min: float
    rmse_max: float
    relmse: float           # mean over seeds
    relmse_min: float
    relmse_max: float
    seeds: int


def spp_sequence(max_spp: int, min_spp: int = 1) -> list[int]:
    """Powers of two from `min_spp` (rounded up to one) to `max_spp`, plus `max_spp` itself."""
    if max_spp < 1 or min_spp < 1 or min_spp > max_spp:
        raise ValueError(f'bad spp range {min_spp}..{max_spp}')
    out, s = [], 1
    while s < min_spp:
        s *= 2
    while s <= max_spp:
        out.append(s)
        s *= 2
    if not out or out[-1] != max_spp:
        out.append(max_spp)
    return out


def fit_slope(x, y) -> float:
    """Least-squares slope of log(y) against log(x); nan with fewer than two usable points."""
    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    ok = (x > 0) & (y > 0) & np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 2 or np.ptp(np.log(x[ok])) == 0:
        return float('nan')
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


# --------------------------------------------------------------------------- reference
def reference_key(scene_bytes: bytes, width: int, height: int, spp: int, chunks: int, sampler: str,
                  filter: str, max_depth: int, integrator: str = 'cook') -> str:
    """Hash of everything the reference image depends on (scene file content + settings)."""
    h = hashlib.sha256()
    h.update(scene_bytes)
    key = ('rtc-ref-v1', int(width), int(height), int(spp), int(chunks), sampler, filter, int(max_depth))
    h.update(repr(key if integrator == 'cook' else (*key, integrator)).encode())
    return h.hexdigest()[:16]


def reference_cache_path(scene_path, key: str) -> Path:
    """`<scene>.ref-<key>.exr` beside the scene file."""
    p = Path(scene_path)
    return p.with_name(f'{p.name}.ref-{key}.exr')


def render_reference(renderer: Renderer, base: RenderOptions, spp: int, chunks: int = 4,
                     sampler: str = 'sobol') -> np.ndarray:
    """Mean of `chunks` renders of ceil(spp / chunks) samples each with reserved seeds (float64)."""
    chunks = max(1, min(int(chunks), int(spp)))
    per = max(1, -(-int(spp) // chunks))
    acc = None
    for k in range(chunks):
        o = replace(base, spp=per, sampler=sampler, seed=REFERENCE_SEED_BASE + k)
        img = renderer.render(o).image.astype(np.float64)
        acc = img if acc is None else acc + img
    return acc / chunks


def load_or_render_reference(renderer: Renderer, base: RenderOptions, spp: int, chunks: int, sampler: str,
                             cache: Path | None, log=lambda s: None) -> np.ndarray:
    """The cached reference at `cache` if it exists and has the right size, else render and store it."""
    o = resolve(base, renderer.desc.settings)
    if cache is not None and Path(cache).exists():
        img = read_image(cache)
        if img.shape[:2] == (o.height, o.width):
            log(f'reference: {cache} (cached)')
            return img.astype(np.float64)
        log(f'reference: {cache} has the wrong size, rendering a new one')
    log(f'reference: rendering {spp} spp ({chunks} seeds, {sampler})...')
    ref = render_reference(renderer, base, spp, chunks, sampler)
    if cache is not None:
        write_image(os.fspath(cache), ref.astype(np.float32),
                    {'rtc:spp': int(spp), 'rtc:sampler': sampler, 'rtc:referenceChunks': int(chunks)})
        log(f'reference: wrote {cache}')
    return ref


# --------------------------------------------------------------------------- measurement
def measure(renderer: Renderer, reference: np.ndarray, base: RenderOptions, samplers=SAMPLERS,
            spps=(1, 2, 4, 8, 16), seeds: int = 1, on_point=None) -> list[Point]:
    """Render every (sampler, spp, seed) once and measure it against `reference` (h, w, 3)."""
    reference = np.asarray(reference, np.float64)
    o = resolve(base, renderer.desc.settings)
    if reference.shape != (o.height, o.width, 3):
        raise ValueError(f'reference is {reference.shape[1]}x{reference.shape[0]}, '
                         f'render is {o.width}x{o.height}')
    renderer.render(replace(base, spp=1, sampler=samplers[0]))   # warm-up
    points = []
    for sampler in samplers:
        for spp in spps:
            for seed in range(seeds):
                r = renderer.render(replace(base, spp=int(spp), sampler=sampler, seed=seed))
                p = Point(sampler, int(spp), seed, r.stats.seconds, rmse(r.image, reference),
                          rel_mse(r.image, reference))
                points.append(p)
                if on_point is not None:
                    on_point(p)
    return points


def summarize(points: list[Point]) -> list[Summary]:
    """Aggregate the seeds of each (sampler, spp), in first-seen sampler order and increasing spp."""
    groups: dict[tuple[str, int], list[Point]] = {}
    for p in points:
        groups.setdefault((p.sampler, p.spp), []).append(p)
    order = list(dict.fromkeys(p.sampler for p in points))
    out = []
    for (sampler, spp), ps in sorted(groups.items(), key=lambda kv: (order.index(kv[0][0]), kv[0][1])):
        r = np.array([p.rmse for p in ps])
        q = np.array([p.relmse for p in ps])
        out.append(Summary(sampler, spp, float(np.mean([p.seconds for p in ps])),
                           float(np.sqrt(np.mean(r * r))), float(r.min()), float(r.max()),
                           float(q.mean()), float(q.min()), float(q.max()), len(ps)))
    return out


def slopes(summary: list[Summary], metric: str = 'rmse', fit_from: int = 1) -> dict[str, tuple[float, float]]:
    """Per sampler: (slope against spp, slope against seconds) of `metric` over points with spp >= fit_from.
    For relMSE (a squared error) the slopes are halved so that both metrics read on the RMSE scale."""
    out = {}
    for sampler in dict.fromkeys(s.sampler for s in summary):
        rows = [s for s in summary if s.sampler == sampler and s.spp >= fit_from]
        e = np.array([getattr(s, metric) for s in rows])
        k = 0.5 if metric == 'relmse' else 1.0
        out[sampler] = (k * fit_slope([s.spp for s in rows], e), k * fit_slope([s.seconds for s in rows], e))
    return out


# --------------------------------------------------------------------------- output
def write_csv(points: list[Point], path) -> None:
    """One row per render: sampler, spp, seed, seconds, rmse, relmse."""
    with open(path, 'w', newline='') as fh:
        w = csv.DictWriter(fh, fieldnames=CSV_COLUMNS)
        w.writeheader()
        for p in points:
            d = asdict(p)
            d['seconds'] = f'{p.seconds:.6g}'
            d['rmse'] = f'{p.rmse:.6e}'
            d['relmse'] = f'{p.relmse:.6e}'
            w.writerow(d)


def read_csv(path) -> list[Point]:
    with open(path, newline='') as fh:
        return [Point(r['sampler'], int(r['spp']), int(r['seed']), float(r['seconds']), float(r['rmse']),
                      float(r['relmse'])) for r in csv.DictReader(fh)]


def format_table(summary: list[Summary], fitted: dict, metric_note: str = '') -> str:
    """Plain-text table: one row per (sampler, spp), then the fitted slopes."""
    lines = [f"{'sampler':<12}{'spp':>6}{'seconds':>10}{'RMSE':>12}{'RMSE min':>12}{'RMSE max':>12}"
             f"{'relMSE':>12}{'seeds':>6}"]
    for s in summary:
        lines.append(f'{s.sampler:<12}{s.spp:>6}{s.seconds:>10.3f}{s.rmse:>12.4e}{s.rmse_min:>12.4e}'
                     f'{s.rmse_max:>12.4e}{s.relmse:>12.4e}{s.seeds:>6}')
    lines.append('')
    lines.append('fitted log-log slopes of RMSE' + (f' ({metric_note})' if metric_note else '') + ':')
    for name, (a, b) in fitted.items():
        lines.append(f'  {name:<12} vs spp {a:+.3f}   vs seconds {b:+.3f}')
    return '\n'.join(lines)


def plot(summary: list[Summary], path, metric: str = 'rmse', fit_from: int = 1, title: str = '') -> None:
    """Two log-log panels (error vs spp, error vs seconds): per sampler the mean line, the min/max band
    over seeds and the fitted slope in the legend."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    label = {'rmse': 'RMSE (linear RGB)', 'relmse': 'relMSE, mean((x-r)^2/(r^2+0.01))'}[metric]
    fitted = slopes(summary, metric, fit_from)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4))
    for sampler in fitted:
        rows = [s for s in summary if s.sampler == sampler]
        spp = np.array([s.spp for s in rows], float)
        sec = np.array([s.seconds for s in rows], float)
        e = np.array([getattr(s, metric) for s in rows])
        lo = np.array([getattr(s, metric + '_min') for s in rows])
        hi = np.array([getattr(s, metric + '_max') for s in rows])
        a, b = fitted[sampler]
        for ax, x, k in ((axes[0], spp, a), (axes[1], sec, b)):
            line, = ax.loglog(x, e, 'o-', ms=3, label=f'{sampler} (slope {k:+.2f})')
            if any(s.seeds > 1 for s in rows):
                ax.fill_between(x, lo, hi, color=line.get_color(), alpha=0.18, lw=0)
    # guide: the Monte Carlo rate through the first point of the first sampler
    first = [s for s in summary if s.sampler == next(iter(fitted))]
    if first:
        x0, e0 = first[0].spp, getattr(first[0], metric)
        xs = np.array([x0, first[-1].spp], float)
        k = -1.0 if metric == 'relmse' else -0.5
        axes[0].loglog(xs, e0 * (xs / x0) ** k, 'k:', lw=1, label=f'spp^{k:g} (independent MC)')
    from matplotlib.ticker import NullFormatter, ScalarFormatter
    spps = sorted({s.spp for s in summary})
    axes[0].set_xticks(spps)
    axes[0].xaxis.set_major_formatter(ScalarFormatter())
    axes[0].xaxis.set_minor_formatter(NullFormatter())
    axes[0].set_xlabel('samples per pixel')
    axes[1].set_xlabel('render seconds (build excluded)')
    for ax in axes:
        ax.set_ylabel(label)
        ax.grid(True, which='both', alpha=0.3)
        ax.legend(fontsize=8)
    note = f'slopes fitted for spp >= {fit_from}' + ('; relMSE slopes halved (RMSE scale)' if metric == 'relmse' else '')
    fig.suptitle((title + '\n' if title else '') + note, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def converge(desc: D.SceneDescription, *, samplers=SAMPLERS, max_spp: int = 64, min_spp: int = 1, seeds: int = 1,
             width: int | None = None, height: int | None = None, max_depth: int | None = None,
             integrator: str | None = None, filter: str = 'gaussian',
             threads: int | None = None, reference: np.ndarray | None = None, reference_spp: int | None = None,
             reference_chunks: int = 4, reference_sampler: str = 'sobol', reference_cache: Path | None = None,
             on_point=None, log=lambda s: None) -> tuple[list[Point], np.ndarray]:
    """The whole study on one built scene: (points, reference image)."""
    base = RenderOptions(width=width, height=height, filter=filter, max_depth=max_depth, integrator=integrator,
                         threads=threads,
                         pass_seconds=1e9)
    with Renderer(desc, threads=threads) as r:
        if reference is None:
            reference = load_or_render_reference(r, base, reference_spp or 16 * max_spp, reference_chunks,
                                                 reference_sampler, reference_cache, log)
        points = measure(r, reference, base, samplers, spp_sequence(max_spp, min_spp), seeds, on_point)
    return points, reference
