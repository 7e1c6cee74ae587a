"""Experiment (measured, not adopted; benchmarks/RESULTS.md, issue 12): a drop-in replacement for
renderer/kernel/jit.py in which SHADING_INLINE_JIT functions are inlined by LLVM (`alwaysinline`) instead
of numba's IR inliner.  Copy it over the kernel's jit.py in a snapshot of the tree to reproduce.
"""
from numba.core import codegen as _codegen
from numba.core import dispatcher as _dispatcher


def llvm_always_inline(expr, caller_info, callee_info):
    """numba `inline` cost model: never inline at IR level; the function is marked `alwaysinline`
    for LLVM instead (see `_mark`)."""
    return False


_orig_add_overload = _dispatcher.Dispatcher.add_overload
_orig_linking = _codegen.CPUCodeLibrary._get_module_for_linking


def _add_overload(self, cres):
    if self.targetoptions.get('inline') is llvm_always_inline:
        cres.library._rtc_always_inline = True
    return _orig_add_overload(self, cres)


def _linking(self):
    if self._shared_module is not None or not getattr(self, '_rtc_always_inline', False):
        return _orig_linking(self)
    self._ensure_finalized()
    own = [fn.name for fn in self._final_module.functions
           if not fn.is_declaration and fn.linkage == _codegen.ll.Linkage.external]
    mod = _orig_linking(self)
    for name in own:
        mod.get_function(name).add_function_attribute('alwaysinline')
    return mod


_dispatcher.Dispatcher.add_overload = _add_overload
_codegen.CPUCodeLibrary._get_module_for_linking = _linking

JIT = dict(cache=True, nogil=True)
INLINE_JIT = dict(JIT, inline='always')
SHADING_JIT = dict(JIT, _nrt=False)
SHADING_INLINE_JIT = dict(SHADING_JIT, inline=llvm_always_inline)
PARALLEL_JIT = dict(JIT, parallel=True)
