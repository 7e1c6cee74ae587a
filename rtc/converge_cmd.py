"""`rtc converge`: speed against error of the samplers on one scene (front end of rtc.renderer.host.converge).

    rtc converge scenes/gallery.xml --width 160 --max-spp 64 --seeds 4 -o benchmarks/converge/gallery

writes PREFIX.csv (one row per render: sampler, spp, seed, seconds, rmse, relmse), PREFIX.png (log-log
error against spp and against seconds, one line per sampler with its fitted slope, min/max band over
seeds) and prints a table.  Without --reference the reference image is rendered once and cached beside
the scene as `<scene>.ref-<hash>.exr` (hash of the scene file's bytes and the reference settings).
"""
from __future__ import annotations

from pathlib import Path

import click

from .exits import fail as _fail
from .renderer_params import RendererCommand, renderer_option
from .scene_input import checked_options, load_scene


@click.command('converge', cls=RendererCommand)
@click.argument('scene', type=click.Path(dir_okay=False))
@click.option('-o', '--output', 'prefix', type=click.Path(dir_okay=False),
              help='Output prefix: PREFIX.csv and PREFIX.png (default: the scene path without suffix + .converge).')
@renderer_option('--samplers', key='samplers', help='Comma-separated samplers to compare.')
@click.option('--max-spp', type=int, default=64, show_default=True, help='Largest sample count (1, 2, 4, ... up to it).')
@click.option('--min-spp', type=int, default=1, show_default=True, help='Smallest sample count.')
@click.option('--seeds', type=int, default=1, show_default=True, help='Renders per point (different seeds).')
@click.option('--reference', type=click.Path(dir_okay=False, exists=True), help='Reference image (EXR, linear).')
@click.option('--reference-spp', type=int, help='Reference samples per pixel (default 16 x max-spp).')
@click.option('--reference-seeds', type=int, default=4, show_default=True,
              help='The reference is the mean of this many renders with distinct seeds.')
@renderer_option('--reference-sampler', key='sampler')
@click.option('--no-cache', is_flag=True, help='Do not read or write the cached reference beside the scene.')
@click.option('--width', type=int, help='Image width (default: the scene render settings).')
@click.option('--height', type=int, help='Image height (default: the scene render settings; only --width '
                                          'given: keeps their aspect).')
@renderer_option('--filter', 'filter_', key='filter')
@renderer_option('--max-depth', key='max_depth', type=int)
@click.option('--threads', type=int, help='Worker threads (default: all cores).')
@click.option('--metric', type=click.Choice(['rmse', 'relmse']), default='rmse', show_default=True,
              help='Error plotted and fitted (both are always in the CSV).')
@click.option('--fit-from', type=int, default=4, show_default=True,
              help='Fit slopes over points with spp >= this (all points if fewer than two qualify).')
@click.option('-q', '--quiet', is_flag=True)
def converge_cmd(scene, prefix, samplers, max_spp, min_spp, seeds, reference, reference_spp, reference_seeds,
                 reference_sampler, no_cache, width, height, filter_, max_depth, threads, metric, fit_from, quiet):
    """Error (RMSE and relMSE against a reference) of SCENE rendered at 1, 2, 4, ... --max-spp samples
    per pixel with each sampler, against spp and against wall-clock seconds."""
    from .renderer.host import converge as C
    from .renderer.kernel.samplers import SAMPLER_NAMES
    from .renderer.host.film import FilmError, read_image

    names = [s.strip() for s in samplers.split(',') if s.strip()]
    bad = [s for s in names if s not in SAMPLER_NAMES]
    if not names or bad:
        _fail(f"--samplers: unknown sampler(s) {', '.join(bad) or '(none)'} (choose from {', '.join(SAMPLER_NAMES)})")
    if max_spp < 1 or min_spp < 1 or min_spp > max_spp or seeds < 1 or reference_seeds < 1:
        _fail('--max-spp, --min-spp, --seeds and --reference-seeds must be positive (min-spp <= max-spp)')
    ref_spp = reference_spp or 16 * max_spp
    if ref_spp < 1:
        _fail('--reference-spp must be positive')
    prefix = Path(prefix) if prefix else Path(scene).with_suffix('.converge')
    if not prefix.parent.exists():
        _fail(f'{prefix}: directory {prefix.parent} does not exist')
    log = (lambda s: None) if quiet else (lambda s: click.echo(s, err=True))

    asked = checked_options(width=width, height=height, filter=filter_, max_depth=max_depth, threads=threads)
    desc = load_scene(scene, options=asked, quiet=quiet)
    o = desc.options
    ref_img, cache = None, None
    if reference:
        try:
            ref_img = read_image(reference)
        except FilmError as e:
            _fail(str(e))
        if ref_img.shape[:2] != (o.height, o.width):
            _fail(f'{reference} is {ref_img.shape[1]}x{ref_img.shape[0]}, the render is {o.width}x{o.height}')
    elif not no_cache:
        key = C.reference_key(Path(scene).read_bytes(), o.width, o.height, ref_spp, reference_seeds,
                              reference_sampler, filter_, max_depth)
        cache = C.reference_cache_path(scene, key)

    def on_point(p):
        log(f'  {p.sampler:<12} spp {p.spp:>5} seed {p.seed}: {p.seconds:7.3f} s  RMSE {p.rmse:.4e}  '
            f'relMSE {p.relmse:.4e}')

    points, _ = C.converge(desc, samplers=names, max_spp=max_spp, min_spp=min_spp, seeds=seeds,
                           width=o.width, height=o.height, max_depth=max_depth, filter=filter_, threads=threads,
                           reference=ref_img, reference_spp=ref_spp, reference_chunks=reference_seeds,
                           reference_sampler=reference_sampler, reference_cache=cache, on_point=on_point, log=log)
    summary = C.summarize(points)
    fit = fit_from if sum(1 for s in summary if s.sampler == names[0] and s.spp >= fit_from) >= 2 else 1
    csv_path, png_path = prefix.with_name(prefix.name + '.csv'), prefix.with_name(prefix.name + '.png')
    C.write_csv(points, csv_path)
    C.plot(summary, png_path, metric=metric, fit_from=fit,
           title=f'{Path(scene).name} {o.width}x{o.height}, {seeds} seed(s), reference {ref_spp} spp')
    note = (f'{"RMSE" if metric == "rmse" else "relMSE (halved)"}; RMSE = sqrt(mean squared error over pixels '
            f'and channels, linear RGB), relMSE = mean((x-ref)^2/(ref^2+0.01)); fitted for spp >= {fit}')
    click.echo(C.format_table(summary, C.slopes(summary, metric, fit), note))
    click.echo(f'wrote {csv_path} and {png_path}')
