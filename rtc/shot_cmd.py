"""`rtc render ... --frames A:B[:STEP] | --frame T | --workers N | --scheduler ADDRESS`: shots.

`shot_options` adds those options to the render command; a render given any of them is a shot,
rendered by `rtc.renderer.host.shots` (in this process, on a local Dask cluster of N worker
processes, or on the Dask cluster at ADDRESS).  This module also gives the workers a way to read a
course XML scene (compiled in memory on each worker), which the renderer itself cannot import.
"""
from __future__ import annotations

import functools
import os
import sys
from pathlib import Path

import click

from .exits import EXIT_INTERRUPTED, fail as _fail

MAX_WORKERS = 256




def open_xml(path: str):
    """A course XML scene compiled to an in-memory stage (on a worker); SceneError if it cannot be.
    (The render options are resolved against its render settings by the reader, as for USD.)"""
    from .compiler.api import compile_to_stage
    from .compiler.diagnostics import CompileError
    from .renderer.errors import SceneError
    if not os.path.isfile(path):
        raise SceneError(f'{path}: no such file')
    try:
        stage, _ = compile_to_stage(path)
    except CompileError as e:
        raise SceneError('; '.join(str(d) for d in e.diagnostics[:3])) from None
    return stage


def shot_options(render_cmd):
    """Decorate the render command (innermost, below its click options) with the shot options."""
    @click.option('--frames', 'frames_spec', metavar='A:B[:STEP]',
                  help='Render the frames A to B (both included) every STEP; OUTPUT names them with '
                       '#### or %04d (shot.####.exr).')
    @click.option('--frame', 'frame_spec', metavar='T', help='Render the stage at time code T.')
    @click.option('--workers', type=int, metavar='N',
                  help='Render on a local Dask cluster of N worker processes.')
    @click.option('--scheduler', metavar='ADDRESS',
                  help='Render on the Dask cluster whose scheduler is at ADDRESS (tcp://host:8786).')
    @functools.wraps(render_cmd)
    def render(*args, frames_spec, frame_spec, workers, scheduler, **kw):
        if frames_spec is None and frame_spec is None and workers is None and scheduler is None:
            return render_cmd(*args, **kw)
        return render_shot(frames_spec=frames_spec, frame_spec=frame_spec, workers=workers, scheduler=scheduler,
                           **kw)
    return render


def _frames(frames_spec, frame_spec, output) -> list:
    from .renderer.host.shots.frames import check_pattern, has_placeholder, parse_frames, parse_time
    if frames_spec is not None and frame_spec is not None:
        raise _Usage('give --frames A:B or --frame T, not both')
    if frames_spec is not None:
        frames = parse_frames(frames_spec)
    elif frame_spec is not None:
        frames = [parse_time(frame_spec)]
    else:
        if has_placeholder(output):
            raise _Usage(f'{output}: names a frame number: say which frame with --frame T or --frames A:B')
        frames = [None]                     # the stage's start time code
    check_pattern(output, len(frames))
    return frames


class _Usage(Exception):
    pass


def render_shot(scene, output, camera, checkpoint, resume, quiet, frames_spec, frame_spec, workers, scheduler,
                strict=False, **asked):
    """`rtc render` with shot options: `asked` are the render options of the command line."""
    from .renderer.host import film as film_mod
    from .renderer.host.shots.frames import ShotError, output_name
    from .renderer.host.shots.run import ShotInterrupted, median, run_shot
    from .renderer.host.shots.worker import Job
    from .scene_input import checked_options
    try:
        frames = _frames(frames_spec, frame_spec, output)
    except (ShotError, _Usage) as e:
        _fail(str(e))
    if strict:
        _fail('--strict is for single renders (rtc render SCENE -o IMAGE --strict): check the scene once that '
              'way, then render the shot')
    if checkpoint is not None:
        _fail('--checkpoint is for single renders; a shot writes every frame when it is complete '
              '(re-run with --resume to skip the frames already written)')
    if workers is not None and scheduler is not None:
        _fail('give --workers N (a local cluster) or --scheduler ADDRESS (an existing one), not both')
    if workers is not None and not 1 <= workers <= MAX_WORKERS:
        _fail(f'--workers must be 1..{MAX_WORKERS}, got {workers}')
    formats = {**film_mod.LINEAR_FORMATS, **film_mod.SRGB_FORMATS}
    out = Path(output)
    if out.suffix.lower() not in formats:
        _fail(f"{output}: unsupported image format '{out.suffix}' (use one of {', '.join(sorted(formats))})")
    if not out.parent.exists():
        _fail(f'{output}: directory {out.parent} does not exist')
    opts = checked_options(**asked)               # absurd values fail before any scene is read
    # the workers read the scene: a path that exists here is sent absolute (a shared file system
    # sees it at the same place); one that does not is sent as given (the workers may see it)
    path = os.path.abspath(scene) if os.path.exists(scene) else scene
    opener = open_xml if Path(scene).suffix.lower() == '.xml' else None
    job = Job(shot='', scene=path, options=opts, opener=opener, camera=camera, threads=opts.threads)
    echo = (lambda m: None) if quiet else (lambda m: click.echo(m, err=True))
    try:
        res = run_shot(job, frames, output, workers=workers, scheduler=scheduler, resume=resume, quiet=quiet,
                       echo=echo)
    except ShotError as e:
        _fail(str(e))
    except ShotInterrupted as e:
        r = e.result
        click.echo(f'rtc: interrupted: cancelled the remaining tasks; kept {len(r.written)} finished frame(s) '
                   f'of {r.frames}; re-run with --resume to render the others', err=True)
        sys.exit(EXIT_INTERRUPTED)
    if not quiet:
        for w in res.warnings:
            click.echo(f'{scene}: warning: {w}', err=True)
        for f in res.skipped[:1]:
            click.echo(f'rtc: skipped {len(res.skipped)} frame(s) already written '
                       f'(e.g. {output_name(output, f)})', err=True)
        click.echo(f'rtc: {res.summary()}', err=True)
        if res.load_seconds:
            click.echo(f'rtc: scene per frame: read {median(res.load_seconds) * 1e3:.0f} ms, built '
                       f'{median(res.build_seconds) * 1e3:.0f} ms (median; prototype BVHs reused in '
                       f'{res.reused.get("prototypes", 0)} of {len(res.load_seconds)} reads)', err=True)
