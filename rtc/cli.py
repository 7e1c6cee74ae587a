"""`rtc`: the command line.  A thin layer: parse options, call the libraries, print, exit.

    rtc compile scene.xml [-o scene.usda]        course XML -> OpenUSD        (compiler/)
    rtc render  scene.usda|scene.xml -o out.exr  USD -> image                 (renderer/)
    rtc info    scene.usda                       what the renderer sees
    rtc converge scene.usda|scene.xml            speed against error

Exit status: 0 success, 1 warnings with --strict, 2 bad input or options, 130 interrupted
(the image so far is written).  The compiler and the renderer never import each other: this module
is the only place that uses both, to let `rtc render scene.xml` compile in memory.
"""
from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path

import click

EXIT_OK, EXIT_WARNINGS, EXIT_ERROR, EXIT_INTERRUPTED = 0, 1, 2, 130


@click.group(context_settings={'help_option_names': ['-h', '--help']})
@click.version_option(package_name='rtc')
def main():
    """rtc: course XML scenes -> OpenUSD -> Cook-style distribution ray tracing on Embree."""


def _fail(message: str, code: int = EXIT_ERROR):
    click.echo(f'rtc: error: {message}', err=True)
    sys.exit(code)


def load_scene(path: str, *, camera=None, width=None, height=None, spp=None, time=None, quiet=False):
    """A SceneDescription from a USD file, or from a course XML file compiled in memory."""
    from .renderer.errors import SceneError
    from .renderer.usd.stage import read_stage
    p = Path(path)
    if not p.exists():
        _fail(f'{path}: no such file')
    source = path
    if p.suffix.lower() == '.xml':
        from .compiler.api import compile_to_stage
        from .compiler.diagnostics import CompileError
        try:
            stage, diags = compile_to_stage(path, width=width, height=height, spp=spp)
        except CompileError as e:
            for d in e.diagnostics:
                click.echo(str(d), err=True)
            sys.exit(EXIT_ERROR)
        if not quiet:
            for d in diags:
                click.echo(str(d), err=True)
        source = stage
    try:
        desc = read_stage(source, time=time, camera_path=camera, width=width, height=height, spp=spp)
    except SceneError as e:
        _fail(str(e))
    if not quiet:
        for w in desc.warnings:
            click.echo(f'{path}: warning: {w}', err=True)
    return desc


class _StopFlag:
    """SIGINT / SIGTERM set a flag; the render finishes its pass, writes what it has, exits 130."""

    def __init__(self):
        self.stopped = False
        self.signal = None

    def __call__(self, signum, frame):
        if self.stopped:                        # second Ctrl-C: give up immediately
            raise KeyboardInterrupt
        self.stopped = True
        self.signal = signum
        click.echo('\nrtc: interrupted: finishing the current pass and writing the image so far...', err=True)

    def install(self):
        signal.signal(signal.SIGINT, self)
        signal.signal(signal.SIGTERM, self)


@main.command('render')
@click.argument('scene', type=click.Path(dir_okay=False))
@click.option('-o', '--output', required=True, type=click.Path(dir_okay=False),
              help='Image to write: .exr (linear float), .png/.jpg/.tif (sRGB).')
@click.option('--width', type=int, help='Image width (default: the stage render settings).')
@click.option('--height', type=int, help='Image height (default: keeps the settings aspect).')
@click.option('--spp', type=int, help='Samples per pixel (default: render settings, else 16).')
@click.option('--sampler', type=click.Choice(['independent', 'stratified', 'cmj', 'sobol']), default='sobol',
              show_default=True)
@click.option('--filter', 'filter_', type=click.Choice(['box', 'tent', 'gaussian']), default='gaussian',
              show_default=True, help='Pixel reconstruction filter.')
@click.option('--seed', type=int, default=0, show_default=True)
@click.option('--max-depth', type=int, help='Bounces (default: the stage\'s, else 8 for path, 4 for cook, '
              'the course\'s specular depth).')
@click.option('--integrator', type=click.Choice(['path', 'cook']),
              help='path: unbiased path tracing with MIS; cook: the course\'s distribution ray tracer '
              '(default: cook for scenes compiled from course XML, path for any other USD).')
@click.option('--threads', type=int, help='Worker threads (default: all cores).')
@click.option('--camera', help='USD path of the camera to render through.')
@click.option('--checkpoint', type=float, metavar='SECONDS',
              help='Write the accumulated state every SECONDS beside the output (OUTPUT.ckpt.npz).')
@click.option('--resume', is_flag=True, help='Continue from OUTPUT.ckpt.npz.')
@click.option('-q', '--quiet', is_flag=True)
def render_cmd(scene, output, width, height, spp, sampler, filter_, seed, max_depth, integrator, threads, camera,
               checkpoint, resume, quiet):
    """Render SCENE (USD, or course XML compiled in memory) to OUTPUT."""
    from .renderer.host import film as film_mod
    from .renderer.host.progress import Progress, summary_line
    from .renderer.host.render import RenderError, RenderOptions, Renderer

    out = Path(output)
    formats = {**film_mod.LINEAR_FORMATS, **film_mod.SRGB_FORMATS}
    if out.suffix.lower() not in formats:
        _fail(f"{output}: unsupported image format '{out.suffix}' (use one of {', '.join(sorted(formats))})")
    if not out.parent.exists():
        _fail(f'{output}: directory {out.parent} does not exist')
    ckpt_path = out.with_name(out.name + '.ckpt.npz')
    opts = RenderOptions(width=width, height=height, spp=spp, sampler=sampler, filter=filter_, seed=seed,
                         max_depth=max_depth, integrator=integrator, threads=threads)
    try:        # absurd command-line values fail before the scene is read (sizes from the file: below)
        RenderOptions(**{**opts.__dict__, 'width': width or 1, 'height': height or 1, 'spp': spp or 1,
                         'max_depth': 0 if max_depth is None else max_depth,
                         'integrator': integrator or 'path'}).validate()
    except RenderError as e:
        _fail(str(e))
    if checkpoint is not None and not 0 < checkpoint < float('inf'):
        _fail(f'--checkpoint must be a positive number of seconds, got {checkpoint}')
    desc = load_scene(scene, camera=camera, width=width, height=height, spp=spp, quiet=quiet)
    try:
        resolved = opts.resolved(desc.settings)
    except RenderError as e:
        _fail(str(e))
    film = None
    if resume:
        if not ckpt_path.exists():
            _fail(f'--resume: no checkpoint {ckpt_path}')
        try:
            film = film_mod.Film.from_checkpoint(ckpt_path)
        except film_mod.FilmError as e:
            _fail(str(e))
        saved = film.meta
        for k in ('sampler', 'filter', 'seed', 'max_depth', 'integrator', 'spp', 'width', 'height'):
            if k in saved and saved[k] != getattr(resolved, k):
                _fail(f'--resume: checkpoint was rendered with {k}={saved[k]}, not {getattr(resolved, k)}')
    stop = _StopFlag()
    stop.install()
    last_ckpt = [time.monotonic()]
    settings = {k: getattr(resolved, k) for k in ('sampler', 'filter', 'seed', 'max_depth', 'integrator', 'spp', 'width', 'height')}

    def save_checkpoint(res):
        res.film.meta.update(settings)
        res.film.to_checkpoint(ckpt_path)

    try:
        with Renderer(desc, threads=threads) as r:
            progress = Progress(resolved.width, resolved.height, resolved.spp, quiet=quiet)
            done = [film.spp if film else 0, 0]
            progress.update(done[0], 0)

            def on_pass(res):
                progress.update(res.film.spp - done[0], res.stats.rays - done[1])
                done[:] = [res.film.spp, res.stats.rays]
                if checkpoint and time.monotonic() - last_ckpt[0] >= checkpoint:
                    save_checkpoint(res)
                    last_ckpt[0] = time.monotonic()

            res = r.render(resolved, film=film, should_stop=lambda: stop.stopped, on_pass=on_pass)
            progress.close()
    except RenderError as e:
        _fail(str(e))
    meta = res.metadata()
    meta['rtc:scene'] = str(scene)
    try:
        film_mod.write_image(output, res.image, meta)
    except film_mod.FilmError as e:
        _fail(str(e))
    if res.interrupted or checkpoint:
        save_checkpoint(res)
    elif ckpt_path.exists() and res.film.spp >= resolved.spp:
        ckpt_path.unlink()
    if not quiet and res.stats.kernel_seconds > 2.0:
        click.echo(f'rtc: compiled the rendering kernels in {res.stats.kernel_seconds:.0f} s '
                   f'(once: later runs load them from the cache)', err=True)
    if not quiet:
        click.echo(summary_line(res.stats.seconds, res.film.spp, res.stats.rays, resolved.width, resolved.height),
                   err=True)
    if res.interrupted:
        click.echo(f'rtc: wrote {output} with {res.film.spp} of {resolved.spp} samples per pixel; '
                   f'continue with --resume', err=True)
        sys.exit(EXIT_INTERRUPTED)


@main.command('info')
@click.argument('scene', type=click.Path(dir_okay=False))
@click.option('--camera', help='USD path of the camera.')
@click.option('--time', 'time_code', type=float, help='Time code (default: the stage start time).')
def info_cmd(scene, camera, time_code):
    """Print what the renderer sees in SCENE: prototypes, instances, triangles, lights, materials."""
    from .renderer.host.info import describe
    desc = load_scene(scene, camera=camera, time=time_code, quiet=True)
    click.echo(describe(desc))


def _register_subcommands():
    """Sub-commands that live in their own modules."""
    from .compiler.cli import compile_cmd
    from .converge_cmd import converge_cmd
    main.add_command(compile_cmd)
    main.add_command(converge_cmd)


_register_subcommands()


if __name__ == '__main__':
    main()
