"""The kernels' JIT options do what `rtc.renderer.kernel.jit` says: `SHADING_INLINE_JIT` helpers are compiled
once as their own functions and inlined by LLVM into their callers (a numba that changed the internals the
hook wraps would silently compile slow kernels: this fails instead)."""
import re

import numba as nb

from rtc.renderer.kernel import jit


def _pair():
    @nb.njit(**dict(jit.SHADING_INLINE_JIT, cache=False))
    def rtc_helper_mul_add(a, b):
        return a * b + 1.0

    @nb.njit(**dict(jit.SHADING_JIT, cache=False))
    def rtc_caller(x):
        s = 0.0
        for i in range(4):
            s += rtc_helper_mul_add(x, float(i))
        return s

    return rtc_helper_mul_add, rtc_caller


def test_helper_is_inlined_by_llvm_not_by_numba():
    helper, caller = _pair()
    assert caller(2.0) == sum(2.0 * i + 1.0 for i in range(4))
    # numba compiled the helper as a function of its own (IR inlining would leave it uncompiled) ...
    assert len(helper.overloads) == 1
    lib = next(iter(helper.overloads.values())).library
    linked = lib._get_module_for_linking()
    own = [fn for fn in linked.functions if not fn.is_declaration and 'rtc_helper_mul_add' in fn.name]
    assert own and all('alwaysinline' in str(fn) for fn in own if fn.name.startswith('_ZN'))
    # ... and the caller's optimised code calls nothing of it: LLVM inlined it
    ir = caller.inspect_llvm(next(iter(caller.overloads)))
    body = ir[ir.index('define'):]
    assert not re.search(r'call [^\n]*rtc_helper_mul_add', body)


def test_inline_helpers_without_the_scene_tables_are_inlined_too():
    """INLINE_JIT (helpers with reference counting on) goes through the same hook."""
    @nb.njit(**dict(jit.INLINE_JIT, cache=False))
    def rtc_small(a):
        return (a[0] * 2.0, a[1] + 1.0)

    @nb.njit(**dict(jit.JIT, cache=False))
    def rtc_user(x):
        p = rtc_small((x, x))
        return p[0] + p[1]

    assert rtc_user(3.0) == 10.0
    ir = rtc_user.inspect_llvm(next(iter(rtc_user.overloads)))
    assert not re.search(r'call [^\n]*rtc_small', ir[ir.index('define'):])
