"""Scene input for the commands that render: a USD file, or a course XML file compiled in memory,
read with the render options the command line asks for.  Used by `rtc render` (rtc/cli.py),
`rtc converge` (rtc/converge_cmd.py) and any later command that renders; bad input exits with a
message (rtc/exits.py), never a traceback."""
from __future__ import annotations

import sys
from pathlib import Path

import click

from .exits import EXIT_ERROR, fail


def load_scene(path: str, *, camera=None, time=None, options=None, quiet=False):
    """A SceneDescription from a USD file, or from a course XML file compiled in memory (the compiler
    writes what the XML says; `options`, what the render asks for, are resolved against the stage's
    render settings by the reader, the same way for both)."""
    from .renderer.errors import RenderError, SceneError
    from .renderer.usd.stage import read_stage
    p = Path(path)
    if not p.exists():
        fail(f'{path}: no such file')
    source = path
    if p.suffix.lower() == '.xml':
        from .compiler.api import compile_to_stage
        from .compiler.diagnostics import CompileError
        try:
            stage, diags = compile_to_stage(path)
        except CompileError as e:
            for d in e.diagnostics:
                click.echo(str(d), err=True)
            sys.exit(EXIT_ERROR)
        if not quiet:
            for d in diags:
                click.echo(str(d), err=True)
        source = stage
    try:
        desc = read_stage(source, time=time, camera_path=camera, options=options)
    except (SceneError, RenderError) as e:
        fail(f'{path}: {e}' if isinstance(e, RenderError) else str(e))
    if not quiet:
        for w in desc.warnings:
            click.echo(f'{path}: warning: {w}', err=True)
    return desc


def checked_options(**asked):
    """RenderOptions of the values given on the command line, refused (exit 2) before any scene is
    read when one is out of range."""
    from .renderer.errors import RenderError
    from .renderer.options import RenderOptions, validate
    options = RenderOptions(**asked)
    try:
        validate(options)
    except RenderError as e:
        fail(str(e))
    return options


