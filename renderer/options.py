"""Render options, resolved in one place: what is asked for > the stage's render settings > defaults.

`RenderOptions` is both the request (None = not asked for) and, after `resolve`, the complete set a
render uses.  The command line, the stage reader (`read_stage(..., options=...)`, which fits the
camera to the resolved image size) and `Renderer.render` all call `resolve`; resolving complete
options returns them unchanged, so a course XML scene rendered directly and the same scene compiled
to USD are resolved identically.  The limits below are the only ones: the compiler checks only
that what it writes into a stage is meaningful (positive sizes); sampler and filter names are the
kernels' registries.

To add an option: a field here (None by default), its default in `DEFAULTS` (or a rule in
`resolve` if the stage can set it), a check in `validate`, and a command-line flag in rtc/cli.py
that passes it on.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Optional

from .description import RenderSettings
from .errors import RenderError
from .kernel.filters import FILTER_NAMES
from .kernel.samplers import SAMPLER_NAMES

MAX_SIDE = 65536              # pixels per side
MAX_PIXELS = 1 << 28          # 268 M pixels: refuse absurd sizes before allocating the film
MAX_SPP = 1 << 20
MAX_DEPTH = 64                # specular bounces
MAX_THREADS = 1024            # Embree starts every thread it is given (threads=100000 took 27 s)
MAX_SEED = 2 ** 32 - 1
DEFAULT_SIZE = (640, 480)     # a stage without render settings (the compiler always writes them)
DEFAULT_SPP = 16


@dataclass
class RenderOptions:
    width: Optional[int] = None
    height: Optional[int] = None         # only one side asked for: the other keeps the stage's aspect
    spp: Optional[int] = None
    sampler: Optional[str] = None
    filter: Optional[str] = None
    seed: Optional[int] = None
    max_depth: Optional[int] = None
    threads: Optional[int] = None        # None: all cores (stays None when resolved)
    pass_seconds: Optional[float] = None
    depth_of_field: Optional[bool] = None
    motion_blur: Optional[bool] = None


#: the options that determine the image (a checkpoint continues only a render with the same ones)
IMAGE_OPTIONS = ('width', 'height', 'spp', 'sampler', 'filter', 'seed', 'max_depth')

#: values of the options a stage's render settings do not set
DEFAULTS = dict(sampler='sobol', filter='gaussian', seed=0, max_depth=4, pass_seconds=1.0,
                depth_of_field=True, motion_blur=True)


def resolve(asked: Optional[RenderOptions] = None, settings: Optional[RenderSettings] = None) -> RenderOptions:
    """Complete, validated options: each value as asked, else from the stage's render settings
    (image size, samples per pixel), else the default.  Raises RenderError naming the bad value
    (and the render settings prim when the value came from the stage)."""
    asked = asked or RenderOptions()
    settings = settings or RenderSettings()
    validate(asked)
    width, height = image_size(asked.width, asked.height, settings)
    spp = asked.spp if asked.spp is not None else settings.samples_per_pixel or DEFAULT_SPP
    stage = settings.path or 'the render settings'
    if asked.width is None or asked.height is None:
        _check(_image_size_error(width, height), stage)
    if asked.spp is None:
        _check(_spp_error(spp), stage + ' rtc:samplesPerPixel')
    rest = {k: getattr(asked, k) if getattr(asked, k) is not None else v for k, v in DEFAULTS.items()}
    return replace(asked, width=int(width), height=int(height), spp=int(spp), **rest)


def image_size(width: Optional[int], height: Optional[int], settings: RenderSettings) -> tuple[int, int]:
    """(width, height): both as asked; one side asked for keeps the aspect ratio of the stage's
    resolution (--width 48 of a 640 x 480 stage is 48 x 36, not 48 x 480); none: the stage's."""
    sw, sh = (settings.width, settings.height) if settings.width and settings.height else DEFAULT_SIZE
    if width is not None and height is None:
        return width, max(1, round(width * sh / sw))
    if height is not None and width is None:
        return max(1, round(height * sw / sh)), height
    return (width, height) if width is not None else (sw, sh)


def validate(o: RenderOptions) -> None:
    """Every value that is set within its limits (unset values are not checked)."""
    for side in ('width', 'height'):
        value = getattr(o, side)
        if value is not None and not 1 <= value <= MAX_SIDE:
            _check(f'image {side} {value} is out of range (1..{MAX_SIDE})')
    if o.width is not None and o.height is not None:
        _check(_image_size_error(o.width, o.height))
    if o.spp is not None:
        _check(_spp_error(o.spp))
    if o.sampler is not None and o.sampler not in SAMPLER_NAMES:
        _check(f"unknown sampler '{o.sampler}' (choose from {', '.join(SAMPLER_NAMES)})")
    if o.filter is not None and o.filter not in FILTER_NAMES:
        _check(f"unknown filter '{o.filter}' (choose from {', '.join(FILTER_NAMES)})")
    if o.max_depth is not None and not 0 <= o.max_depth <= MAX_DEPTH:
        _check(f'max depth {o.max_depth} is out of range (0..{MAX_DEPTH})')
    if o.seed is not None and not 0 <= o.seed <= MAX_SEED:
        _check(f'seed {o.seed} is out of range (0..{MAX_SEED})')
    if o.threads is not None and not 1 <= o.threads <= MAX_THREADS:
        _check(f'threads {o.threads} is out of range (1..{MAX_THREADS})')
    if o.pass_seconds is not None and not 0 < o.pass_seconds < float('inf'):
        _check(f'pass seconds {o.pass_seconds} must be a positive number')


def _image_size_error(width: int, height: int) -> Optional[str]:
    if not (1 <= width <= MAX_SIDE and 1 <= height <= MAX_SIDE) or width * height > MAX_PIXELS:
        return f'image size {width}x{height} is out of range (each side 1..{MAX_SIDE}, at most {MAX_PIXELS} pixels)'
    return None


def _spp_error(spp: int) -> Optional[str]:
    return f'samples per pixel {spp} is out of range (1..{MAX_SPP})' if not 1 <= spp <= MAX_SPP else None


def _check(error: Optional[str], where: str = '') -> None:
    if error:
        raise RenderError(f'{where}: {error}' if where else error)

