"""Command-line options whose choices and defaults belong to the renderer (the sampler and filter
registries, `rtc.renderer.options.DEFAULTS`), read when a command that renders parses its arguments:
`rtc compile` and `rtc --help` never import the renderer (numba, about 0.8 s).

    @main.command('render', cls=RendererCommand)
    @renderer_option('--sampler', key='sampler', help='...')

The option's default is the renderer's, set with the choices (so the help shows it)."""
from __future__ import annotations

import click


def renderer_option(*decls, key: str, **kw):
    """A click option tied to the renderer's `key`: 'sampler' and 'filter' take their choices from the
    registries, 'samplers' (a comma-separated list) defaults to all samplers, any key of DEFAULTS
    defaults to its value."""
    def decorate(f):
        f = click.option(*decls, default=None, **kw)(f)
        f.__click_params__[-1].renderer_key = key
        return f
    return decorate


class RendererCommand(click.Command):
    """A command some of whose options are `renderer_option`s, filled in before parsing."""

    def parse_args(self, ctx, args):
        from .renderer.kernel.filters import FILTER_NAMES
        from .renderer.kernel.samplers import SAMPLER_NAMES
        from .renderer.options import DEFAULTS
        registries = {'sampler': SAMPLER_NAMES, 'filter': FILTER_NAMES}
        for p in self.params:
            key = getattr(p, 'renderer_key', None)
            if key in registries:
                p.type = click.Choice(list(registries[key]))
            if key == 'samplers':
                p.default, p.show_default = ','.join(SAMPLER_NAMES), True
            elif key in DEFAULTS:
                p.default, p.show_default = DEFAULTS[key], True
        return super().parse_args(ctx, args)
