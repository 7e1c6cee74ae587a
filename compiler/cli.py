"""`rtc compile`: the command-line face of rtc.compiler.api (registered by rtc/cli.py).

Exit status: 0 = compiled (warnings allowed), 1 = warnings only and --strict (nothing written),
2 = errors (nothing written).  Diagnostics go to stderr, one per line, compiler style.
"""
from __future__ import annotations

import time
from pathlib import Path

import click

from . import api
from .diagnostics import CompileError, Diagnostic


@click.command("compile")
@click.argument("scene", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Output .usda, .usdc or .usd (default: SCENE's name with .usda, in the current "
                   "directory).")
@click.option("--width", type=int, help="Image width in pixels (default 512; the height's if only "
                                         "--height is given).")
@click.option("--height", type=int, help="Image height in pixels (default: the width).")
@click.option("--spp", type=int, help="Samples per pixel, stored for the renderer.")
@click.option("--focus-distance", type=float, help="Depth of field: distance to the plane in focus.")
@click.option("--lens-radius", type=float, help="Depth of field: thin-lens radius (0 = pinhole).")
@click.option("--check", is_flag=True, help="Validate the scene only; write nothing.")
@click.option("--strict", is_flag=True, help="Treat warnings as failures (exit 1, write nothing).")
@click.option("-q", "--quiet", is_flag=True, help="Print errors only.")
@click.option("-v", "--verbose", is_flag=True, help="Also print what was written.")
def compile_cmd(scene: Path, output, width, height, spp, focus_distance, lens_radius, check, strict,
                quiet, verbose):
    """Compile a course XML SCENE to OpenUSD."""
    options = dict(width=width, height=height, spp=spp, focus_distance=focus_distance,
                   lens_radius=lens_radius)
    out = output or Path.cwd() / scene.with_suffix(".usda").name
    start = time.perf_counter()
    try:
        if check:
            diagnostics = api.check(scene, **options)
            if strict and diagnostics:
                raise CompileError(diagnostics)
        else:
            diagnostics = api.compile_file(scene, out, strict=strict, **options)
    except CompileError as exc:
        _report(exc.diagnostics, quiet)
        raise SystemExit(2 if any(d.is_error for d in exc.diagnostics) else 1)
    except OSError as exc:
        click.echo(f"{exc.filename or out}: error: {exc.strerror or exc}", err=True)
        raise SystemExit(2)
    _report(diagnostics, quiet)
    if verbose:
        what = "checked" if check else f"wrote {out}"
        click.echo(f"{scene}: {what} in {time.perf_counter() - start:.2f} s "
                   f"({len(diagnostics)} warning{'s' if len(diagnostics) != 1 else ''})", err=True)


def _report(diagnostics: list[Diagnostic], quiet: bool) -> None:
    for d in diagnostics:
        if d.is_error or not quiet:
            click.echo(str(d), err=True)
