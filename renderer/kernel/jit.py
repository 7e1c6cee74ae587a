"""The numba compilation options of every kernel function, in one place.

* `JIT`: a cached (on-disk, see `rtc.renderer.__init__`), GIL-free function.
* `INLINE_JIT`: also inlined into its callers at numba IR level (small helpers returning tuples:
  as separate LLVM functions numba's calling convention passes results through memory and checks a
  status per call; inlined, a Sobol' 2D sample took 29 ns instead of 45).
* `SHADING_JIT`: the per-sample shading functions, which receive the scene tables (`SceneData`, a
  tuple of ~27 arrays) and allocate nothing.  With numba's reference counting on, every call to such
  a function increfs and decrefs each array of the tuple with atomic instructions on cache lines
  both threads share: measured 16 % of the render time in NRT_incref/NRT_decref alone (perf,
  gallery.xml) and poor 2-thread scaling.  `_nrt=False` compiles them without reference counting
  (they may not create arrays); the caller (`render_pass`) owns the arrays for the whole pass.
* `SHADING_INLINE_JIT`: the per-hit helpers called from `trace_path` (surface, colors, direct,
  sample_light, ...) and `trace_path` itself: a call passes the 27-array tuple as ~190 scalar
  arguments, and inlining them halved the time per sample outside Embree (single thread,
  interleaved: quad + point light 1100 -> 520-780 ns/sample, Blinn-Phong 1120 -> 510-900) at the
  price of a longer first compile.
* `PARALLEL_JIT`: the entry points that run a numba-parallel loop.
"""
JIT = dict(cache=True, nogil=True)
INLINE_JIT = dict(JIT, inline='always')
SHADING_JIT = dict(JIT, _nrt=False)
SHADING_INLINE_JIT = dict(SHADING_JIT, inline='always')
PARALLEL_JIT = dict(JIT, parallel=True)
