"""rtc's renderer: USD -> two-level Embree scene -> Cook-style distribution ray tracing.

The numba kernels are cached on disk.  numba keys a cached function on its own source file only, so a
kernel whose callees (in other modules) changed would be loaded stale.  The cache therefore lives in a
directory named after a hash of every source file of this package: any edit, upgrade or checkout gets
fresh kernels, and unchanged sources reuse them across runs.  An explicit NUMBA_CACHE_DIR wins.
"""
import hashlib
import os
from pathlib import Path


def _kernel_cache_dir() -> str:
    here = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for source in sorted(here.rglob('*.py')):
        digest.update(source.relative_to(here).as_posix().encode())
        digest.update(source.read_bytes())
    base = Path(os.environ.get('XDG_CACHE_HOME') or Path.home() / '.cache') / 'rtc' / 'numba'
    return str(base / digest.hexdigest()[:16])


if not os.environ.get('NUMBA_CACHE_DIR'):
    import numba.core.config

    numba.core.config.CACHE_DIR = _kernel_cache_dir()
