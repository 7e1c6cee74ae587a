"""The numba compilation options of every kernel function, in one place.

* `KERNEL_JIT`: the integrators' entry points (`integrator.render_tiles`, `path.render_tiles_path`),
  called by the host on every render thread at once (host/render.py): cached (on disk, see
  `rtc.renderer.__init__`), GIL-free, and without reference counting (`_nrt=False`: they allocate
  nothing - the host allocates each thread's scratch - so the scene tables cross no refcounted call).
  No numba `parallel=True`: a prange loop made numba lower and optimise every kernel function again
  inside a gufunc and its wrapper (the cook kernel's cold compile 96 -> 52 s without it, benchmarks/
  RESULTS.md, issue 12), and host threads claiming tiles from an atomic counter balance better.
* `STAGE_JIT`: the stages of an integrator that have one call site (`render_tile`, `trace_path`,
  `_direct_light`, the camera stage, ...): inlined by numba's IR inliner, so that an entry point and its
  stages are one function - typed once, optimised once by LLVM and turned into machine code once.  As
  functions of their own, each level of the call chain re-optimised and re-emitted everything LLVM had
  inlined below it (cook kernel of gallery.xml: 35.5 -> 24.3 s of cold compile).
* `JIT`: a cached, GIL-free function.
* `SHADING_JIT`: the per-sample shading functions, which receive the scene tables (`SceneData`, a
  tuple of ~27 arrays) and allocate nothing.  With numba's reference counting on, every call to such
  a function increfs and decrefs each array of the tuple with atomic instructions on cache lines
  both threads share: measured 16 % of the render time in NRT_incref/NRT_decref alone (perf,
  gallery.xml) and poor 2-thread scaling.  `_nrt=False` compiles them without reference counting.
* `INLINE_JIT`, `SHADING_INLINE_JIT`: helpers that must be inlined into their callers - small
  functions returning tuples (as calls, numba's calling convention passes results through memory and
  checks a status per call: a Sobol' 2D sample took 45 ns instead of 29) and the per-hit helpers that
  receive the scene tables (a call passes the 27-array tuple as ~190 scalar arguments; inlined, the
  time per sample outside Embree halved).  They are inlined by LLVM, not by numba: numba's IR inliner
  re-types and re-lowers a callee's body at every call site, which made one `render_tile` of ~40
  inlined helpers (every sampler and model, before kernels were specialised) 70 % of a cold compile.  Here each helper is typed, lowered and cached once, as its
  own function marked `alwaysinline`, and LLVM inlines it when its caller's module is linked and
  optimised: the same machine code after optimisation.

numba has no public option for LLVM-level inlining; `_llvm_inline` below is the hook: a numba
`inline` cost model that always declines IR inlining, whose dispatchers get their linking module's
functions marked `alwaysinline` (two numba internals wrapped: `Dispatcher.add_overload`, which sees
every compiled or cache-loaded overload, and `CPUCodeLibrary._get_module_for_linking`, which builds
the module a caller links; the attribute is in the cached bitcode too).  numba is pinned to one minor
release in pyproject.toml, and `tests/renderer/test_jit.py` checks that the attribute reaches the
linked module and that the caller calls nothing of the helper, so a numba that changes these
internals fails a test instead of silently compiling slow kernels.
"""
from numba.core import codegen as _codegen
from numba.core import dispatcher as _dispatcher


def _llvm_inline(expr, caller_info, callee_info):
    """numba `inline` cost model of the `SHADING_INLINE_JIT` functions: never inline at IR level
    (LLVM inlines them instead: see the module docstring)."""
    return False


_add_overload = _dispatcher.Dispatcher.add_overload
_module_for_linking = _codegen.CPUCodeLibrary._get_module_for_linking


def _add_overload_marked(self, cres):
    if self.targetoptions.get('inline') is _llvm_inline:
        cres.library._rtc_always_inline = True
    return _add_overload(self, cres)


def _module_for_linking_marked(self):
    if self._shared_module is not None or not getattr(self, '_rtc_always_inline', False):
        return _module_for_linking(self)
    self._ensure_finalized()
    own = [fn.name for fn in self._final_module.functions
           if not fn.is_declaration and fn.linkage == _codegen.ll.Linkage.external]
    module = _module_for_linking(self)          # cached as self._shared_module, serialised with it
    for name in own:
        module.get_function(name).add_function_attribute('alwaysinline')
    return module


_dispatcher.Dispatcher.add_overload = _add_overload_marked
_codegen.CPUCodeLibrary._get_module_for_linking = _module_for_linking_marked

JIT = dict(cache=True, nogil=True)
INLINE_JIT = dict(JIT, inline=_llvm_inline)
SHADING_JIT = dict(JIT, _nrt=False)
SHADING_INLINE_JIT = dict(SHADING_JIT, inline=_llvm_inline)
KERNEL_JIT = dict(SHADING_JIT)
STAGE_JIT = dict(SHADING_JIT, inline='always')
