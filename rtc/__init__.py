"""rtc: course XML scenes -> OpenUSD -> Cook-style distribution ray tracing on Embree.

Importing rtc registers its codeless USD schemas (schemas/plugInfo.json, generatedSchema.usda: the
applied API schemas that type and document the `rtc:` attributes) with usd-core's plugin registry,
so that the compiler can apply them and UsdValidation finds them.
"""
from pathlib import Path


def _register_schemas() -> None:
    from pxr import Plug
    here = Path(__file__).resolve().parent
    # installed: package data rtc/schemas; a source tree (editable install): ../schemas
    for folder in (here / 'schemas', here.parent / 'schemas'):
        if (folder / 'plugInfo.json').is_file():
            Plug.Registry().RegisterPlugins(str(folder))
            return
    raise ImportError(f'rtc: its USD schemas (schemas/plugInfo.json) are missing beside {here}')


_register_schemas()
