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

import signal
import sys
import time
from pathlib import Path

import click

from .exits import EXIT_INTERRUPTED, fail as _fail
from .renderer_params import RendererCommand, renderer_option
from .scene_input import checked_options, load_scene
from .shot_cmd import shot_options

__all__ = ['main', 'load_scene', 'checked_options']


@click.group(context_settings={'help_option_names': ['-h', '--help']})
@click.version_option(package_name='rtc')
def main():
    """rtc: course XML scenes -> OpenUSD -> Cook-style distribution ray tracing on Embree."""


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


def _checkpoint_path(output: str) -> Path:
    """OUTPUT.ckpt.npz beside an output image whose format and directory are usable."""
    from .renderer.host.film import LINEAR_FORMATS, SRGB_FORMATS
    out = Path(output)
    formats = {**LINEAR_FORMATS, **SRGB_FORMATS}
    if out.suffix.lower() not in formats:
        _fail(f"{output}: unsupported image format '{out.suffix}' (use one of {', '.join(sorted(formats))})")
    if not out.parent.exists():
        _fail(f'{output}: directory {out.parent} does not exist')
    return out.with_name(out.name + '.ckpt.npz')


def _resumed_film(ckpt_path: Path, resolved):
    """The film of a checkpoint rendered with the same image-defining options as `resolved`."""
    from .renderer.host.film import Film, FilmError
    from .renderer.options import IMAGE_OPTIONS
    if not ckpt_path.exists():
        _fail(f'--resume: no checkpoint {ckpt_path}')
    try:
        film = Film.from_checkpoint(ckpt_path)
    except FilmError as e:
        _fail(str(e))
    for k in IMAGE_OPTIONS:
        if k in film.meta and film.meta[k] != getattr(resolved, k):
            _fail(f'--resume: checkpoint was rendered with {k}={film.meta[k]}, not {getattr(resolved, k)}')
    return film


@main.command('render', cls=RendererCommand)
@click.argument('scene', type=click.Path(dir_okay=False))
@click.option('-o', '--output', required=True, type=click.Path(dir_okay=False),
              help='Image to write: .exr (linear float), .png/.jpg/.tif (sRGB).')
@click.option('--width', type=int, help='Image width (default: the stage render settings; only --height '
                                         'given: keeps their aspect).')
@click.option('--height', type=int, help='Image height (default: the stage render settings; only --width '
                                          'given: keeps their aspect).')
@click.option('--spp', type=int, help='Samples per pixel (default: the stage render settings, else 16).')
@renderer_option('--sampler', key='sampler')
@renderer_option('--filter', 'filter', key='filter', help='Pixel reconstruction filter.')
@renderer_option('--seed', key='seed', type=int)
@click.option('--max-depth', type=int, help='Bounces (default: 8 for path, counted as pbrt: 1 = direct light only; '
              '4 for cook, the course\'s specular depth).')
@renderer_option('--integrator', key='integrator',
                 help='path: unbiased path tracing with MIS; cook: the course\'s distribution ray tracer '
                 '(default: cook for scenes compiled from course XML, path for any other USD).')
@click.option('--threads', type=int, help='Worker threads (default: all cores).')
@click.option('--camera', help='USD path of the camera to render through.')
@click.option('--checkpoint', type=float, metavar='SECONDS',
              help='Write the accumulated state every SECONDS beside the output (OUTPUT.ckpt.npz).')
@click.option('--resume', is_flag=True, help='Continue from OUTPUT.ckpt.npz (a shot: skip the frames already written).')
@click.option('--encoding', type=click.Choice(['srgb', 'linear']),   # renderer/options.py ENCODINGS
              help="8/16-bit outputs: sRGB, or linear values as the course's renderers write them (default: "
                   "what the stage asks for, linear for course scenes, else sRGB).")
@click.option('--strict', is_flag=True, help='Treat warnings about the scene as failures (exit 1, nothing written).')
@click.option('-q', '--quiet', is_flag=True)
@shot_options
def render_cmd(scene, output, camera, checkpoint, resume, strict, quiet, **asked):
    """Render SCENE (USD, or course XML compiled in memory) to OUTPUT."""
    # every option not named in the signature is a RenderOptions field (`asked`): a new render option
    # is a click option above and a field in renderer/options.py (docs/architecture.md)
    from .renderer.errors import RenderError
    from .renderer.host.film import FilmError, write_image
    from .renderer.host.progress import Progress, summary_line
    from .renderer.host.render import Renderer
    from .renderer.options import IMAGE_OPTIONS

    ckpt_path = _checkpoint_path(output)
    asked = checked_options(**asked)
    if checkpoint is not None and not 0 < checkpoint < float('inf'):
        _fail(f'--checkpoint must be a positive number of seconds, got {checkpoint}')
    desc = load_scene(scene, camera=camera, options=asked, quiet=quiet, strict=strict)
    resolved = desc.options
    film = _resumed_film(ckpt_path, resolved) if resume else None
    stop = _StopFlag()
    stop.install()
    last_ckpt = [time.monotonic()]
    settings = {k: getattr(resolved, k) for k in IMAGE_OPTIONS}

    def save_checkpoint(res):
        res.film.meta.update(settings)
        res.film.to_checkpoint(ckpt_path)

    try:
        with Renderer(desc, threads=resolved.threads) as r:
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
    try:
        write_image(output, res.image, {**res.metadata(), 'rtc:scene': str(scene)}, encoding=resolved.encoding,
                    warn=lambda message: None if quiet else click.echo(f'rtc: warning: {message}', err=True))
    except FilmError as e:
        _fail(str(e))
    if res.interrupted or checkpoint:
        save_checkpoint(res)
    elif ckpt_path.exists() and res.film.spp >= resolved.spp:
        ckpt_path.unlink()
    if not quiet and res.stats.kernel_seconds > 2.0:
        click.echo(f'rtc: compiled the rendering kernels for this scene\'s features in {res.stats.kernel_seconds:.0f} s '
                   f'(once: later renders that need the same features load them from the cache)', err=True)
    if not quiet:
        click.echo(summary_line(res.stats.seconds, res.film.spp, res.stats.rays, resolved.width, resolved.height),
                   err=True)
    if not quiet and res.stats.bad_samples:
        click.echo(f'rtc: warning: {res.stats.bad_samples} samples were not finite (NaN or inf) and were left out of '
                   f'their pixels', err=True)
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
