"""Specialised kernels: an entry point compiled for one `features.Features` set.

`specialize(entry, features)` walks the kernel functions `entry` calls (the numba dispatchers named by
the globals of each function's code, transitively) and, for every function that tests a feature
constant or calls one that does, makes a twin: the same code object with a copy of its module's
globals in which the `F_*` constants hold the feature set's values and the callees are their twins,
compiled with the same options.  numba then prunes the branches of the features that are off before it
types anything (features.py).  Functions that test no feature, directly or through a callee, are
shared by every specialisation (compiled and cached once).

Caching: numba keys a cached function on its qualified name, source line and bytecode - not on the
values of its globals - so a twin's qualified name carries the feature set's key
(`render_tiles__1f2e3d4c5b`): each specialisation has cache files of its own and loads in later
processes like any cached kernel.  (The cache directory itself is keyed on the renderer's sources:
`rtc.renderer.__init__`.)

Kernel functions must call other kernel functions by plain global names (`from .x import f`, then
`f(...)`): a call through a module attribute would not be specialised (tests/renderer/test_specialize.py
checks every kernel module).
"""
from __future__ import annotations

import os
import threading
import types as pytypes

import numba
from numba.core.caching import FunctionCache
from numba.core.registry import CPUDispatcher

from .. import _kernel_cache_dir
from .features import ALL, FEATURE_NAMES, Features

_LOCK = threading.Lock()
# This package's kernel cache (`rtc.renderer`), for the twins, which are made at render time: numba's
# cache directory is one global setting, and a second copy of the renderer in the process (the A/B
# harness's baseline, `benchmarks/ab_render.py`) sets it to its own when imported.  A twin cached in
# the other copy's directory is found there again after an edit of a callee's file only (numba keys a
# cached function on its own file), and an A/B then compared a stale kernel.
_CACHE_DIR = _kernel_cache_dir()
_TWINS: dict = {}              # (id of the general dispatcher, features key) -> twin dispatcher
_DEPENDS: dict = {}            # id of a dispatcher -> whether it depends on a feature constant
SHARED = 'shared'              # the key of the twins of functions that test no feature (every specialisation's)


def _names(code) -> set:
    """Global names a code object (and the code objects nested in it) refers to."""
    out = set(code.co_names)
    for c in code.co_consts:
        if isinstance(c, pytypes.CodeType):
            out |= _names(c)
    return out


def callees(disp) -> dict:
    """{global name: dispatcher} of the kernel functions `disp`'s code calls by name."""
    g = disp.py_func.__globals__
    return {n: g[n] for n in _names(disp.py_func.__code__) if isinstance(g.get(n), CPUDispatcher)}


def depends(disp) -> bool:
    """True if `disp` or a function it calls (transitively) tests a feature constant."""
    key = id(disp)
    if key not in _DEPENDS:
        _DEPENDS[key] = False                # a guard against cycles (numba kernels are not recursive)
        names = _names(disp.py_func.__code__)
        _DEPENDS[key] = bool(names & FEATURE_NAMES) or any(depends(c) for c in callees(disp).values())
    return _DEPENDS[key]


def _twin(disp, consts: dict, key: str, entry: bool = False):
    """The twin of `disp` for feature constants `consts` named by `key` (None: a function that tests no
    feature, whose twin differs from it only in having no Python entry)."""
    tk = (id(disp), key)
    if tk in _TWINS:
        return _TWINS[tk]
    py = disp.py_func
    g = dict(py.__globals__)
    g.update(consts)
    for name, callee in callees(disp).items():
        g[name] = _twin(callee, consts, key) if depends(callee) else _twin(callee, {}, SHARED)
    fn = pytypes.FunctionType(py.__code__, g, py.__name__, py.__defaults__, py.__closure__)
    fn.__qualname__ = f'{py.__qualname__}__{key}'
    fn.__module__ = py.__module__
    fn.__doc__ = py.__doc__
    options = {k: v for k, v in disp.targetoptions.items() if k != 'nopython'}      # njit's own
    # only the entry point is called from Python: its callees need neither a CPython wrapper nor a C
    # callable wrapper, which numba would otherwise compile for each (~1/3 of a small function's compile)
    options.update(no_cfunc_wrapper=True, **({} if entry else {'no_cpython_wrapper': True}))
    twin = numba.njit(**options)(fn)
    if isinstance(disp._cache, FunctionCache):
        _enable_caching(twin)
    _TWINS[tk] = twin
    return twin


def _enable_caching(twin) -> None:
    """Cache `twin` in this package's directory (NUMBA_CACHE_DIR, when set, is every copy's)."""
    if os.environ.get('NUMBA_CACHE_DIR'):
        twin.enable_caching()
        return
    before = numba.core.config.CACHE_DIR
    numba.core.config.CACHE_DIR = _CACHE_DIR
    try:
        twin.enable_caching()
    finally:
        numba.core.config.CACHE_DIR = before


def specialize(entry, features: Features | None):
    """`entry` (a kernel dispatcher) compiled for `features`; None or `features.ALL`: `entry` itself
    (the general kernel)."""
    if features is None or features.constants() == ALL.constants():
        return entry
    with _LOCK:
        if not depends(entry):
            return entry
        return _twin(entry, features.constants(), features.key(), entry=True)
